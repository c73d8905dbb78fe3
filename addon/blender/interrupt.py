"""Ctrl-C for the ``bo2`` command: a stop request that renders and bakes poll.

Once ``bpy`` is imported, SIGINT no longer raises KeyboardInterrupt in Python; ``install``
routes it to a flag instead. The BO2 engine's render and the bake's captures stop at their next
poll (within a tile), and the command then raises KeyboardInterrupt itself (``check``). In the
Blender UI nothing installs it and the flag stays down.
"""

from __future__ import annotations

import signal
import threading

_requested = threading.Event()


def install() -> None:
    """From now on SIGINT sets the stop request (on the main thread only, where Python takes
    signals)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, lambda *_: _requested.set())


def requested() -> bool:
    """Whether Ctrl-C was pressed since ``install``."""
    return _requested.is_set()


def check() -> None:
    """Raise KeyboardInterrupt when Ctrl-C was pressed."""
    if _requested.is_set():
        raise KeyboardInterrupt
