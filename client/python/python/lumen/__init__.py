"""Lumen from Python: collision detection for endoscopy simulators.

- :class:`Client`: a connection to the daemon (``lumen serve``), on this machine over iceoryx2
  shared memory (:meth:`Client.local`) or over the network (:meth:`Client.zenoh`).
- :class:`Session`: one scene; write each frame in place (``frame()``, a float32 array over the
  frame itself), ``submit()`` it, read its :class:`Reply` (``contacts()``).
- :class:`Observer`: watches a session's frames and replies.
- :class:`Detector`: embedded detection in this process, no daemon.

Contacts are NumPy structured arrays of :data:`CONTACT_DTYPE` (the 88-byte wire record).
Errors derive from :class:`LumenError` (see :mod:`lumen.errors`).
"""

from . import _lumen
from ._dtype import CONTACT_DTYPE
from ._lumen import (
    CONTACT_BYTES,
    FLAG_NOT_STAR,
    FLAG_OTHER_WALL,
    FLAG_OUTSIDE,
    KIND_EXTERIOR,
    KIND_INTERIOR,
    KIND_SELF,
    MAX_OTHER_WALLS,
    NO_INDEX,
    NO_SPOKE,
    PROTOCOL_VERSION,
    Client,
    Detector,
    ObservedFrame,
    Observer,
    Reply,
    Session,
    now_ns,
)
from .errors import (
    BadStateError,
    ClosedError,
    DisconnectedError,
    FrameError,
    LumenError,
    NoDaemonError,
    NoFrameError,
    ProtocolError,
    RefusedError,
    SessionEndedError,
    SpecError,
    TimeoutError,
    TransportError,
)

__version__ = _lumen.__version__

__all__ = [
    "CONTACT_BYTES",
    "CONTACT_DTYPE",
    "FLAG_NOT_STAR",
    "FLAG_OTHER_WALL",
    "FLAG_OUTSIDE",
    "KIND_EXTERIOR",
    "KIND_INTERIOR",
    "KIND_SELF",
    "MAX_OTHER_WALLS",
    "NO_INDEX",
    "NO_SPOKE",
    "PROTOCOL_VERSION",
    "BadStateError",
    "Client",
    "ClosedError",
    "Detector",
    "DisconnectedError",
    "FrameError",
    "LumenError",
    "NoDaemonError",
    "NoFrameError",
    "ObservedFrame",
    "Observer",
    "ProtocolError",
    "RefusedError",
    "Reply",
    "Session",
    "SessionEndedError",
    "SpecError",
    "TimeoutError",
    "TransportError",
    "now_ns",
]
