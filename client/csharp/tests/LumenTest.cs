// The C# wrapper tested for real (Mono): embedded detection on the straight-tube scene of
// client/c/examples/straight_tube_scene.h checked against the closed form, and, given a daemon
// (`local PREFIX` or `zenoh ENDPOINT`), a session through it. Exits non-zero on any mismatch.
// Built and run by tests/e2e/csharp_client.rs:
//   mcs -out:LumenTest.exe client/csharp/Lumen.cs client/csharp/tests/LumenTest.cs
//   LD_LIBRARY_PATH=target/debug mono LumenTest.exe [local PREFIX | zenoh ENDPOINT [SESSIONS] | tls ENDPOINT CA CERT KEY]
// (SESSIONS: that many sessions dropped without Dispose, then 32 disposed on another thread.)
using System;
using System.Runtime.InteropServices;
using System.Threading;
using Lumen;

static class LumenTest
{
    const int Rings = 11, Spokes = 32, Points = 7, Samples = (Points - 1) * 4 + 1;
    const double TubeR = 10, RodR = 2, Spacing = 10, Tolerance = 1e-3;
    const string Spec = "{\"bodies\":[" +
        "{\"name\":\"colon\",\"shape\":{\"tube\":{\"rings\":11,\"spokes\":32}}}," +
        "{\"name\":\"scope\",\"shape\":{\"rod\":{\"points\":7,\"radius\":[2.0]}}}]," +
        "\"pairs\":[{\"a\":\"scope\",\"b\":\"colon\",\"kind\":\"interior\"}],\"precision\":4}";

    /// The tube's rings (control point, then spokes relative to it), then the rod's points at
    /// `offset` along +y from the axis.
    static float[] State(double offset)
    {
        var s = new float[Rings * (Spokes + 1) * 3 + Points * 3];
        int p = 0;
        for (int i = 0; i < Rings; i++)
        {
            s[p++] = (float)(i * Spacing); s[p++] = 0; s[p++] = 0;
            for (int k = 0; k < Spokes; k++)
            {
                double a = 2 * Math.PI * (k + 0.5) / Spokes;
                s[p++] = 0; s[p++] = (float)(TubeR * Math.Cos(a)); s[p++] = (float)(TubeR * Math.Sin(a));
            }
        }
        for (int j = 0; j < Points; j++) { s[p++] = (float)(20 + j * Spacing); s[p++] = (float)offset; s[p++] = 0; }
        return s;
    }

    /// Mismatches of one frame's contacts against the closed form: the rod's +y side meets the
    /// 32-gon's apothem, depth = r - (R cos(pi/32) - offset), normal +y.
    static int Check(Contact[] cs, int count, double offset)
    {
        double apothem = TubeR * Math.Cos(Math.PI / Spokes), expected = RodR - (apothem - offset);
        int bad = count == (expected > 0 ? Samples : 0) ? 0 : 1;
        for (int i = 0; i < count; i++)
        {
            Contact c = cs[i];
            if (Math.Abs(c.Depth - expected) > Tolerance || Math.Abs(c.Normal.Y - 1) > Tolerance || Math.Abs(c.PointB.Y - apothem) > Tolerance ||
                c.Sample != i || c.BodyA != 1 || c.BodyB != 0 || c.SpokeB != Spokes - 1 || (c.Flags & Contact.FlagOutside) != 0)
            {
                Console.Error.WriteLine("offset {0}: contact {1}: depth {2} (expected {3}) normal {4}", offset, i, c.Depth, expected, c.Normal);
                bad++;
            }
        }
        return bad;
    }

    static int Layout()
    {
        int bad = Marshal.SizeOf(typeof(Contact)) == 88 ? 0 : 1;
        string[] fields = { "Sample", "Weight0", "PointA", "PointB", "Normal", "Depth" };
        int[] offsets = { 8, 32, 48, 60, 72, 84 };
        for (int i = 0; i < fields.Length; i++)
            if ((int)Marshal.OffsetOf(typeof(Contact), fields[i]) != offsets[i]) { Console.Error.WriteLine("{0} not at {1}", fields[i], offsets[i]); bad++; }
        Console.WriteLine("Contact: {0} bytes", Marshal.SizeOf(typeof(Contact)));
        return bad;
    }

    static int Embedded()
    {
        int bad = 0;
        using (var detector = new Detector(Spec))
        {
            foreach (double offset in new[] { 8.5, 9.0, 0.0 })
            {
                int n = detector.Detect(State(offset));
                Console.WriteLine("embedded: offset {0:F2}: {1} contacts, depth {2:F4}", offset, n, n > 0 ? detector.Contacts[0].Depth : 0);
                bad += Check(detector.Contacts, n, offset);
            }
            try { detector.Detect(new float[3]); bad++; }
            catch (LumenException e) { Console.WriteLine("short state: {0}: {1}", e.Status, e.Message); bad += e.Status == Status.BadState ? 0 : 1; }
        }
        try { new Detector("{\"bodies\":[],\"pairs\":[]}"); bad++; }
        catch (LumenException e) { Console.WriteLine("empty spec: {0}", e.Status); bad += e.Status == Status.BadSpec ? 0 : 1; }
        return bad;
    }

    static int Daemon(Client client)
    {
        int bad = 0;
        using (var session = client.Open(Spec))
        {
            Console.WriteLine("session {0}", session.Id);
            for (int k = 0; k < 20; k++)
            {
                double offset = k % 2 == 0 ? 8.5 : 9.0;
                ulong number = session.Submit(State(offset));
                Reply reply = session.Receive(2000);
                bad += reply.Frame == number && reply.Status == FrameStatus.Ok ? 0 : 1;
                bad += Check(session.Contacts, reply.Count, offset);
            }
            float[] poisoned = State(8.5);
            poisoned[Rings * (Spokes + 1) * 3 + 4] = float.NaN; // the rod's point 1, y
            session.Submit(poisoned);
            Reply r = session.Receive(2000);
            Console.WriteLine("bad frame: {0} body {1} index {2}: {3}", r.Status, r.ErrorBody, r.ErrorIndex, r.Message);
            bad += r.Status == FrameStatus.NonFinite && r.ErrorBody == 1 && r.ErrorIndex == 1 && r.Count == 0 ? 0 : 1;
            Console.WriteLine("daemon: 20 frames checked");
            // A Receive that gave up never makes the next one return that frame's late reply.
            ulong early = session.Submit(State(9.0));
            bool gaveUp = false;
            try { session.Receive(0); } catch (LumenException e) when (e.Status == Status.Timeout) { gaveUp = true; }
            System.Threading.Thread.Sleep(300);
            ulong next = session.Submit(State(8.5));
            Reply late = session.Receive(2000);
            bool newest = late.Frame == next && next == early + 1 && (!gaveUp || session.StaleReplies >= 1);
            bad += newest ? 0 : 1;
            bad += Check(session.Contacts, late.Count, 8.5);
            Console.WriteLine("after a timeout: {0}", newest ? "the newest frame's reply" : "another frame's reply");
            bad += Observed(client, session);
        }
        try { client.Open("{\"bodies\":[],\"pairs\":[]}"); bad++; }
        catch (LumenException e) { Console.WriteLine("refused: {0}", e.Status); bad += e.Status == Status.Refused ? 0 : 1; }
        return bad;
    }

    /// An observer of `session` sees its newest frame and the reply to it, bit for bit.
    static int Observed(Client client, Session session)
    {
        int bad = 0;
        using (var observer = client.Observe(session.Id))
        {
            float[] state = State(8.5);
            ulong last = 0;
            bool frame = false, reply = false;
            for (int k = 0; k < 200 && !(frame && reply); k++)
            {
                // Frames keep coming while the observer takes its place; the last one counts.
                if (!frame) { last = session.Submit(state); session.Receive(2000); }
                ObservedKind kind;
                try { kind = observer.Next(50); } catch (LumenException e) when (e.Status == Status.Timeout) { continue; }
                if (kind == ObservedKind.Frame && observer.FrameNumber == last)
                {
                    frame = true;
                    for (int i = 0; i < state.Length; i++) if (observer.State[i] != state[i]) { bad++; break; }
                }
                if (kind == ObservedKind.Contacts && frame && observer.Reply.Frame == last)
                {
                    reply = true;
                    bad += Check(observer.Contacts, observer.Reply.Count, 8.5);
                }
            }
            bad += frame && reply ? 0 : 1;
            Console.WriteLine("observer: {0}", frame && reply ? "the newest frame and its reply" : "missed them");
        }
        return bad;
    }

    /// Opens a session, drops it without Dispose and lets it go.
    static void OpenAndDrop(Client client)
    {
        client.Open(Spec).Submit(State(8.5));
    }

    /// Sessions nobody disposes are closed by their finalizers, and Dispose on another thread
    /// closes a session (a frame from that thread is WrongThread for a local session, taken for
    /// a zenoh one): `count` sessions dropped (finalizers run every 8) and 32 disposed from
    /// a thread of their own, against a daemon that serves at most 16 at once: past the 16th,
    /// an open succeeds only if the earlier sessions were closed.
    static int Lifetimes(Client client, int count, bool local)
    {
        int bad = 0;
        try
        {
            for (int k = 0; k < count; k++)
            {
                OpenAndDrop(client);
                if (k % 8 == 7) { GC.Collect(); GC.WaitForPendingFinalizers(); }
            }
            Console.WriteLine("finalized: {0} sessions", count);
        }
        catch (LumenException e) { Console.Error.WriteLine("finalizers: {0}", e.Message); bad++; }
        try
        {
            for (int k = 0; k < 32; k++)
            {
                var s = client.Open(Spec);
                Exception thrown = null;
                Status? submitted = null;
                var t = new Thread(() =>
                {
                    // A frame from another thread: a local session says WrongThread, a zenoh one takes it.
                    try { s.Submit(State(8.5)); submitted = Status.Ok; } catch (LumenException e) { submitted = e.Status; }
                    try { s.Dispose(); s.Dispose(); } catch (Exception e) { thrown = e; }
                });
                t.Start();
                t.Join();
                if (thrown != null) { Console.Error.WriteLine("Dispose on another thread: {0}", thrown.Message); bad++; break; }
                if (submitted != (local ? Status.WrongThread : Status.Ok)) { Console.Error.WriteLine("a frame from another thread: {0}", submitted); bad++; break; }
                try { s.Submit(State(8.5)); bad++; } catch (ObjectDisposedException) { }
            }
            Console.WriteLine("disposed elsewhere: 32 sessions");
        }
        catch (LumenException e) { Console.Error.WriteLine("Dispose on another thread: {0}", e.Message); bad++; }
        return bad;
    }

    static int Main(string[] args)
    {
        int bad = Layout() + Embedded();
        if (args.Length >= 2)
        {
            using (Client client = args[0] == "local" ? Client.Local(args[1], "LumenTest.cs")
                : args[0] == "tls" ? Client.ZenohTls(args[1], args[2], args[3], args[4], "LumenTest.cs")
                : Client.Zenoh(args[1], "LumenTest.cs"))
            {
                bad += Daemon(client);
                if (args.Length == 3 && args[0] != "tls") bad += Lifetimes(client, int.Parse(args[2]), args[0] == "local");
            }
        }
        if (bad > 0) { Console.Error.WriteLine("{0} mismatches", bad); return 1; }
        Console.WriteLine("ok");
        return 0;
    }
}
