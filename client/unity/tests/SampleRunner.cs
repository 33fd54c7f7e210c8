// Runs the package's sample as Unity would (Start, FixedUpdate each physics step, OnDrawGizmos,
// OnDestroy), against the stand-in UnityEngine, for FRAMES frames; checks every reply's contacts
// against the closed form of the sample's straight colon. Exits non-zero on any mismatch.
//   mono SampleRunner.exe [local PREFIX | zenoh ENDPOINT] FRAMES
using System;
using System.Reflection;
using Lumen;
using Lumen.Samples;
using UnityEngine;

static class SampleRunner
{
    static void Call(object target, string method)
    {
        target.GetType().GetMethod(method, BindingFlags.Instance | BindingFlags.NonPublic | BindingFlags.Public).Invoke(target, null);
    }

    static int Main(string[] args)
    {
        var sample = new ScopeContacts();
        if (args[0] == "local") sample.prefix = args[1]; else sample.zenohEndpoint = args[1];
        sample.replyWaitMs = 2000;
        int frames = int.Parse(args[2]), bad = 0, touching = 0;
        Call(sample, "Start");
        double apothem = ScopeContacts.TubeRadius * Math.Cos(Math.PI / ScopeContacts.Spokes);
        for (int k = 0; k < frames; k++)
        {
            Call(sample, "FixedUpdate");
            if (sample.Answered != k + 1) { Console.Error.WriteLine("frame {0} not answered", k); bad++; continue; }
            // The rod's +y side meets the 32-gon's apothem when it reaches it (and the -y side
            // the one across, for a negative offset): depth = r - (apothem - |offset|).
            double depth = ScopeContacts.RodRadius - (apothem - Math.Abs(sample.Offset));
            int expected = depth > 0 ? (ScopeContacts.Points - 1) * 4 + 1 : 0;
            Reply r = sample.LastReply;
            if (r.Count != expected) { Console.Error.WriteLine("frame {0}: {1} contacts, expected {2}", k, r.Count, expected); bad++; continue; }
            for (int i = 0; i < r.Count; i++)
                if (Math.Abs(sample.Contacts[i].Depth - depth) > 1e-3) { Console.Error.WriteLine("frame {0}: depth {1}, expected {2}", k, sample.Contacts[i].Depth, depth); bad++; break; }
            if (expected > 0) touching++;
            Call(sample, "OnDrawGizmos");
        }
        Call(sample, "OnDestroy");
        Console.WriteLine("sample: {0} frames answered, {1} touching the wall, {2} lines drawn", sample.Answered, touching, Gizmos.Lines);
        if (bad > 0 || touching == 0 || Gizmos.Lines == 0) { Console.Error.WriteLine("{0} mismatches", bad); return 1; }
        Console.WriteLine("ok");
        return 0;
    }
}
