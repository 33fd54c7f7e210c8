// Lumen's sample: a scope sliding inside a straight colon, sent to the daemon each FixedUpdate;
// the wall's contacts push it back and are drawn with Gizmos (the Scene view, or the Game view
// with Gizmos on). Add it to any GameObject and press Play beside a running `lumen serve`.
// A real simulator writes its own colon and scope into the state instead (proto/README.md's
// layout: per ring its control point then its radial vectors, relative to it; then the rod's
// points), in millimetres or whatever unit its spec uses.
using System;
using Lumen;
using UnityEngine;

namespace Lumen.Samples
{
    public class ScopeContacts : MonoBehaviour
    {
        [Tooltip("Empty: iceoryx2 on this machine (the daemon's --prefix below). Else a zenoh endpoint, e.g. tcp/127.0.0.1:7447.")]
        public string zenohEndpoint = "";
        [Tooltip("The daemon's iceoryx2 prefix (lumen serve --prefix); empty: LUMEN_IOX2_PREFIX, else the default.")]
        public string prefix = "";
        [Tooltip("How long a FixedUpdate waits for the daemon's reply, ms.")]
        public uint replyWaitMs = 20;

        public const int Rings = 11, Spokes = 32, Points = 7;
        public const float TubeRadius = 10, RodRadius = 2, Spacing = 10;
        const string Spec = "{\"bodies\":[" +
            "{\"name\":\"colon\",\"shape\":{\"tube\":{\"rings\":11,\"spokes\":32}}}," +
            "{\"name\":\"scope\",\"shape\":{\"rod\":{\"points\":7,\"radius\":[2.0]}}}]," +
            "\"pairs\":[{\"a\":\"scope\",\"b\":\"colon\",\"kind\":\"interior\"}],\"precision\":4}";

        Client client;
        Session session;
        float[] state;

        /// <summary>How far the scope's axis is off the colon's, this frame (mm, along +y).</summary>
        public float Offset { get; private set; }
        /// <summary>The last reply (Count contacts in Contacts) and how many frames were answered.</summary>
        public Reply LastReply { get; private set; }
        public int Answered { get; private set; }
        public Contact[] Contacts { get { return session != null ? session.Contacts : new Contact[0]; } }

        void Start()
        {
            client = string.IsNullOrEmpty(zenohEndpoint)
                ? Client.Local(string.IsNullOrEmpty(prefix) ? null : prefix, "unity-sample")
                : Client.Zenoh(zenohEndpoint, "unity-sample");
            session = client.Open(Spec);
            state = new float[Rings * (Spokes + 1) * 3 + Points * 3];
            WriteColon(state);
        }

        void FixedUpdate()
        {
            // The scope sways across the lumen: touching the wall beyond 10 cos(pi/32) - 2 mm.
            Offset = 9.5f * (float)Math.Sin(Answered * 0.05);
            WriteScope(state, Offset);
            try
            {
                ulong frame = session.Submit(state);
                Reply reply = session.Receive(replyWaitMs);
                if (reply.Frame != frame) throw new InvalidOperationException("a reply to another frame");
                if (reply.Status != FrameStatus.Ok) { Debug.LogWarning(reply.Message); return; }
                LastReply = reply;
                Answered++;
            }
            catch (LumenException e) when (e.Status == Status.Disconnected || e.Status == Status.Timeout)
            {
                // The daemon restarted or is late: keep submitting, the session reopens by itself.
            }
        }

        void OnDrawGizmos()
        {
            if (session == null) return;
            Gizmos.color = Color.red;
            for (int i = 0; i < LastReply.Count; i++)
            {
                Contact c = session.Contacts[i];
                var wall = new Vector3(c.PointB.X, c.PointB.Y, c.PointB.Z);
                var normal = new Vector3(c.Normal.X, c.Normal.Y, c.Normal.Z);
                Gizmos.DrawLine(wall, wall - c.Depth * normal);   // how far the scope is in the wall
            }
        }

        void OnDestroy()
        {
            // Any thread may do this; a session dropped without it is closed by its finalizer.
            if (session != null) session.Dispose();
            if (client != null) client.Dispose();
            session = null;
            client = null;
        }

        static void WriteColon(float[] s)
        {
            int p = 0;
            for (int i = 0; i < Rings; i++)
            {
                s[p++] = i * Spacing; s[p++] = 0; s[p++] = 0;
                for (int k = 0; k < Spokes; k++)
                {
                    double a = 2 * Math.PI * (k + 0.5) / Spokes;
                    s[p++] = 0; s[p++] = (float)(TubeRadius * Math.Cos(a)); s[p++] = (float)(TubeRadius * Math.Sin(a));
                }
            }
        }

        static void WriteScope(float[] s, float offset)
        {
            int p = Rings * (Spokes + 1) * 3;
            for (int j = 0; j < Points; j++) { s[p++] = 20 + j * Spacing; s[p++] = offset; s[p++] = 0; }
        }
    }
}
