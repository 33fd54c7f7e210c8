// Round-trip latency of the C# client: the straight-tube scene (client/c/examples/
// straight_tube_scene.h, 25 contacts a frame), FRAMES frames each copied into the frame,
// submitted, and its reply awaited; prints the median and 99th percentile in microseconds.
// client/latency.sh runs it beside the Rust, C and Python clients' twins, alternated.
//   mcs -out:Latency.exe client/csharp/Lumen.cs client/csharp/examples/Latency.cs
//   LD_LIBRARY_PATH=target/release mono Latency.exe (local PREFIX | zenoh ENDPOINT) FRAMES
using System;
using System.Diagnostics;
using Lumen;

static class Latency
{
    const string Spec = "{\"bodies\":[" +
        "{\"name\":\"colon\",\"shape\":{\"tube\":{\"rings\":11,\"spokes\":32}}}," +
        "{\"name\":\"scope\",\"shape\":{\"rod\":{\"points\":7,\"radius\":[2.0]}}}]," +
        "\"pairs\":[{\"a\":\"scope\",\"b\":\"colon\",\"kind\":\"interior\"}],\"precision\":4}";

    static float[] State(double offset)
    {
        var s = new float[11 * 33 * 3 + 7 * 3];
        int p = 0;
        for (int i = 0; i < 11; i++)
        {
            s[p++] = i * 10f; s[p++] = 0; s[p++] = 0;
            for (int k = 0; k < 32; k++)
            {
                double a = 2 * Math.PI * (k + 0.5) / 32;
                s[p++] = 0; s[p++] = (float)(10 * Math.Cos(a)); s[p++] = (float)(10 * Math.Sin(a));
            }
        }
        for (int j = 0; j < 7; j++) { s[p++] = 20 + j * 10f; s[p++] = (float)offset; s[p++] = 0; }
        return s;
    }

    static int Main(string[] args)
    {
        if (args.Length != 3) { Console.Error.WriteLine("usage: Latency.exe (local PREFIX | zenoh ENDPOINT) FRAMES"); return 2; }
        int frames = int.Parse(args[2]);
        using (Client client = args[0] == "local" ? Client.Local(args[1], "Latency.cs") : Client.Zenoh(args[1], "Latency.cs"))
        using (Session session = client.Open(Spec))
        {
            float[] state = State(8.5);
            var times = new double[frames];
            var watch = new Stopwatch();
            for (int k = -100; k < frames; k++) // 100 frames of warm-up
            {
                watch.Restart();
                session.Submit(state);
                Reply reply = session.Receive(1000);
                if (reply.Count != 25) { Console.Error.WriteLine("{0} contacts, expected 25", reply.Count); return 1; }
                if (k >= 0) times[k] = watch.Elapsed.TotalMilliseconds * 1000;
            }
            Array.Sort(times);
            Console.WriteLine("csharp: p50 {0:F1} us p99 {1:F1} us ({2} frames)", times[frames / 2], times[frames * 99 / 100], frames);
        }
        return 0;
    }
}
