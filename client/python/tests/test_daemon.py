"""Through a real daemon (`lumen serve`, spawned per test), on both transports: round trips
that match the embedded detector and the closed form, the zero-copy frame rule, an observer,
a bad frame's status, refusals and closing."""

import os
import time

import numpy as np
import pytest

import lumen
import straight_tube as st
from conftest import free_port, shm_files, unique_prefix

TRANSPORTS = ["iceoryx2", "zenoh"]
WAIT = 3.0
# Pressing the wall at growing, then easing offsets; one frame on the axis (no contact).
OFFSETS = [8.5, 8.6, 8.8, 9.0, 0.0, 8.7, 9.1, 8.25]


def eventually(f, limit=3.0):
    end = time.monotonic() + limit
    while True:
        if f():
            return True
        if time.monotonic() > end:
            return False
        time.sleep(0.02)


def reply_to(session, n):
    """The reply to frame ``n`` (older replies skipped)."""
    while True:
        r = session.contacts(WAIT)
        if r.frame == n:
            return r
        assert r.frame < n, f"a reply to frame {r.frame} before frame {n}'s"


def first_round_trip(session, state):
    """Frame and reply until the first one is answered (a zenoh subscription may take a moment
    to reach the daemon); returns (frame number, reply)."""
    for _ in range(5):
        f = session.frame()
        f[:] = state
        n = session.submit()
        try:
            return n, reply_to(session, n)
        except lumen.TimeoutError:
            continue
    raise AssertionError("no reply to five frames")


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_round_trip_matches_the_embedded_detector_and_the_closed_form(start_daemon, transport):
    d = start_daemon("rt", zenoh=transport == "zenoh")
    client = d.client(transport)
    assert client.transport == transport
    reference = lumen.Detector(st.SPEC)
    with client.open_session(st.SPEC_JSON) as s:
        assert s.transport == transport
        assert s.floats == st.FLOATS
        assert s.layout == reference.layout
        # A reply holds every wall a sample may report: its first and up to MAX_OTHER_WALLS more.
        assert s.max_contacts == st.SAMPLES * (1 + lumen.MAX_OTHER_WALLS) == st.SAMPLES * 4
        n0, r = first_round_trip(s, st.state(8.5))
        assert r.ok and r.status == 0 and r.status_name == "ok" and r.message == ""
        assert r.contacts.tobytes() == reference.detect(st.state(8.5)).tobytes()
        for offset in OFFSETS:
            frame = s.frame()
            st.state(offset, out=frame)  # written in place: the frame itself
            n = s.submit()
            r = reply_to(s, n)
            assert (r.session, r.frame, r.ok) == (s.id, n, True), r
            assert r.error_body is None and r.error_index is None and r.error_spoke is None
            assert r.detect_ns > 0 and r.client_time_ns > 0 and not r.truncated
            expected = reference.detect(st.state(offset))
            assert r.contacts.dtype == lumen.CONTACT_DTYPE
            assert r.contacts.tobytes() == expected.tobytes(), f"offset {offset}: the daemon's contacts differ from the embedded detector's"
            assert len(r) == (st.SAMPLES if st.expected_depth(offset) > 0 else 0)
            if len(r):
                np.testing.assert_allclose(r.contacts["depth"], st.expected_depth(offset), atol=1e-3)
                np.testing.assert_allclose(r.contacts["normal"][:, 1], 1.0, atol=1e-3)
        frames = n0 + 1 + len(OFFSETS)
        # The daemon counts a frame just after sending its reply.
        assert eventually(lambda: [x["frames"] for x in client.status()["sessions"]] == [frames]), client.status()
        assert client.status()["sessions"][0]["session"] == s.id
        assert client.status()["sessions"][0]["client"] == "pytest"
    assert s.closed
    with pytest.raises(lumen.ClosedError):
        s.frame()
    assert eventually(lambda: client.status()["sessions"] == []), client.status()


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_the_frame_is_writable_until_submit_only(start_daemon, transport):
    d = start_daemon("zc", zenoh=transport == "zenoh")
    s = d.client(transport).open_session(st.SPEC)
    first_round_trip(s, st.state(8.5))
    f = s.frame()
    assert f.dtype == np.float32 and f.shape == (st.FLOATS,) and f.flags.writeable and f.flags.c_contiguous
    assert not f.flags.owndata, "the frame array must be a view over the session's frame, not a copy"
    assert s.frame() is f, "frame() before submit() returns the same frame"
    st.state(8.5, out=f)
    # The array is the frame: a value written through it reaches the daemon.
    f[st.rod_index(3, 1)] = 9.5  # one rod point pushed 1 mm harder
    n = s.submit()
    assert not f.flags.writeable, "a submitted frame's array must become read-only"
    with pytest.raises(ValueError):
        f[0] = 1.0
    with pytest.raises(ValueError):
        f.flags.writeable = True
    r = reply_to(s, n)
    expected = st.state(8.5)
    expected[st.rod_index(3, 1)] = 9.5
    assert r.contacts.tobytes() == lumen.Detector(st.SPEC).detect(expected).tobytes()
    # Sample 12 sits on point 3: 1 mm deeper than the others.
    assert r.contacts["depth"][12] == pytest.approx(st.expected_depth(9.5), abs=1e-3)
    assert r.contacts["depth"][0] == pytest.approx(st.expected_depth(8.5), abs=1e-3)
    g = s.frame()
    assert g is not f and g.flags.writeable
    st.state(9.0, out=g)
    s.submit()
    with pytest.raises(lumen.NoFrameError, match="call frame"):
        s.submit()
    h = s.frame()
    s.close()
    assert not h.flags.writeable, "closing must make the frame array read-only"
    with pytest.raises(lumen.ClosedError):
        s.submit()


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_a_bad_frame_gets_its_status_and_the_session_goes_on(start_daemon, transport):
    d = start_daemon("bad", zenoh=transport == "zenoh")
    client = d.client(transport)
    s = client.open_session(st.SPEC)
    reference = lumen.Detector(st.SPEC)
    n0, r = first_round_trip(s, st.state(8.5))
    assert r.ok
    bad = st.state(9.0)
    bad[st.spoke_index(3, 5, 1)] = np.nan  # tube ring 3, spoke 5, y
    n = s.submit_state(bad)
    r = reply_to(s, n)
    assert not r.ok
    assert (r.status, r.status_name) == (6, "non_finite")
    assert (r.error_body, r.error_index, r.error_spoke) == (0, 3, 5)
    assert "ring 3" in r.message and len(r.contacts) == 0
    with pytest.raises(lumen.FrameError) as e:
        r.raise_for_status()
    assert (e.value.status, e.value.status_name, e.value.frame) == (6, "non_finite", n)
    assert (e.value.error_body, e.value.error_index, e.value.error_spoke) == (0, 3, 5)
    assert isinstance(e.value, lumen.LumenError)
    bad = st.state(9.0)
    bad[st.rod_index(2, 0)] = np.inf  # rod point 2, x
    r = reply_to(s, s.submit_state(bad))
    assert (r.status_name, r.error_body, r.error_index, r.error_spoke) == ("non_finite", 1, 2, None)
    # The session goes on.
    r = reply_to(s, s.submit_state(st.state(9.0))).raise_for_status()
    assert r.contacts.tobytes() == reference.detect(st.state(9.0)).tobytes()
    np.testing.assert_allclose(r.contacts["depth"], st.expected_depth(9.0), atol=1e-3)
    counts = lambda: [(x["frames"], x["bad_frames"]) for x in client.status()["sessions"]]  # noqa: E731
    assert eventually(lambda: counts() == [(n0 + 4, 2)]), counts()


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_observers_beyond_the_limit_are_refused_with_observers_full(start_daemon, transport):
    d = start_daemon("full", zenoh=transport == "zenoh", args=["--max-observers", "1"])
    s = d.client(transport).open_session(st.SPEC)
    watcher = d.client(transport)
    first = watcher.observe(s.id)
    with pytest.raises(lumen.RefusedError) as e:
        watcher.observe(s.id)
    assert e.value.code == "observers_full" and "max_observers" in str(e.value), str(e.value)
    # The place comes back once the first observer is closed.
    first.close()
    deadline = time.monotonic() + WAIT
    while True:
        try:
            watcher.observe(s.id).close()
            break
        except lumen.RefusedError:
            assert time.monotonic() < deadline, "the place never came back"
            time.sleep(0.05)
    s.close()


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_an_observer_sees_the_sessions_frames_and_contacts(start_daemon, transport):
    d = start_daemon("obs", zenoh=transport == "zenoh")
    s = d.client(transport).open_session(st.SPEC)
    watcher = d.client(transport)
    obs = watcher.observe(s.id)
    assert obs.session == s.id
    first_round_trip(s, st.state(8.5))
    seen_frames, seen_replies = [], []
    for k, offset in enumerate(OFFSETS):
        n = s.submit_state(st.state(offset))
        mine = reply_to(s, n)
        got = [False, False]
        while got != [True, True]:
            o = obs.next(WAIT)
            assert o.session == s.id
            if isinstance(o, lumen.ObservedFrame):
                seen_frames.append(o.frame)
                if o.frame == n:
                    assert o.state.dtype == np.float32 and not o.state.flags.writeable
                    assert o.state.tobytes() == st.state(offset).tobytes()
                    got[0] = True
            else:
                assert isinstance(o, lumen.Reply)
                seen_replies.append(o.frame)
                if o.frame == n:
                    assert o.ok and o.contacts.tobytes() == mine.contacts.tobytes()
                    if st.expected_depth(offset) > 0:
                        np.testing.assert_allclose(o.contacts["depth"], st.expected_depth(offset), atol=1e-3)
                    got[1] = True
    assert len(set(seen_frames)) >= len(OFFSETS) and len(set(seen_replies)) >= len(OFFSETS)
    id = s.id
    s.close()
    # The observer is told the session ended.
    with pytest.raises(lumen.SessionEndedError) as e:
        while True:
            obs.next(WAIT)
    assert e.value.session == id


def test_an_observer_of_every_frame_keeps_sixteen_frames_over_iceoryx2(start_daemon):
    d = start_daemon("every")
    s = d.client("iceoryx2").open_session(st.SPEC)
    watcher = d.client("iceoryx2")
    every, newest = watcher.observe(s.id), watcher.observe(s.id)
    every.every_frame()

    def drained(obs):
        frames, replies = [], []
        while True:
            try:
                o = obs.next(0.3)
            except lumen.TimeoutError:
                return frames, replies
            (frames if isinstance(o, lumen.ObservedFrame) else replies).append(o.frame)

    # Twenty frames while neither observer reads: the client never waits for them; one keeps
    # the last sixteen in order with their replies, the other skips to the newest.
    sent = []
    for k in range(20):
        n = s.submit_state(st.state(8.5 + 0.1 * k))
        reply_to(s, n)
        sent.append(n)
    frames, replies = drained(every)
    assert frames == sent[-16:] and replies == sent[-16:], (frames, replies)
    frames, _ = drained(newest)
    assert frames == sent[-1:], frames
    s.close()


@pytest.mark.parametrize("transport", TRANSPORTS)
def test_an_invalid_spec_is_refused_with_the_daemons_code(start_daemon, transport):
    d = start_daemon("ref", zenoh=transport == "zenoh")
    client = d.client(transport)
    with pytest.raises(lumen.RefusedError) as e:
        client.open_session(st.SPEC_JSON.replace('"rings":11', '"rings":1'))
    assert e.value.code == "spec" and "control points" in e.value.reason
    with pytest.raises(lumen.RefusedError) as e:
        client.observe(12345)
    assert e.value.code == "unknown_session"
    with pytest.raises(lumen.SpecError):
        client.open_session("{not json")


def test_no_daemon_is_a_typed_error_saying_what_to_do():
    prefix = unique_prefix("none")
    try:
        client = lumen.Client.local(prefix=prefix)
        with pytest.raises(lumen.NoDaemonError, match="lumen serve") as e:
            client.open_session(st.SPEC)
        assert isinstance(e.value, ConnectionError) and e.value.transport == "iceoryx2"
        del client
    finally:
        left = shm_files(prefix)
        if all(f.endswith(".global_mgmt") for f in left):
            for f in left:
                os.remove(os.path.join("/dev/shm", f))
    port = free_port()  # nobody listens there
    with pytest.raises(lumen.LumenError) as e:
        lumen.Client.zenoh(f"tcp/127.0.0.1:{port}").open_session(st.SPEC)
    assert isinstance(e.value, (lumen.NoDaemonError, lumen.TransportError)), e.value


def test_a_lost_daemon_is_disconnected_and_the_session_reopens(start_daemon):
    d = start_daemon("lost")
    s = d.client("iceoryx2").open_session(st.SPEC)
    first_round_trip(s, st.state(8.5))
    f = s.frame()
    st.state(8.5, out=f)
    assert d.stop() == 0, "the daemon did not stop cleanly on SIGTERM"
    with pytest.raises(lumen.DisconnectedError, match="keep submitting"):
        s.submit()
        s.contacts(WAIT)
    assert isinstance(lumen.DisconnectedError("x"), ConnectionError)
    # A new daemon on the same prefix: the session reopens by itself on a later frame.
    start_daemon("lost", prefix=d.prefix)
    for _ in range(50):
        try:
            r = reply_to(s, s.submit_state(st.state(9.0)))
            break
        except (lumen.DisconnectedError, lumen.TimeoutError):
            time.sleep(0.1)
    else:
        raise AssertionError("the session did not reopen")
    assert s.reconnects == 1
    assert r.ok and len(r) == st.SAMPLES
    np.testing.assert_allclose(r.contacts["depth"], st.expected_depth(9.0), atol=1e-3)
