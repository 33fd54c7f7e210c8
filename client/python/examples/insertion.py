#!/usr/bin/env python3
"""A scripted insertion through Lumen from Python: a scope (a rod) pushed into a curved tube
built in NumPy, then pulled back; plots the maximum penetration per frame to a PNG.

The tube: 100 mm straight along x, a 120-degree bend of radius 60 mm, 100 mm straight again;
radius 15 mm, a ring every 4 mm, 24 spokes. The scope: 40 points 4 mm apart, radius 5.5 mm. Its
tip follows the midline; in the bend the shaft, stiffer than the colon, presses on the outer
wall while pushed and hugs the inner wall while pulled back (a kinematic script, not physics).

    python client/python/examples/insertion.py --out insertion.png             # starts a daemon
    python client/python/examples/insertion.py --prefix P --out insertion.png  # daemon on prefix P
    python client/python/examples/insertion.py --zenoh tcp/127.0.0.1:7447 --out insertion.png
    python client/python/examples/insertion.py --embedded --out insertion.png  # no daemon

Starting a daemon needs the `lumen` binary: `--lumen-bin`, else `$LUMEN_BIN`, else
`<repo>/target/debug/lumen` (`cargo build -p lumen-cli --bin lumen`).
"""

from __future__ import annotations

import argparse
import gc
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import lumen

TUBE_R, SPOKES, RING_STEP = 15.0, 24, 4.0
STRAIGHT, BEND_R, BEND_ANGLE = 100.0, 60.0, np.radians(120.0)
ROD_POINTS, ROD_STEP, ROD_R = 40, 4.0, 5.5
STIFFNESS = 700.0  # mm^2: lateral shift of the shaft = STIFFNESS * curvature (pushing)


def midline(s: np.ndarray):
    """Point, unit tangent and unit normal (towards the bend's centre) at arc lengths `s`."""
    s = np.asarray(s, dtype=np.float64)
    bend = BEND_R * BEND_ANGLE
    a = np.clip(s - STRAIGHT, 0.0, bend) / BEND_R  # angle turned so far
    centre = np.array([STRAIGHT, BEND_R, 0.0])
    on_arc = centre + BEND_R * np.stack([np.sin(a), -np.cos(a), np.zeros_like(a)], axis=-1)
    tangent = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=-1)
    normal = np.stack([-np.sin(a), np.cos(a), np.zeros_like(a)], axis=-1)
    before = np.minimum(s, STRAIGHT)[..., None] * np.array([1.0, 0.0, 0.0])
    after = np.maximum(s - STRAIGHT - bend, 0.0)[..., None] * tangent
    point = np.where((s <= STRAIGHT)[..., None], before, on_arc + after)
    return point, tangent, normal


def curvature(s: np.ndarray) -> np.ndarray:
    """The midline's curvature, smoothed over one scope segment either side (the shaft cannot
    follow a step)."""
    s = np.asarray(s, dtype=np.float64)
    taps = np.linspace(-2 * ROD_STEP, 2 * ROD_STEP, 9)
    inside = lambda x: ((x > STRAIGHT) & (x < STRAIGHT + BEND_R * BEND_ANGLE)).astype(np.float64)  # noqa: E731
    return np.mean([inside(s + t) for t in taps], axis=0) / BEND_R


def tube_length() -> float:
    return 2 * STRAIGHT + BEND_R * BEND_ANGLE


def spec(rings: int) -> dict:
    return {
        "bodies": [
            {"name": "colon", "shape": {"tube": {"rings": rings, "spokes": SPOKES}}},
            {"name": "scope", "shape": {"rod": {"points": ROD_POINTS, "radius": [ROD_R]}}},
        ],
        "pairs": [{"a": "scope", "b": "colon", "kind": "interior"}],
        "precision": 4,
    }


def tube_state(rings: int) -> np.ndarray:
    """The tube's floats: per ring its control point then its radial vectors (relative)."""
    s = np.arange(rings) * RING_STEP
    point, tangent, normal = midline(s)
    binormal = np.cross(tangent, normal)
    angle = 2 * np.pi * (np.arange(SPOKES) + 0.5) / SPOKES
    spokes = TUBE_R * (np.cos(angle)[None, :, None] * normal[:, None, :] + np.sin(angle)[None, :, None] * binormal[:, None, :])
    out = np.concatenate([point[:, None, :], spokes], axis=1)  # (rings, spokes + 1, 3)
    return out.astype(np.float32).ravel()


def scope_state(tip: float, pushing: bool) -> np.ndarray:
    """The scope's points: along the midline behind its tip (straight back out of the entrance),
    shifted towards the outer wall while pushed, the inner one while pulled."""
    s = tip - np.arange(ROD_POINTS) * ROD_STEP
    point, _, normal = midline(np.maximum(s, 0.0))
    point = point + np.minimum(s, 0.0)[:, None] * np.array([1.0, 0.0, 0.0])
    shift = STIFFNESS * curvature(s) * (-1.0 if pushing else 0.85)
    return (point + shift[:, None] * normal).astype(np.float32).ravel()


def script(frames: int):
    """(tip arc length, pushing) per frame: push from 40 mm to near the end, then pull back."""
    far = tube_length() - 30.0
    push = frames * 2 // 3
    for k in range(frames):
        if k < push:
            yield 40.0 + (far - 40.0) * k / (push - 1), True
        else:
            yield far - (far - 120.0) * (k - push + 1) / (frames - push), False


class StartedDaemon:
    """`lumen serve` on a prefix of its own, stopped on exit."""

    def __init__(self, binary: Path) -> None:
        self.prefix = f"lumen_example{os.getpid()}_"
        self.process = subprocess.Popen([str(binary), "serve", "--prefix", self.prefix, "--log", "warn"], stdout=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 30
        assert self.process.stdout is not None
        for line in self.process.stdout:
            if line.startswith("lumen serve: ready"):
                return
            if time.monotonic() > deadline:
                break
        self.stop()
        sys.exit(f"{binary} serve did not get ready")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            self.process.wait(timeout=10)
        left = [f for f in os.listdir("/dev/shm") if f.startswith(self.prefix)]
        if all(f.endswith(".global_mgmt") for f in left):
            for f in left:
                os.remove(os.path.join("/dev/shm", f))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("insertion.png"), help="the plot (PNG)")
    p.add_argument("--frames", type=int, default=240)
    where = p.add_mutually_exclusive_group()
    where.add_argument("--prefix", help="use the running daemon on this iceoryx2 prefix")
    where.add_argument("--zenoh", metavar="ENDPOINT", help="use the daemon at this zenoh endpoint (tcp/HOST:PORT)")
    where.add_argument("--embedded", action="store_true", help="detect in this process (lumen.Detector), no daemon")
    p.add_argument("--lumen-bin", type=Path, default=Path(os.environ.get("LUMEN_BIN", Path(__file__).resolve().parents[3] / "target" / "debug" / "lumen")))
    args = p.parse_args()

    rings = int(tube_length() // RING_STEP) + 1
    scene = spec(rings)
    tube = tube_state(rings)
    started = client = session = frame = None
    transport = "embedded"
    if args.embedded:
        detector = lumen.Detector(scene)
    else:
        if args.zenoh:
            client = lumen.Client.zenoh(args.zenoh, name="insertion.py")
        else:
            prefix = args.prefix
            if prefix is None:
                if not args.lumen_bin.is_file():
                    sys.exit(f"{args.lumen_bin} does not exist: build it with `cargo build -p lumen-cli --bin lumen`, or give --prefix / --zenoh / --embedded")
                started = StartedDaemon(args.lumen_bin)
                prefix = started.prefix
            client = lumen.Client.local(prefix=prefix, name="insertion.py")
        session = client.open_session(scene)
        transport = session.transport
        print(f"session {session.id} over {session.transport}: {session.floats} floats per frame")

    depth, count, outside, tips = [], [], [], []
    try:
        for k, (tip, pushing) in enumerate(script(args.frames)):
            rod = scope_state(tip, pushing)
            if args.embedded:
                contacts = detector.detect(np.concatenate([tube, rod]))
            else:
                frame = session.frame()  # the frame itself (shared memory on iceoryx2)
                frame[: tube.size] = tube
                frame[tube.size :] = rod
                n = session.submit()  # `frame` is read-only from here on
                reply = session.contacts(timeout=2.0).raise_for_status()
                assert reply.frame == n, (reply.frame, n)
                contacts = reply.contacts
            depth.append(float(contacts["depth"].max()) if len(contacts) else 0.0)
            count.append(len(contacts))
            outside.append(int(np.count_nonzero(contacts["flags"] & lumen.FLAG_OUTSIDE)))
            tips.append(tip)
        if not args.embedded:
            session.close()
    finally:
        # Let go of the client (its iceoryx2 node) before the daemon's prefix is cleaned up.
        client = session = frame = None  # a frame array keeps its session alive
        gc.collect()
        if started is not None:
            started.stop()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.5))
    frames = np.arange(len(depth))
    ax.plot(frames, depth, color="tab:red", label="max penetration")
    ax.set_xlabel("frame")
    ax.set_ylabel("max penetration (mm)", color="tab:red")
    ax.axvline(args.frames * 2 // 3 - 0.5, color="grey", linestyle=":", label="push -> pull back")
    twin = ax.twinx()
    twin.plot(frames, count, color="tab:blue", alpha=0.5, label="contacts")
    twin.set_ylabel("contacts", color="tab:blue")
    ax.set_title(f"Scripted insertion in a {np.degrees(BEND_ANGLE):.0f}-degree bend ({transport})")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    peak = int(np.argmax(depth))
    print(f"{len(depth)} frames; max penetration {depth[peak]:.3f} mm at frame {peak} (tip at {tips[peak]:.0f} mm); samples outside the wall: {max(outside)}")
    print(f"plot: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
