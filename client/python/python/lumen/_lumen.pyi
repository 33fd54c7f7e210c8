"""Type stubs of the native module ``lumen._lumen`` (re-exported by ``lumen``)."""

from __future__ import annotations

import os
from types import TracebackType
from typing import Any, Dict, List, Mapping, Optional, Tuple, Type, Union

import numpy as np
import numpy.typing as npt

Spec = Union[str, Mapping[str, Any]]
"""A scene spec: JSON text, or a dict of the same shape (proto/README.md)."""

CONTACT_BYTES: int
PROTOCOL_VERSION: int
NO_INDEX: int
NO_SPOKE: int
FLAG_NOT_STAR: int
FLAG_OUTSIDE: int
FLAG_OTHER_WALL: int
KIND_INTERIOR: int
KIND_EXTERIOR: int
KIND_SELF: int
MAX_OTHER_WALLS: int
__version__: str

def contact_fields() -> List[Tuple[str, str, int]]:
    """The contact record's fields: (name, NumPy format, byte offset)."""

def now_ns() -> int:
    """Nanoseconds on this process's monotonic clock (what ``submit()`` stamps frames with)."""

class Reply:
    """One reply of the daemon to one frame; the contacts are a copy (valid for ever).

    A refused frame still gets a reply: ``ok`` is False, ``status``/``status_name`` say why,
    ``message`` explains, ``error_*`` point at a bad value, ``contacts`` is empty;
    ``raise_for_status()`` raises it as ``lumen.FrameError``.
    """

    session: int
    frame: int
    status: int
    message: str
    detect_ns: int
    skipped: int
    error_body: Optional[int]
    error_index: Optional[int]
    error_spoke: Optional[int]
    client_time_ns: int
    truncated: bool
    contacts: np.ndarray
    """Structured array of ``lumen.CONTACT_DTYPE`` (pair, kind, flags, body_a, body_b, sample,
    segment_a, param_a, index_b, spoke_b, param_b, weights_b[4], point_a[3], point_b[3],
    normal[3], depth)."""
    @property
    def ok(self) -> bool: ...
    @property
    def status_name(self) -> str:
        """"ok", "malformed", "bad_version", "bad_session", "bad_length", "bad_counts",
        "non_finite", "not_star_shaped", "internal", "out_of_range", "no_base", "bad_delta" or
        "unknown"."""
    @property
    def detect_us(self) -> float: ...
    @property
    def round_trip_us(self) -> float: ...
    def raise_for_status(self) -> Reply:
        """Raises ``lumen.FrameError`` if the frame was refused, else returns ``self``."""
    def __len__(self) -> int: ...

class ObservedFrame:
    """A frame an observer saw (``state`` is a read-only copy)."""

    session: int
    frame: int
    client_time_ns: int
    state: npt.NDArray[np.float32]

class Client:
    """A connection to the daemon. Belongs to the thread that made it (as do its sessions and
    observers)."""

    @staticmethod
    def local(prefix: Optional[str] = None, name: Optional[str] = None) -> Client:
        """Over iceoryx2 shared memory on this machine; ``prefix`` is the daemon's ``--prefix``
        (default: ``LUMEN_IOX2_PREFIX``). Raises ``NoDaemonError`` if none answers."""
    @staticmethod
    def zenoh(endpoint: str, name: Optional[str] = None) -> Client:
        """Over zenoh, e.g. ``"tcp/127.0.0.1:7447"``."""
    @staticmethod
    def zenoh_tls(endpoint: str, root_ca: Union[str, os.PathLike[str]], name: Optional[str] = None) -> Client:
        """Over zenoh TLS (``"tls/host:port"``), trusting the CA in the PEM file ``root_ca``."""
    @property
    def transport(self) -> str:
        """``"iceoryx2"`` or ``"zenoh"``."""
    def open_session(self, spec: Spec) -> Session:
        """Opens a session; an invalid spec raises ``RefusedError`` (``code == "spec"``)."""
    def observe(self, session: int) -> Observer:
        """Watches session ``session``'s frames and replies."""
    def describe(self, session: int) -> Dict[str, Any]: ...
    def status(self) -> Dict[str, Any]:
        """``pid``, ``version``, ``uptime_s``, ``sessions`` (frames, bad_frames, fps, ...)."""

class Session:
    """One scene on the daemon. ``frame()`` is valid only until ``submit()`` (zero copy)."""

    @property
    def id(self) -> int: ...
    @property
    def floats(self) -> int: ...
    @property
    def layout(self) -> List[Dict[str, Any]]:
        """Per body: ``name``, ``offset``, ``points``, ``spokes`` (0 for a rod)."""
    @property
    def max_contacts(self) -> int: ...
    @property
    def transport(self) -> str: ...
    @property
    def reconnects(self) -> int: ...
    @property
    def next_frame(self) -> int: ...
    @property
    def closed(self) -> bool: ...
    def frame(self) -> npt.NDArray[np.float32]:
        """A writable float32 array over the frame itself, valid until ``submit()`` (then
        read-only and undefined); write every value."""
    def submit(self, client_time_ns: Optional[int] = None) -> int:
        """Sends the frame; returns its number. The frame array becomes read-only."""
    def submit_state(self, state: npt.NDArray[np.float32], client_time_ns: Optional[int] = None) -> int:
        """Copies ``state`` into a frame and submits it."""
    def contacts(self, timeout: float = 1.0) -> Reply:
        """The next reply, waiting up to ``timeout`` s (``lumen.TimeoutError`` otherwise)."""
    def try_contacts(self) -> Optional[Reply]: ...
    def info(self) -> Dict[str, Any]: ...
    def close(self) -> None: ...
    def __enter__(self) -> Session: ...
    def __exit__(self, exc_type: Optional[Type[BaseException]], exc: Optional[BaseException], tb: Optional[TracebackType]) -> bool: ...

class Observer:
    """Watches a session without slowing it."""

    @property
    def session(self) -> int: ...
    def every_frame(self) -> None:
        """Every frame in order, not the newest: over iceoryx2 up to 8 frames behind lose
        none; over zenoh nothing changes."""
    def next(self, timeout: float = 1.0) -> Union[ObservedFrame, Reply]:
        """The next frame or reply; ``lumen.TimeoutError`` if none, ``SessionEndedError`` once
        the session is gone."""
    def close(self) -> None: ...
    def __enter__(self) -> Observer: ...
    def __exit__(self, exc_type: Optional[Type[BaseException]], exc: Optional[BaseException], tb: Optional[TracebackType]) -> bool: ...

class Detector:
    """Embedded detection for one scene, in this process."""

    def __init__(self, spec: Spec) -> None:
        """Raises ``lumen.SpecError`` for an invalid spec."""
    @property
    def floats(self) -> int: ...
    @property
    def layout(self) -> List[Dict[str, Any]]: ...
    @property
    def spec(self) -> Dict[str, Any]: ...
    def detect(self, state: npt.NDArray[np.float32]) -> np.ndarray:
        """One frame's contacts (structured array of ``CONTACT_DTYPE``); ``BadStateError`` for a
        wrong length or a non-finite value."""
