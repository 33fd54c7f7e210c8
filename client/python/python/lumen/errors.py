"""Lumen's exceptions: every one derives from :class:`LumenError` and says what to do."""

from __future__ import annotations

import builtins
from typing import Any, Optional

__all__ = [
    "LumenError",
    "NoDaemonError",
    "RefusedError",
    "TimeoutError",
    "DisconnectedError",
    "NoFrameError",
    "SessionEndedError",
    "ClosedError",
    "TransportError",
    "ProtocolError",
    "SpecError",
    "BadStateError",
    "FrameError",
]


class LumenError(Exception):
    """Base of every Lumen error. ``str(e)`` says what went wrong and what to do."""

    def __init__(self, message: str, **details: Any) -> None:
        super().__init__(message)
        self.message = message
        for key, value in details.items():
            setattr(self, key, value)


class NoDaemonError(LumenError, ConnectionError):
    """No daemon answered: start one with ``lumen serve`` (same iceoryx2 prefix / zenoh endpoint); one that runs may be too busy to answer in time.

    ``transport``: ``"iceoryx2"`` or ``"zenoh"``.
    """

    transport: str


class RefusedError(LumenError):
    """The daemon refused the request.

    ``code`` is the daemon's code: ``"bad_request"``, ``"version"``, ``"spec"`` (the spec is
    invalid; ``reason`` names the body, pair or field), ``"limit"`` (beyond the daemon's
    configured limits), ``"busy"`` (too many sessions), ``"unknown_session"``, ``"internal"``.
    """

    code: str
    reason: str


class TimeoutError(LumenError, builtins.TimeoutError):
    """Nothing within the timeout; the session still works: wait again or submit the next frame.

    ``timeout``: the wait, in seconds.
    """

    timeout: float


class DisconnectedError(LumenError, ConnectionError):
    """The daemon went away: keep submitting, the session reopens by itself (new id, same spec)
    once a daemon answers again. Frame arrays handed out before are no longer usable."""


class NoFrameError(LumenError):
    """``submit()`` without a frame: call ``frame()`` and write it first."""


class SessionEndedError(LumenError):
    """The observed session ended (its client left or the daemon stopped). ``session``: its id."""

    session: int


class ClosedError(LumenError):
    """A call on a closed session or observer: open a new one."""


class TransportError(LumenError):
    """The transport failed (iceoryx2: shared memory exhausted, permissions, incompatible
    service; zenoh: endpoint unreachable, bad configuration)."""


class ProtocolError(LumenError):
    """The daemon sent something this client does not understand (version mismatch?)."""


class SpecError(LumenError, ValueError):
    """The scene spec is not valid JSON for a spec, or is invalid (the message names the body,
    pair or field). See proto/README.md for the format."""


class BadStateError(LumenError, ValueError):
    """The embedded detector refused a state: wrong length, a non-finite value, a ring that is
    not star-shaped. The frame was not used and the detector's history is kept: fix the state
    and call ``detect`` again.

    ``body`` (name) and ``body_index`` say which body, ``index`` the control point or ring,
    ``spoke`` the radial vector (None for a control point, or when not applicable).
    """

    body: Optional[str]
    body_index: Optional[int]
    index: Optional[int]
    spoke: Optional[int]


class FrameError(LumenError):
    """The daemon refused a frame (raised by ``Reply.raise_for_status()``); the session goes on.

    ``status`` (int) and ``status_name`` (``"non_finite"``, ``"bad_length"``, ...) say why,
    ``reason`` is the daemon's message, ``frame`` the frame number, and ``error_body``,
    ``error_index``, ``error_spoke`` point at a bad value (or are None).
    """

    status: int
    status_name: str
    reason: str
    frame: int
    error_body: Optional[int]
    error_index: Optional[int]
    error_spoke: Optional[int]
