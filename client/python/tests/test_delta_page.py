"""The delta encoder of proto/README.md (the block after ``<!-- tested: python-delta -->``),
written there for a client with nothing but NumPy and zstandard: it must give the page's worked
example (header and delta header byte for byte, the zstd frame holding the 13 bytes listed), and
a colon-sized delta that the page's decoding rule turns back into the new state bit for bit."""

import re

import numpy as np
import zstandard

from conftest import REPO

PAGE = REPO / "proto" / "README.md"


def page_snippet(name: str) -> str:
    lines = PAGE.read_text().splitlines()
    marker = f"<!-- tested: {name} -->"
    at = [i for i, line in enumerate(lines) if line.strip() == marker]
    assert len(at) == 1, f"{PAGE}: the marker {marker} should be there exactly once"
    body = []
    for line in lines[at[0] + 2 :]:
        if line.startswith("```"):
            return "\n".join(body) + "\n"
        body.append(line)
    raise AssertionError(f"{PAGE}: the block after {marker} is never closed")


def delta_frame():
    scope = {}
    exec(compile(page_snippet("python-delta"), str(PAGE), "exec"), scope)
    return scope["delta_frame"]


def page_example_bytes() -> bytes:
    text = PAGE.read_text()
    block = text[text.index("The 78 bytes on\nzenoh:") :].split("```")[1]
    return bytes(int(b, 16) for b in block.split())


def test_the_pages_encoder_writes_the_pages_example():
    base = np.array([1, 2, 3, 4, 5, 6], dtype=np.float32)
    new = np.array([1, 2, 3, 4, 5.5, 6], dtype=np.float32)
    msg = delta_frame()(7, 4, 3, base, new, 1, client_time_ns=1000)
    want = page_example_bytes()
    assert len(want) == 78
    assert msg[:52] == want[:52]
    assert zstandard.ZstdDecompressor().decompress(msg[56:]) == bytes.fromhex("02000000000000002000000000")
    assert int.from_bytes(msg[52:56], "little") == len(msg) - 56


def rebuild(base: np.ndarray, msg: bytes) -> np.ndarray:
    """The page's decoding rule, on its own."""
    changed = int.from_bytes(msg[48:52], "little")
    raw = zstandard.ZstdDecompressor().decompress(msg[56:])
    rows = base.size // 3
    nbitmap = (rows + 7) // 8
    assert len(raw) == nbitmap + 12 * changed
    bits = np.unpackbits(np.frombuffer(raw[:nbitmap], dtype=np.uint8), bitorder="little")[:rows].astype(bool)
    assert bits.sum() == changed
    z = np.frombuffer(raw[nbitmap:], dtype=np.uint8).reshape(4, -1).T.copy().view(np.uint32).ravel()
    d = (z >> 1) ^ (np.uint32(0) - (z & 1))
    out = base.view(np.uint32).reshape(-1, 3).copy()
    out[bits] = (out[bits].ravel() + d).reshape(-1, 3)
    return out.ravel().view(np.float32)


def test_a_colon_sized_delta_rebuilds_the_state_bit_for_bit():
    rng = np.random.default_rng(3)
    base = rng.normal(0, 40, 124_230).astype(np.float32)
    new = base.copy()
    moved = rng.choice(base.size // 3, 7_000, replace=False)
    for r in moved:
        new[3 * r : 3 * r + 3] += rng.normal(0, 0.01, 3).astype(np.float32)
    new[9] = -new[9]
    msg = delta_frame()(1, 2, 1, base, new, 2)
    assert np.array_equal(rebuild(base, msg).view(np.uint32), new.view(np.uint32))
    assert len(msg) < 4 * new.size // 4, f"{len(msg)} bytes for 7,000 of 41,410 rows"
    assert re.fullmatch(rb"LMNF", msg[:4])
