"""Fixtures: the `lumen` binary and daemons (`lumen serve`) started per test, each with its own
iceoryx2 prefix and, for zenoh, its own loopback port; stopped (and their prefix's leftovers
removed) at teardown."""

from __future__ import annotations

import gc
import itertools
import os
import queue
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path
from typing import Iterator, List, Optional, Sequence

import pytest

REPO = Path(__file__).resolve().parents[3]
_counter = itertools.count()


def unique_prefix(tag: str) -> str:
    """An iceoryx2 prefix nothing else uses: ``lt<pid>_<tag><n>_``."""
    return f"lt{os.getpid()}_{tag}{next(_counter)}_"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def shm_files(prefix: str) -> List[str]:
    try:
        return [n for n in os.listdir("/dev/shm") if n.startswith(prefix)]
    except FileNotFoundError:
        return []


@pytest.fixture(scope="session")
def lumen_bin() -> Path:
    """The daemon binary: ``$LUMEN_BIN``, else ``<repo>/target/debug/lumen``. Missing is a
    failure, never a skip."""
    path = Path(os.environ.get("LUMEN_BIN", REPO / "target" / "debug" / "lumen"))
    if not path.is_file():
        pytest.fail(
            f"the lumen binary {path} does not exist: build it with `cargo build -p lumen-cli --bin lumen` "
            "(from the repository root), or point LUMEN_BIN at one",
            pytrace=False,
        )
    return path


class Daemon:
    """A ``lumen serve`` child with its prefix (and zenoh port)."""

    def __init__(self, binary: Path, tag: str, zenoh: bool, prefix: Optional[str] = None, args: Sequence[str] = ()) -> None:
        self.prefix = prefix or unique_prefix(tag)
        self.port: Optional[int] = free_port() if zenoh else None
        cmd = [str(binary), "serve", "--prefix", self.prefix, "--log", "warn", *args]
        if self.port is not None:
            # The tests read every session from status: list them (the default shows counts only).
            cmd += ["--zenoh-listen", f"tcp/127.0.0.1:{self.port}", "--zenoh-status", "sessions"]
        self.process = subprocess.Popen(cmd, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
        self.lines: "queue.Queue[str]" = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        deadline = time.monotonic() + 30
        while True:
            left = deadline - time.monotonic()
            try:
                line = self.lines.get(timeout=max(left, 0.01))
            except queue.Empty:
                self.stop()
                raise AssertionError(f"the daemon ({' '.join(cmd)}) did not print its ready line within 30 s") from None
            if line.startswith("lumen serve: ready"):
                break

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.put(line)

    @property
    def endpoint(self) -> str:
        assert self.port is not None, "started without zenoh"
        return f"tcp/127.0.0.1:{self.port}"

    def client(self, transport: str):
        import lumen

        if transport == "zenoh":
            return lumen.Client.zenoh(self.endpoint, name="pytest")
        return lumen.Client.local(prefix=self.prefix, name="pytest")

    def stop(self) -> Optional[int]:
        """SIGTERM (the daemon releases its shared memory), SIGKILL after 5 s; then removes
        iceoryx2's per-prefix node counter if nothing else of the prefix is left."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        left = shm_files(self.prefix)
        if all(f.endswith(".global_mgmt") for f in left):
            for f in left:
                try:
                    os.remove(os.path.join("/dev/shm", f))
                except FileNotFoundError:
                    pass
        return self.process.returncode


@pytest.fixture
def start_daemon(lumen_bin: Path) -> Iterator:
    """``start_daemon(tag, zenoh=False, prefix=None, args=())`` starts a daemon (on a prefix of
    its own unless given one of an earlier daemon of the test; ``args`` added to ``lumen
    serve``'s); all are stopped at teardown."""
    started: List[Daemon] = []

    def start(tag: str, zenoh: bool = False, prefix: Optional[str] = None, args: Sequence[str] = ()) -> Daemon:
        d = Daemon(lumen_bin, tag, zenoh, prefix, args)
        started.append(d)
        return d

    yield start
    # Clients kept alive by a traceback cycle (pytest.raises) would keep their iceoryx2 node.
    gc.collect()
    for d in started:
        d.stop()
