"""Ctrl-C for the ``bo2`` command: a stop request that renders and bakes poll, and a deadline.

Once ``bpy`` is imported, SIGINT no longer raises KeyboardInterrupt in Python. ``install``
routes it to a flag: the BO2 engine's render and the bake's captures stop at their next poll
(within a tile) and the command raises KeyboardInterrupt itself (``check``), keeping what it
finished. A render that cannot poll (Cycles runs in C and does not return to Python before it
ends) is ended by a watcher thread, woken by the signal's wakeup file descriptor: ``GRACE``
seconds after Ctrl-C (later while a render still polls the request: it is stopping) it prints
``bo2: interrupted`` and exits with 130, but never while a file is being written
(``writing``) nor once the command settles to end by itself (``settle``). In the Blender
UI nothing installs it and the flag stays down.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import socket
import threading
import time

GRACE = 0.8  # seconds the command has to stop by itself before it is ended
PATIENCE = 20.0  # at most this long while it still polls the request (it is stopping)
_requested = threading.Event()
_files = threading.RLock()  # held while a file is written, and once the command settles
_polled = [0.0]  # when the request was last seen by a poll (time.monotonic)
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
        since = time.monotonic()  # a render that polls is stopping by itself: wait for it
        while (time.monotonic() - _polled[0] < GRACE
               and time.monotonic() - since < PATIENCE):
            time.sleep(0.05)
        with _files:
            os.write(terminal, b"\nbo2: interrupted\n")
            leave()
            os._exit(130)

    signal.signal(signal.SIGINT, lambda *_: _requested.set())
    signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
    threading.Thread(target=watch, daemon=True, name="bo2 Ctrl-C").start()
    _installed.append((reader, writer))


def installed() -> bool:
    """Whether ``install`` has run in this process."""
    return bool(_installed)


def requested() -> bool:
    """Whether Ctrl-C was pressed since ``install`` (a poll that sees it keeps the deadline
    away while it comes again within ``GRACE``: the command is stopping by itself)."""
    if _requested.is_set():
        _polled[0] = time.monotonic()
        return True
    return False


def check() -> None:
    """Raise KeyboardInterrupt when Ctrl-C was pressed."""
    if _requested.is_set():
        raise KeyboardInterrupt


def settle() -> None:
    """The command is ending by itself after Ctrl-C: the deadline no longer applies (the
    files lock is kept by this thread; ``writing`` may still take it again)."""
    _files.acquire(blocking=False)


_cleanups: list = []  # what ``leave`` runs: temporary files of this process


def at_exit(cleanup) -> None:
    """Run ``cleanup()`` when the process ends, by itself (``atexit``) or ended by Ctrl-C's
    deadline (``leave``), which skips atexit."""
    atexit.register(cleanup)
    _cleanups.append(cleanup)


def leave() -> None:
    """Run the ``at_exit`` clean-ups now: the process is about to end with ``os._exit``."""
    while _cleanups:
        try:
            _cleanups.pop()()
        except Exception:  # noqa: BLE001, S110 - the process is ending: clean what can be
            pass


@contextlib.contextmanager
def writing():
    """A file write that Ctrl-C's deadline waits for (so that it is never left half-done)."""
    with _files:
        yield
