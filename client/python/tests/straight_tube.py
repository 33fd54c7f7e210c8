"""The scene of client/c/examples/straight_tube.c: a straight circular tube (radius 10, 32
spokes, 11 rings along x, 10 apart) and a rod of radius 2 (7 points from x = 20 to 80) held
parallel to the axis at a known offset along +y.

The spokes sit at the middles of 32 sectors turned half a sector from +y, so the rod's side
facing +y meets the middle of a flat wall strip, at the 32-gon's apothem a = R cos(pi / 32):
depth = offset + r - a (the circle's d + r - R, with the polygon's apothem for R).
"""

import json
import math

import numpy as np

RINGS, SPOKES, POINTS, PRECISION = 11, 32, 7, 4
SAMPLES = (POINTS - 1) * PRECISION + 1
TUBE_R, ROD_R, SPACING = 10.0, 2.0, 10.0
APOTHEM = TUBE_R * math.cos(math.pi / SPOKES)
FLOATS = RINGS * (SPOKES + 1) * 3 + POINTS * 3

SPEC_JSON = (
    '{"bodies":['
    '{"name":"colon","shape":{"tube":{"rings":11,"spokes":32}}},'
    '{"name":"scope","shape":{"rod":{"points":7,"radius":[2.0]}}}],'
    '"pairs":[{"a":"scope","b":"colon","kind":"interior"}],'
    '"precision":4}'
)
SPEC = json.loads(SPEC_JSON)


def expected_depth(offset: float) -> float:
    return ROD_R - (APOTHEM - offset)


def state(offset: float, out: "np.ndarray | None" = None) -> np.ndarray:
    """The frame's floats (written into ``out`` if given): per ring its control point then its
    32 spokes relative to it, then the rod's points at ``offset`` along +y."""
    if out is None:
        out = np.empty(FLOATS, dtype=np.float32)
    tube = out[: RINGS * (SPOKES + 1) * 3].reshape(RINGS, SPOKES + 1, 3)
    tube[:, 0, 0] = np.arange(RINGS) * SPACING
    tube[:, 0, 1:] = 0.0
    angle = 2.0 * np.pi * (np.arange(SPOKES) + 0.5) / SPOKES
    tube[:, 1:, 0] = 0.0
    tube[:, 1:, 1] = (TUBE_R * np.cos(angle)).astype(np.float32)
    tube[:, 1:, 2] = (TUBE_R * np.sin(angle)).astype(np.float32)
    rod = out[RINGS * (SPOKES + 1) * 3 :].reshape(POINTS, 3)
    rod[:, 0] = 20.0 + np.arange(POINTS) * SPACING
    rod[:, 1] = offset
    rod[:, 2] = 0.0
    return out


def spoke_index(ring: int, spoke: int, coordinate: int) -> int:
    """Where ring ``ring``'s spoke ``spoke``, coordinate ``coordinate`` sits in the state."""
    return (ring * (SPOKES + 1) + 1 + spoke) * 3 + coordinate


def rod_index(point: int, coordinate: int) -> int:
    return RINGS * (SPOKES + 1) * 3 + point * 3 + coordinate
