"""Ctrl-C for the ``bo2`` command: a stop request that renders and bakes poll, and a deadline.

Once ``bpy`` is imported, SIGINT no longer raises KeyboardInterrupt in Python. ``install``
routes it to a flag: the BO2 engine's render and the bake's captures stop at their next poll
(within a tile) and the command raises KeyboardInterrupt itself (``check``), keeping what it
finished. A render that cannot poll (Cycles runs in C and does not return to Python before it
ends) is ended by a watcher thread, woken by the signal's wakeup file descriptor: ``GRACE``
seconds after Ctrl-C it prints ``bo2: interrupted`` and exits with 130, but never while a file
is being written (``writing``). In the Blender UI nothing installs it and the flag stays down.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import threading
import time

GRACE = 0.8  # seconds the command has to stop by itself before it is ended
_requested = threading.Event()
_files = threading.Lock()  # held while a file is written
_installed: list = []


def install(terminal: int = 2) -> None:
    """From now on SIGINT sets the stop request, and ends the process ``GRACE`` seconds later
    if it is still running, saying so on file descriptor ``terminal`` (main thread only, where
    Python takes signals)."""
    if _installed or threading.current_thread() is not threading.main_thread():
        return
    reader, writer = socket.socketpair()
    writer.setblocking(False)

    def watch():
        while reader.recv(1) not in (b"", bytes([signal.SIGINT])):
            pass
        _requested.set()
        time.sleep(GRACE)
        with _files:
            os.write(terminal, b"\nbo2: interrupted\n")
            os._exit(130)

    signal.signal(signal.SIGINT, lambda *_: _requested.set())
    signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
    threading.Thread(target=watch, daemon=True, name="bo2 Ctrl-C").start()
    _installed.append((reader, writer))


def installed() -> bool:
    """Whether ``install`` has run in this process."""
    return bool(_installed)


def requested() -> bool:
    """Whether Ctrl-C was pressed since ``install``."""
    return _requested.is_set()


def check() -> None:
    """Raise KeyboardInterrupt when Ctrl-C was pressed."""
    if _requested.is_set():
        raise KeyboardInterrupt


def settle() -> None:
    """The command is ending by itself after Ctrl-C: the deadline no longer applies."""
    _files.acquire(blocking=False)


@contextlib.contextmanager
def writing():
    """A file write that Ctrl-C's deadline waits for (so that it is never left half-done)."""
    with _files:
        yield
