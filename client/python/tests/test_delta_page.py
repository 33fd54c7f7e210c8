"""The delta encoder of proto/README.md (the block after ``<!-- tested: python-delta -->``),
written there for a client with nothing but NumPy and zstandard: it must give the page's worked
example (header and delta header byte for byte, the zstd frame holding the 13 bytes listed), and
a colon-sized delta that the page's decoding rule turns back into the new state bit for bit;
and the page's scaled rows (flags bit 2) with nothing but NumPy's float32 products: its 17-byte
example, and a colon-sized scaled delta rebuilt bit for bit, smaller than the plain one."""

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


def colon_sized(seed: int, move):
    """A colon-sized state (124,230 floats) and a new one whose 7,000 random rows `move(row,
    rng)` changes, with one more float's sign flipped."""
    rng = np.random.default_rng(seed)
    base = rng.normal(0, 40, 124_230).astype(np.float32)
    new = base.copy()
    for r in rng.choice(base.size // 3, 7_000, replace=False):
        new[3 * r : 3 * r + 3] = move(base[3 * r : 3 * r + 3], rng)
    new[9] = -new[9]
    return base, new


def test_a_colon_sized_delta_rebuilds_the_state_bit_for_bit():
    base, new = colon_sized(3, lambda row, rng: row + rng.normal(0, 0.01, 3).astype(np.float32))
    msg = delta_frame()(1, 2, 1, base, new, 2)
    assert np.array_equal(rebuild(base, msg).view(np.uint32), new.view(np.uint32))
    assert len(msg) < 4 * new.size // 4, f"{len(msg)} bytes for 7,000 of 41,410 rows"
    assert re.fullmatch(rb"LMNF", msg[:4])


def scaled_example_bytes() -> bytes:
    text = PAGE.read_text()
    block = text[text.index("17 bytes, and the header's flags are 7") :].split("```")[1]
    return bytes(int(b, 16) for b in block.split())


def unzigzag(z: np.ndarray) -> np.ndarray:
    return (z >> 1) ^ (np.uint32(0) - (z & 1))


def unplane(raw: bytes, count: int) -> np.ndarray:
    return np.frombuffer(raw, dtype=np.uint8).reshape(4, count).T.copy().view(np.uint32).ravel()


def rebuild_scaled(base: np.ndarray, raw: bytes) -> np.ndarray:
    """The page's decoding rule for scaled rows (flags bit 2), on its own: the bitmap, four
    planes of the scales, four planes of the floats coded against the base times the scale."""
    rows = base.size // 3
    nbitmap = (rows + 7) // 8
    bits = np.unpackbits(np.frombuffer(raw[:nbitmap], dtype=np.uint8), bitorder="little")[:rows].astype(bool)
    changed = int(bits.sum())
    assert len(raw) == nbitmap + 16 * changed
    codes = unplane(raw[nbitmap : nbitmap + 4 * changed], changed)
    scales = (np.uint32(0x3F800000) + unzigzag(codes)).view(np.float32)
    old = base.reshape(-1, 3)[bits]
    predicted = np.where((codes == 0)[:, None], old, old * scales[:, None])  # float32 products
    d = unzigzag(unplane(raw[nbitmap + 4 * changed :], 3 * changed))
    out = base.view(np.uint32).reshape(-1, 3).copy()
    out[bits] = (predicted.view(np.uint32).ravel() + d).reshape(-1, 3)
    return out.ravel().view(np.float32)


def scaled_raw(base: np.ndarray, new: np.ndarray) -> bytes:
    """A scaled delta's zstd input written from the page: each changed row's scale is
    new[k] / base[k] for the base's float largest in magnitude (1.0 where that is not finite)."""
    old, now = base.reshape(-1, 3), new.reshape(-1, 3)
    changed = (old.view(np.uint32) != now.view(np.uint32)).any(axis=1)
    o, n = old[changed], now[changed]
    k = np.abs(o).argmax(axis=1)
    rows = np.arange(len(o))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (n[rows, k] / o[rows, k]).astype(np.float32)
    s[~np.isfinite(s)] = 1.0
    dz = (s.view(np.uint32) - np.uint32(0x3F800000)).view(np.int32)
    codes = ((dz << 1) ^ (dz >> 31)).view(np.uint32)
    predicted = np.where((codes == 0)[:, None], o, o * s[:, None])
    d = (n.view(np.uint32) - predicted.view(np.uint32)).ravel().view(np.int32)
    z = ((d << 1) ^ (d >> 31)).view(np.uint32)
    bitmap = np.packbits(changed, bitorder="little").tobytes()
    return bitmap + codes.view(np.uint8).reshape(-1, 4).T.tobytes() + z.view(np.uint8).reshape(-1, 4).T.tobytes()


def test_the_pages_scaled_example_lengthens_the_second_point():
    raw = scaled_example_bytes()
    assert len(raw) == 17
    base = np.array([1, 2, 3, 4, 5, 6], dtype=np.float32)
    assert rebuild_scaled(base, raw).tolist() == [1, 2, 3, 6, 7.5, 9]
    assert scaled_raw(base, np.array([1, 2, 3, 6, 7.5, 9], dtype=np.float32)) == raw


def test_a_colon_sized_scaled_delta_rebuilds_bit_for_bit_and_is_smaller():
    # Wall tips pushed along their own spokes: each row times one factor, rounded to float32.
    base, new = colon_sized(5, lambda row, rng: row * np.float32(1 + rng.normal(0, 0.01)))
    raw = scaled_raw(base, new)
    assert np.array_equal(rebuild_scaled(base, raw).view(np.uint32), new.view(np.uint32))
    scaled = len(zstandard.ZstdCompressor(level=-1).compress(raw))
    plain = len(delta_frame()(1, 2, 1, base, new, 2)) - 56
    assert scaled < 0.7 * plain, f"scaled {scaled} bytes, plain {plain}"
