// Lumen from C# (Unity, Mono, .NET): P/Invoke declarations over the C library liblumen_c
// (client/c, header lumen.h) and a small wrapper: IDisposable handles, float arrays for the
// frame, the 88-byte Contact record. Written for Unity's scripting runtime: no unsafe code,
// nothing newer than .NET Standard 2.0. See client/csharp/README.md.
using System;
using System.Runtime.InteropServices;
using System.Text;

namespace Lumen
{
    /// <summary>What a call did (lumen.h's LumenStatus). Every failure raises a
    /// <see cref="LumenException"/> carrying it and the library's message.</summary>
    public enum Status
    {
        Ok = 0, NullArgument = 1, BadUtf8 = 2, BadSpec = 3, BadState = 4, Panic = 5, BadHandle = 6,
        WrongThread = 7, NoDaemon = 8, Refused = 9, Timeout = 10, Disconnected = 11, NoFrame = 12,
        SessionEnded = 13, Transport = 14, Protocol = 15,
    }

    /// <summary>What the daemon made of one frame (the reply header's status).</summary>
    public enum FrameStatus : ushort
    {
        Ok = 0, Malformed = 1, BadVersion = 2, BadSession = 3, BadLength = 4, BadCounts = 5,
        NonFinite = 6, NotStarShaped = 7, Internal = 8, OutOfRange = 9, NoBase = 10, BadDelta = 11,
    }

    /// <summary>A call into Lumen failed: <see cref="Status"/> says which way, the message what
    /// to do. <c>Disconnected</c>: keep submitting, the session reopens by itself.</summary>
    public class LumenException : Exception
    {
        public readonly Status Status;
        public LumenException(Status status, string message) : base(message) { Status = status; }
    }

    /// <summary>Three floats, laid out as in C (Unity: <c>new Vector3(v.X, v.Y, v.Z)</c>).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct Vec3
    {
        public float X, Y, Z;
        public override string ToString() { return string.Format("({0}, {1}, {2})", X, Y, Z); }
    }

    /// <summary>One contact, proto's 88-byte wire record field for field (proto/README.md).
    /// <c>Normal</c> points from the rod towards the wall; <c>Depth</c> &gt; 0 is penetration,
    /// in the scene's unit; separating moves the rod by -Depth * Normal.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct Contact
    {
        public ushort Pair;
        public byte Kind;          // 0 interior, 1 exterior, 2 self
        public byte Flags;         // 1 not star-shaped, 2 sample outside the wall, 4 another wall
        public ushort BodyA, BodyB;
        public uint Sample, SegmentA;
        public float ParamA;
        public uint IndexB, SpokeB;
        public float ParamB;
        public float Weight0, Weight1, Weight2, Weight3;
        public Vec3 PointA, PointB, Normal;
        public float Depth;

        public const int Size = 88;
        public const byte FlagOutside = 2;
    }

    /// <summary>lumen.h's functions, as P/Invoke declarations, and what the wrapper shares.</summary>
    internal static class Native
    {
        const string Lib = "lumen_c"; // liblumen_c.so / lumen_c.dll / liblumen_c.dylib

        [DllImport(Lib)] internal static extern UIntPtr lumen_last_error(byte[] buf, UIntPtr len);
        [DllImport(Lib)] internal static extern Status lumen_detector_new(byte[] spec, UIntPtr len, out IntPtr detector);
        [DllImport(Lib)] internal static extern Status lumen_detector_free(IntPtr detector);
        [DllImport(Lib)] internal static extern Status lumen_detector_floats(IntPtr detector, out UIntPtr floats);
        [DllImport(Lib)] internal static extern Status lumen_detector_detect(IntPtr detector, float[] state, UIntPtr len, out IntPtr contacts, out UIntPtr count);
        [DllImport(Lib)] internal static extern Status lumen_client_local(byte[] prefix, byte[] name, out IntPtr client);
        [DllImport(Lib)] internal static extern Status lumen_client_zenoh(byte[] endpoint, IntPtr tls, byte[] name, out IntPtr client);
        [DllImport(Lib)] internal static extern Status lumen_client_free(IntPtr client);
        [DllImport(Lib)] internal static extern Status lumen_session_open(IntPtr client, byte[] spec, UIntPtr len, out IntPtr session);
        [DllImport(Lib)] internal static extern Status lumen_session_id(IntPtr session, out ulong id);
        [DllImport(Lib)] internal static extern Status lumen_session_reconnects(IntPtr session, out ulong reconnects);
        [DllImport(Lib)] internal static extern Status lumen_session_stale_replies(IntPtr session, out ulong stale);
        [DllImport(Lib)] internal static extern Status lumen_session_frame(IntPtr session, out IntPtr frame, out UIntPtr floats);
        [DllImport(Lib)] internal static extern Status lumen_session_submit(IntPtr session, out ulong frameNumber);
        [DllImport(Lib)] internal static extern Status lumen_session_contacts(IntPtr session, uint timeoutMs, out NativeReply reply);
        [DllImport(Lib)] internal static extern Status lumen_session_close(IntPtr session);
        [DllImport(Lib)] internal static extern Status lumen_observer_open(IntPtr client, ulong session, out IntPtr observer);
        [DllImport(Lib)] internal static extern Status lumen_observer_next(IntPtr observer, uint timeoutMs, out NativeObserved seen);
        [DllImport(Lib)] internal static extern Status lumen_observer_free(IntPtr observer);

        [StructLayout(LayoutKind.Sequential)]
        internal struct NativeObserved { public int Kind; public IntPtr Frame; public IntPtr State; public UIntPtr Floats; public NativeReply Reply; }

        [StructLayout(LayoutKind.Sequential)]
        internal struct NativeTls { public IntPtr RootCa; public IntPtr Certificate; public IntPtr PrivateKey; }

        /// <summary>A copy of <paramref name="s"/> as UTF-8 with a NUL in unmanaged memory
        /// (IntPtr.Zero for null); free it with Marshal.FreeHGlobal.</summary>
        internal static IntPtr Unmanaged(string s)
        {
            if (s == null) return IntPtr.Zero;
            byte[] bytes = CString(s);
            IntPtr p = Marshal.AllocHGlobal(bytes.Length);
            Marshal.Copy(bytes, 0, p, bytes.Length);
            return p;
        }

        /// <summary>A reply's header fields and its contacts (copied into <paramref name="contacts"/>).</summary>
        internal static Reply ReadReply(NativeReply r, ref Contact[] contacts)
        {
            var reply = new Reply
            {
                Frame = (ulong)Marshal.ReadInt64(r.Header, 16),
                Status = (FrameStatus)(ushort)Marshal.ReadInt16(r.Header, 6),
                DetectNs = (uint)Marshal.ReadInt32(r.Header, 32),
                Skipped = (uint)Marshal.ReadInt32(r.Header, 40),
                ErrorBody = (uint)Marshal.ReadInt32(r.Header, 44),
                ErrorIndex = (uint)Marshal.ReadInt32(r.Header, 48),
                ErrorSpoke = (uint)Marshal.ReadInt32(r.Header, 52),
            };
            if (reply.Status != FrameStatus.Ok)
            {
                int len = (ushort)Marshal.ReadInt16(r.Header, 56);
                var text = new byte[len];
                Marshal.Copy(new IntPtr(r.Header.ToInt64() + 60), text, 0, len);
                reply.Message = Encoding.UTF8.GetString(text);
            }
            reply.Count = CopyContacts(r.Contacts, (ulong)r.Count, ref contacts);
            return reply;
        }

        [StructLayout(LayoutKind.Sequential)]
        internal struct NativeReply { public IntPtr Header; public IntPtr Contacts; public UIntPtr Count; }

        /// <summary>UTF-8 with a terminating NUL; null stays null (the C side's "not given").</summary>
        internal static byte[] CString(string s)
        {
            if (s == null) return null;
            byte[] bytes = Encoding.UTF8.GetBytes(s);
            Array.Resize(ref bytes, bytes.Length + 1);
            return bytes;
        }

        /// <summary>Raises the last error of this thread unless <paramref name="status"/> is Ok.</summary>
        internal static void Check(Status status, string what)
        {
            if (status == Status.Ok) return;
            var buf = new byte[1024];
            ulong needed = (ulong)lumen_last_error(buf, (UIntPtr)buf.Length);
            int n = (int)Math.Min(needed, (ulong)buf.Length) - 1;
            throw new LumenException(status, what + ": " + Encoding.UTF8.GetString(buf, 0, Math.Max(n, 0)));
        }

        /// <summary>Copies <paramref name="count"/> contacts at <paramref name="ptr"/> into
        /// <paramref name="into"/> (grown when too small); returns the count.</summary>
        internal static int CopyContacts(IntPtr ptr, ulong count, ref Contact[] into)
        {
            int n = (int)count;
            if (into == null || into.Length < n) into = new Contact[Math.Max(n, 16)];
            for (int i = 0; i < n; i++)
                into[i] = (Contact)Marshal.PtrToStructure(new IntPtr(ptr.ToInt64() + (long)i * Contact.Size), typeof(Contact));
            return n;
        }
    }

    /// <summary>A handle lumen.h made, freed exactly once by its free function: by
    /// <c>Dispose</c>, or by the garbage collector's finalizer when it was dropped undisposed (an
    /// exception after opening, a domain reload). Any thread may free lumen's handles, the
    /// finalizer's included; the status of the free is kept in <see cref="Released"/>.</summary>
    internal abstract class LumenHandle : SafeHandle
    {
        protected LumenHandle() : base(IntPtr.Zero, true) { }
        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }
        /// <summary>The status of the free function, once it ran.</summary>
        internal Status Released = Status.Ok;
        internal void Take(IntPtr h) { SetHandle(h); }
        /// <summary>The pointer for a call; throws ObjectDisposedException once freed.</summary>
        internal IntPtr Live(string what)
        {
            if (IsClosed || IsInvalid) throw new ObjectDisposedException(what);
            return handle;
        }
        protected abstract Status Free(IntPtr h);
        protected override bool ReleaseHandle()
        {
            Released = Free(handle);
            // The C side freed the handle whatever the status (a session it could not close on
            // the daemon is still released): never retried.
            return true;
        }
        /// <summary>Frees it now on this thread; throws what the free function reported.</summary>
        internal void Free(string what)
        {
            if (IsClosed || IsInvalid) return;
            Dispose();
            Native.Check(Released, what);
        }
    }

    internal sealed class DetectorHandle : LumenHandle { protected override Status Free(IntPtr h) { return Native.lumen_detector_free(h); } }
    internal sealed class ClientHandle : LumenHandle { protected override Status Free(IntPtr h) { return Native.lumen_client_free(h); } }
    internal sealed class SessionHandle : LumenHandle { protected override Status Free(IntPtr h) { return Native.lumen_session_close(h); } }
    internal sealed class ObserverHandle : LumenHandle { protected override Status Free(IntPtr h) { return Native.lumen_observer_free(h); } }

    /// <summary>Embedded detection, no daemon: one scene, one state per frame, in order.
    /// One thread at a time per detector.</summary>
    public sealed class Detector : IDisposable
    {
        readonly DetectorHandle handle = new DetectorHandle();
        Contact[] contacts = new Contact[16];

        /// <summary>A detector for the scene spec (JSON, proto/README.md). Throws
        /// <see cref="LumenException"/> (BadSpec) naming what is wrong.</summary>
        public Detector(string specJson)
        {
            byte[] spec = Encoding.UTF8.GetBytes(specJson);
            IntPtr h;
            Native.Check(Native.lumen_detector_new(spec, (UIntPtr)spec.Length, out h), "lumen_detector_new");
            handle.Take(h);
            UIntPtr n;
            Native.Check(Native.lumen_detector_floats(h, out n), "lumen_detector_floats");
            Floats = (int)n;
        }

        /// <summary>The number of floats of one frame's state.</summary>
        public readonly int Floats;

        /// <summary>One frame: fills <see cref="Contacts"/> and returns how many there are.</summary>
        public int Detect(float[] state)
        {
            IntPtr ptr; UIntPtr count;
            Native.Check(Native.lumen_detector_detect(Live(), state, (UIntPtr)state.Length, out ptr, out count), "lumen_detector_detect");
            return Native.CopyContacts(ptr, (ulong)count, ref contacts);
        }

        /// <summary>The last frame's contacts (the first <c>Detect</c>'s return value of them);
        /// the array is reused by the next frame.</summary>
        public Contact[] Contacts { get { return contacts; } }

        IntPtr Live() { return handle.Live("Detector"); }

        /// <summary>Frees the detector (idempotent; a dropped one is freed by its finalizer).</summary>
        public void Dispose() { handle.Free("lumen_detector_free"); }
    }

    /// <summary>A connection to the daemon (<c>lumen serve</c>). A local (iceoryx2) client and
    /// its sessions send frames from the thread that made it (Unity: the main thread; other
    /// threads get WrongThread), but any thread may Dispose them, the finalizer's included.
    /// A zenoh client and its sessions may be used from any thread, one call at a time.</summary>
    public sealed class Client : IDisposable
    {
        readonly ClientHandle handle = new ClientHandle();
        Client(IntPtr h) { handle.Take(h); }

        /// <summary>The daemon on this machine, over shared memory; <paramref name="prefix"/>
        /// must be the daemon's <c>--prefix</c> (null: LUMEN_IOX2_PREFIX, else the default).</summary>
        public static Client Local(string prefix = null, string name = null)
        {
            IntPtr h;
            Native.Check(Native.lumen_client_local(Native.CString(prefix), Native.CString(name), out h), "lumen_client_local");
            return new Client(h);
        }

        /// <summary>The daemon at a zenoh endpoint such as <c>tcp/127.0.0.1:7447</c>; a plain endpoint on another machine is refused unless the environment has <c>LUMEN_ZENOH_INSECURE=1</c> (the daemon there cannot be authenticated; use TLS).</summary>
        public static Client Zenoh(string endpoint, string name = null)
        {
            IntPtr h;
            Native.Check(Native.lumen_client_zenoh(Native.CString(endpoint), IntPtr.Zero, Native.CString(name), out h), "lumen_client_zenoh");
            return new Client(h);
        }

        /// <summary>The daemon at a <c>tls/HOST:PORT</c> zenoh endpoint, authenticated by the lab's
        /// certificate authority <paramref name="rootCa"/> (PEM); with <paramref name="certificate"/>
        /// and <paramref name="privateKey"/> (PEM) for a daemon that requires client certificates
        /// (its access policy knows this client by the certificate's common name).</summary>
        public static Client ZenohTls(string endpoint, string rootCa, string certificate = null, string privateKey = null, string name = null)
        {
            var tls = new Native.NativeTls { RootCa = Native.Unmanaged(rootCa), Certificate = Native.Unmanaged(certificate), PrivateKey = Native.Unmanaged(privateKey) };
            IntPtr t = Marshal.AllocHGlobal(Marshal.SizeOf(typeof(Native.NativeTls)));
            try
            {
                Marshal.StructureToPtr(tls, t, false);
                IntPtr h;
                Native.Check(Native.lumen_client_zenoh(Native.CString(endpoint), t, Native.CString(name), out h), "lumen_client_zenoh");
                return new Client(h);
            }
            finally
            {
                Marshal.FreeHGlobal(t);
                Marshal.FreeHGlobal(tls.RootCa);
                Marshal.FreeHGlobal(tls.Certificate);
                Marshal.FreeHGlobal(tls.PrivateKey);
            }
        }

        /// <summary>Watches session <paramref name="sessionId"/> (any client's, on this client's
        /// transport): its newest frames and the daemon's replies (a VR front-end, a recorder).
        /// Refused (code observers_full) when the session has all the observers it allows.</summary>
        public Observer Observe(ulong sessionId)
        {
            IntPtr o;
            Native.Check(Native.lumen_observer_open(handle.Live("Client"), sessionId, out o), "lumen_observer_open");
            return new Observer(o);
        }

        /// <summary>Opens a session for the scene spec (JSON); the daemon validates it
        /// (<see cref="Status.Refused"/> names what is wrong).</summary>
        public Session Open(string specJson)
        {
            byte[] spec = Encoding.UTF8.GetBytes(specJson);
            IntPtr s;
            Native.Check(Native.lumen_session_open(handle.Live("Client"), spec, (UIntPtr)spec.Length, out s), "lumen_session_open");
            return new Session(s);
        }

        /// <summary>Frees the client (its sessions stay open; idempotent; a dropped client is
        /// freed by its finalizer).</summary>
        public void Dispose() { handle.Free("lumen_client_free"); }
    }

    /// <summary>One reply of the daemon: the header's fields and the contacts, copied.</summary>
    public struct Reply
    {
        public ulong Frame;
        public FrameStatus Status;
        public string Message;      // why not Ok (null when Ok)
        public uint ErrorBody, ErrorIndex, ErrorSpoke;
        public uint DetectNs, Skipped;
        public int Count;           // contacts in Session.Contacts
    }

    /// <summary>One scene on the daemon: <see cref="Submit"/> a frame, read its
    /// <see cref="Receive"/>d reply. If the daemon restarts, calls throw Disconnected and the
    /// session reopens by itself on a later Submit.</summary>
    public sealed class Session : IDisposable
    {
        readonly SessionHandle handle = new SessionHandle();
        Contact[] contacts = new Contact[16];
        internal Session(IntPtr h) { handle.Take(h); }

        /// <summary>The session id (changes when the session reopens).</summary>
        public ulong Id { get { ulong id; Native.Check(Native.lumen_session_id(Live(), out id), "lumen_session_id"); return id; } }

        /// <summary>How many times the session reopened after losing the daemon.</summary>
        public ulong Reconnects { get { ulong n; Native.Check(Native.lumen_session_reconnects(Live(), out n), "lumen_session_reconnects"); return n; } }
        /// <summary>Replies dropped because they answered a frame older than the newest
        /// submitted (see <see cref="Receive"/>).</summary>
        public ulong StaleReplies { get { ulong n; Native.Check(Native.lumen_session_stale_replies(Live(), out n), "lumen_session_stale_replies"); return n; } }

        /// <summary>Copies <paramref name="state"/> (the whole scene, proto/README.md's layout)
        /// into the frame (the shared memory the daemon reads, over iceoryx2) and sends it;
        /// returns its frame number.</summary>
        public ulong Submit(float[] state)
        {
            IntPtr frame; UIntPtr floats;
            Native.Check(Native.lumen_session_frame(Live(), out frame, out floats), "lumen_session_frame");
            if ((int)floats != state.Length)
                throw new LumenException(Status.BadState, string.Format("state has {0} floats; the session's layout needs {1}", state.Length, (int)floats));
            Marshal.Copy(state, 0, frame, state.Length);
            ulong number;
            Native.Check(Native.lumen_session_submit(Live(), out number), "lumen_session_submit");
            return number;
        }

        /// <summary>Waits up to <paramref name="timeoutMs"/> for the reply to the newest frame
        /// submitted (throws Timeout when none came); its contacts go to <see cref="Contacts"/>.
        /// A reply to an older frame (late, after its Receive timed out) is dropped, never
        /// returned: <see cref="StaleReplies"/> counts them.</summary>
        public Reply Receive(uint timeoutMs)
        {
            Native.NativeReply r;
            Native.Check(Native.lumen_session_contacts(Live(), timeoutMs, out r), "lumen_session_contacts");
            return Native.ReadReply(r, ref contacts);
        }

        /// <summary>The last reply's contacts (its <c>Count</c> first ones); reused by the next.</summary>
        public Contact[] Contacts { get { return contacts; } }

        IntPtr Live() { return handle.Live("Session"); }

        /// <summary>Closes the session on the daemon (waits for its answer). Idempotent, and
        /// safe from any thread (OnDestroy, a Task): the handle is freed whatever happens, and
        /// a failure to reach the daemon is thrown once. A session dropped without Dispose is
        /// closed by its finalizer.</summary>
        public void Dispose() { handle.Free("lumen_session_close"); }
    }

    /// <summary>What <see cref="Observer.Next"/> saw.</summary>
    public enum ObservedKind { Frame = 1, Contacts = 2 }

    /// <summary>A watcher of one session: its newest frame as soon as it exists (older ones not
    /// yet seen are skipped) and the daemon's replies while it keeps up; it never slows the
    /// session. Dispose gives its place back (a dropped one is freed by its finalizer).</summary>
    public sealed class Observer : IDisposable
    {
        readonly ObserverHandle handle = new ObserverHandle();
        float[] state = new float[0];
        Contact[] contacts = new Contact[16];
        internal Observer(IntPtr h) { handle.Take(h); }

        /// <summary>Waits up to <paramref name="timeoutMs"/> for the next frame or reply: a frame
        /// fills <see cref="FrameNumber"/> and <see cref="State"/>, a reply <see cref="Reply"/>
        /// and <see cref="Contacts"/>. Throws Timeout when nothing came, SessionEnded once the
        /// session is gone.</summary>
        public ObservedKind Next(uint timeoutMs)
        {
            Native.NativeObserved seen;
            Native.Check(Native.lumen_observer_next(handle.Live("Observer"), timeoutMs, out seen), "lumen_observer_next");
            if (seen.Kind == (int)ObservedKind.Frame)
            {
                FrameNumber = (ulong)Marshal.ReadInt64(seen.Frame, 16);
                int n = (int)seen.Floats;
                if (state.Length != n) state = new float[n];
                Marshal.Copy(seen.State, state, 0, n);
                return ObservedKind.Frame;
            }
            Reply = Native.ReadReply(seen.Reply, ref contacts);
            return ObservedKind.Contacts;
        }

        /// <summary>The last frame's number and state (the spec's layout; reused by the next).</summary>
        public ulong FrameNumber { get; private set; }
        public float[] State { get { return state; } }
        /// <summary>The last reply, and its contacts (its <c>Count</c> first ones; reused by the next).</summary>
        public Reply Reply { get; private set; }
        public Contact[] Contacts { get { return contacts; } }

        /// <summary>Stops watching (idempotent; any thread).</summary>
        public void Dispose() { handle.Free("lumen_observer_free"); }
    }
}
