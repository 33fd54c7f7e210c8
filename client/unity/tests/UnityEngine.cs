// A stand-in for the few UnityEngine types Lumen's package uses, so that its C# compiles and
// runs under Mono without Unity (tests/e2e/c_client.rs). Not Unity: just the same names and
// signatures, with Gizmos counting what is drawn.
using System;

namespace UnityEngine
{
    public class Object { }
    public class Component : Object { }
    public class Behaviour : Component { }
    public class MonoBehaviour : Behaviour { }

    [AttributeUsage(AttributeTargets.Field)]
    public sealed class TooltipAttribute : Attribute { public TooltipAttribute(string tooltip) { } }

    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
        public static Vector3 operator +(Vector3 a, Vector3 b) { return new Vector3(a.x + b.x, a.y + b.y, a.z + b.z); }
        public static Vector3 operator -(Vector3 a, Vector3 b) { return new Vector3(a.x - b.x, a.y - b.y, a.z - b.z); }
        public static Vector3 operator *(float k, Vector3 a) { return new Vector3(k * a.x, k * a.y, k * a.z); }
        public static Vector3 operator *(Vector3 a, float k) { return k * a; }
    }

    public struct Color
    {
        public float r, g, b, a;
        public Color(float r, float g, float b, float a = 1) { this.r = r; this.g = g; this.b = b; this.a = a; }
        public static Color red { get { return new Color(1, 0, 0); } }
    }

    public static class Gizmos
    {
        public static Color color;
        /// <summary>Lines drawn since the start (the stand-in's own count).</summary>
        public static int Lines;
        public static void DrawLine(Vector3 from, Vector3 to) { Lines++; }
    }

    public static class Debug
    {
        public static void Log(object message) { Console.WriteLine(message); }
        public static void LogWarning(object message) { Console.Error.WriteLine("warning: " + message); }
    }
}
