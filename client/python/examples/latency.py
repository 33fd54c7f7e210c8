"""Round-trip latency of the Python client, the twin of client/c/examples/latency.{c,rs}: the
straight-tube scene (25 contacts a frame), each frame copied into the frame in place (a NumPy
view of the shared memory over iceoryx2), submitted, and its reply awaited; prints the median
and 99th percentile in microseconds. client/latency.sh runs it beside the Rust and C twins.

    python client/python/examples/latency.py (local PREFIX | zenoh ENDPOINT) FRAMES
"""

import math
import sys
import time

import numpy as np

import lumen

SPEC = {
    "bodies": [
        {"name": "colon", "shape": {"tube": {"rings": 11, "spokes": 32}}},
        {"name": "scope", "shape": {"rod": {"points": 7, "radius": [2.0]}}},
    ],
    "pairs": [{"a": "scope", "b": "colon", "kind": "interior"}],
    "precision": 4,
}


def state(offset: float) -> np.ndarray:
    """The straight-tube scene's state (straight_tube_scene.h's fill_state) at `offset`."""
    s = []
    for i in range(11):
        s += [i * 10.0, 0.0, 0.0]
        for k in range(32):
            a = 2 * math.pi * (k + 0.5) / 32
            s += [0.0, 10 * math.cos(a), 10 * math.sin(a)]
    for j in range(7):
        s += [20.0 + j * 10.0, offset, 0.0]
    return np.array(s, dtype=np.float32)


def main() -> None:
    transport, target, frames = sys.argv[1], sys.argv[2], int(sys.argv[3])
    client = lumen.Client.local(prefix=target, name="latency.py") if transport == "local" else lumen.Client.zenoh(target)
    session = client.open_session(SPEC)
    s = state(8.5)
    times = []
    for k in range(frames + 100):
        start = time.perf_counter()
        session.frame()[:] = s
        session.submit()
        reply = session.contacts(timeout=1.0)
        assert len(reply.contacts) == 25, "contacts of the straight tube"
        if k >= 100:
            times.append((time.perf_counter() - start) * 1e6)
    times.sort()
    print(f"python: p50 {times[frames // 2]:.1f} us p99 {times[frames * 99 // 100]:.1f} us ({frames} frames)")
    session.close()


if __name__ == "__main__":
    main()
