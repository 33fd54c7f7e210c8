"""The Python snippet of docs/guide/integrating.md (the block after ``<!-- tested: python -->``),
run as it stands against a real daemon (`lumen serve`) on the straight tube of
``straight_tube.py``: it must hand every frame's contacts to ``push_back``, each the closed
form's."""

import numpy as np

import straight_tube as st
from conftest import REPO

GUIDE = REPO / "docs" / "guide" / "integrating.md"
OFFSET = 8.5
FRAMES = 100


def guide_snippet(name: str):
    """The fenced block right after ``<!-- tested: NAME -->`` and the line it starts on; fails
    when the marker is missing or there twice."""
    lines = GUIDE.read_text().splitlines()
    marker = f"<!-- tested: {name} -->"
    at = [i for i, line in enumerate(lines) if line.strip() == marker]
    assert len(at) == 1, f"{GUIDE}: the marker {marker} should be there exactly once (found {len(at)})"
    fence = at[0] + 1
    assert fence < len(lines) and lines[fence].startswith("```"), f"{GUIDE}:{fence + 1}: a fenced block should follow {marker}"
    body = []
    for line in lines[fence + 1 :]:
        if line.startswith("```"):
            return "\n".join(body) + "\n", fence + 2
        body.append(line)
    raise AssertionError(f"{GUIDE}:{fence + 1}: the block after {marker} is never closed")


def test_the_guides_python_snippet_runs_a_session(start_daemon, monkeypatch):
    code, line = guide_snippet("python")
    d = start_daemon("guide")
    # The snippet's Client.local() takes the daemon's prefix from the environment.
    monkeypatch.setenv("LUMEN_IOX2_PREFIX", d.prefix)
    handed = []

    def fill(frame):
        st.state(OFFSET, out=frame)

    def push_back(normal, depth, point_b):
        handed.append((np.array(normal), np.array(depth), np.array(point_b)))

    # Line numbers in a traceback are the guide's own.
    compiled = compile("\n" * (line - 1) + code, str(GUIDE), "exec")
    exec(compiled, {"spec": st.SPEC, "fill": fill, "push_back": push_back, "__name__": "guide"})

    assert len(handed) == FRAMES, f"{len(handed)} replies handed on, {FRAMES} frames sent"
    for normal, depth, point_b in handed:
        assert depth.shape == (st.SAMPLES,)
        np.testing.assert_allclose(depth, st.expected_depth(OFFSET), atol=1e-3)
        np.testing.assert_allclose(normal, np.tile([0.0, 1.0, 0.0], (st.SAMPLES, 1)), atol=1e-3)
        np.testing.assert_allclose(point_b[:, 1], st.APOTHEM, atol=1e-3)
