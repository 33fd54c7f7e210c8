"""Embedded detection (no daemon): the closed-form depths of client/c/examples/straight_tube.c."""

import math

import numpy as np
import pytest

import lumen
import straight_tube as st

TOLERANCE = 1e-3


def check_frame(contacts: np.ndarray, offset: float) -> None:
    """Every contact of one frame against the closed form (what the C example checks)."""
    expected = st.expected_depth(offset)
    assert contacts.dtype == lumen.CONTACT_DTYPE
    assert len(contacts) == (st.SAMPLES if expected > 0 else 0)
    if len(contacts) == 0:
        return
    np.testing.assert_allclose(contacts["depth"], expected, atol=TOLERANCE)
    np.testing.assert_allclose(contacts["normal"], np.tile([0.0, 1.0, 0.0], (len(contacts), 1)), atol=TOLERANCE)
    np.testing.assert_allclose(contacts["point_b"][:, 1], st.APOTHEM, atol=TOLERANCE)
    # The deepest point of the rod: its side facing the wall, at offset + r.
    np.testing.assert_allclose(contacts["point_a"][:, 1], offset + st.ROD_R, atol=TOLERANCE)
    np.testing.assert_array_equal(contacts["sample"], np.arange(st.SAMPLES))
    np.testing.assert_array_equal(contacts["segment_a"], np.minimum(np.arange(st.SAMPLES) // st.PRECISION, st.POINTS - 2))
    assert (contacts["pair"] == 0).all() and (contacts["kind"] == lumen.KIND_INTERIOR).all()
    assert (contacts["body_a"] == 1).all() and (contacts["body_b"] == 0).all()
    assert (contacts["spoke_b"] == st.SPOKES - 1).all()
    assert not (contacts["flags"] & lumen.FLAG_OUTSIDE).any()
    # Rod from x = 20 to 80 in a tube whose rings are 10 apart: sample x = 20 + 2.5 i.
    np.testing.assert_allclose(contacts["point_a"][:, 0], 20.0 + 2.5 * np.arange(st.SAMPLES), atol=TOLERANCE)
    x = contacts["point_a"][:, 0]
    ring = contacts["index_b"].astype(float)
    assert ((ring * st.SPACING <= x + TOLERANCE) & (x <= (ring + 1) * st.SPACING + TOLERANCE)).all(), "a contact on the wrong ring pair"
    np.testing.assert_allclose(contacts["point_b"][:, 0], x, atol=TOLERANCE)
    np.testing.assert_allclose(contacts["weights_b"].sum(axis=1), 1.0, atol=1e-5)


def test_the_contact_dtype_is_the_wire_record():
    dt = lumen.CONTACT_DTYPE
    assert dt.itemsize == 88 == lumen.CONTACT_BYTES
    # proto/README.md, section 3, and the C example's static asserts.
    offsets = {name: dt.fields[name][1] for name in dt.names}
    assert offsets == {
        "pair": 0, "kind": 2, "flags": 3, "body_a": 4, "body_b": 6, "sample": 8, "segment_a": 12, "param_a": 16,
        "index_b": 20, "spoke_b": 24, "param_b": 28, "weights_b": 32, "point_a": 48, "point_b": 60, "normal": 72, "depth": 84,
    }  # fmt: skip


def test_straight_tube_depths_match_the_closed_form():
    det = lumen.Detector(st.SPEC_JSON)
    assert det.floats == st.FLOATS == 11 * 33 * 3 + 7 * 3
    assert det.layout == [
        {"name": "colon", "offset": 0, "points": 11, "spokes": 32},
        {"name": "scope", "offset": 11 * 33 * 3, "points": 7, "spokes": 0},
    ]
    depths = []
    # Pressing the wall, pressing harder, then on the axis (clear of the wall): the C example's frames.
    for offset in (8.5, 9.0, 0.0):
        contacts = det.detect(st.state(offset))
        check_frame(contacts, offset)
        depths.append(float(contacts["depth"][0]) if len(contacts) else 0.0)
    # d + r - a with the 32-gon's apothem a = R cos(pi/32): 0.5482 and 1.0482, as the C example prints.
    np.testing.assert_allclose(depths, [st.expected_depth(8.5), st.expected_depth(9.0), 0.0], atol=1e-4)
    assert abs(depths[0] - 0.54815) < 1e-4
    assert math.isclose(depths[1] - depths[0], 0.5, abs_tol=1e-5)


def test_a_dict_spec_detects_as_its_json():
    a, b = lumen.Detector(st.SPEC_JSON), lumen.Detector(st.SPEC)
    state = st.state(8.75)
    assert a.detect(state).tobytes() == b.detect(state).tobytes()
    assert b.spec["precision"] == 4 and b.spec["bodies"][1]["name"] == "scope"


def test_contacts_are_a_copy():
    det = lumen.Detector(st.SPEC)
    first = det.detect(st.state(8.5))
    kept = first.copy()
    det.detect(st.state(9.0))
    assert first.tobytes() == kept.tobytes(), "the next frame overwrote an array handed out"
    assert first.flags.owndata or first.base is not None


def test_bad_states_are_refused_with_where_and_the_history_is_kept():
    det = lumen.Detector(st.SPEC)
    check_frame(det.detect(st.state(8.5)), 8.5)
    with pytest.raises(lumen.BadStateError, match=f"state has {st.FLOATS - 1} floats") as e:
        det.detect(st.state(8.5)[:-1].copy())
    assert isinstance(e.value, lumen.LumenError) and isinstance(e.value, ValueError)
    bad = st.state(9.0)
    bad[st.spoke_index(3, 5, 1)] = np.nan
    with pytest.raises(lumen.BadStateError) as e:
        det.detect(bad)
    assert (e.value.body, e.value.body_index, e.value.index, e.value.spoke) == ("colon", 0, 3, 5)
    assert "ring 3" in str(e.value)
    bad = st.state(9.0)
    bad[st.rod_index(2, 0)] = np.inf
    with pytest.raises(lumen.BadStateError) as e:
        det.detect(bad)
    assert (e.value.body, e.value.body_index, e.value.index, e.value.spoke) == ("scope", 1, 2, None)
    # The next good frame goes on.
    check_frame(det.detect(st.state(9.0)), 9.0)


def test_a_state_of_another_dtype_is_a_type_error():
    det = lumen.Detector(st.SPEC)
    with pytest.raises(TypeError):
        det.detect(st.state(8.5).astype(np.float64))


def test_invalid_specs_raise_spec_error_naming_the_problem():
    with pytest.raises(lumen.SpecError, match="control points"):
        lumen.Detector(st.SPEC_JSON.replace('"rings":11', '"rings":1'))
    with pytest.raises(lumen.SpecError):
        lumen.Detector("{not json")
    with pytest.raises(lumen.SpecError, match="nowhere"):
        lumen.Detector(dict(st.SPEC, pairs=[{"a": "scope", "b": "nowhere", "kind": "interior"}]))
