"""The ``bo2`` command's terminal: Blender's own output silenced, progress bars that pass the
silencing, and Ctrl-C ending a render at once."""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
import time

from ..blender import interrupt
from ..blender.headless import HeadlessError
from . import CommandError


@contextlib.contextmanager
def quiet_blender():
    """Silence Blender's own C-level stdout/stderr. An error raised inside becomes a
    CommandError: its last line with Blender's last line appended, unless it is one already
    written for the user (CommandError, ``headless.HeadlessError``)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            yield
        except CommandError:
            raise
        except HeadlessError as exc:
            raise CommandError(str(exc)) from exc
        except Exception as exc:
            sys.stdout.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            log.seek(0)
            lines = [s.strip() for s in log.read().decode(errors="replace").splitlines()]
            detail = next((s for s in reversed(lines) if s), "").removeprefix("Error: ")
            text = str(exc).strip()
            message = text.splitlines()[-1].removeprefix("Error: ") if text else type(exc).__name__
            if detail and detail not in message and message not in detail:
                message = f"{message} ({detail})"
            raise CommandError(message) from exc
        finally:
            sys.stdout.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def stderr_copy():
    """A text stream on a duplicate of stderr: what is written to it passes ``quiet_blender``."""
    sys.stderr.flush()
    return os.fdopen(os.dup(2), "w")


def progress_bar(out, fraction: float, start: float, width: int = 30) -> None:
    """One self-overwriting line on ``out``: [#####.....]  42.0%  12.3 s."""
    filled = int(round(fraction * width))
    out.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {fraction * 100:5.1f}%  "
              f"{time.perf_counter() - start:6.1f} s")
    out.flush()


class BatchProgress:
    """The progress bar of a batch render: one self-overwriting line on a duplicate of stderr
    (it passes ``quiet_blender``), with messages printed above it."""

    def __init__(self, total: int):
        self.terminal = stderr_copy()
        self.total, self.done, self.label, self.width = total, 0, "", 0
        self.start = time.perf_counter()

    def draw(self, label: str | None = None) -> None:
        if label is not None:  # the whole line fits in 80 columns
            self.label = label if len(label) <= 28 else "..." + label[-25:]
        bar = io.StringIO()
        progress_bar(bar, self.done / self.total, self.start, width=20)
        line = f"{bar.getvalue()}  {self.done}/{self.total}  {self.label}"
        self.terminal.write(line.ljust(self.width))  # spaces over a longer previous line
        self.terminal.flush()
        self.width = len(line)

    def clear(self) -> None:
        """Blank the bar's line (before a message, or the last words of an interrupt)."""
        self.terminal.write("\r" + " " * self.width + "\r")
        self.terminal.flush()

    def message(self, text: str, stream) -> None:
        self.clear()
        print(text, file=stream, flush=True)
        self.draw()

    def close(self) -> None:
        self.draw("")
        self.terminal.write("\n")
        self.terminal.close()


@contextlib.contextmanager
def exit_on_interrupt(describe):
    """Ctrl-C ends the process at once with one error line, even inside a render.

    A render started from Python in the ``bpy`` module does not return to Python before it
    finishes, and the KeyboardInterrupt raised in Blender's callbacks is swallowed. So a thread
    woken by the signal's wakeup file descriptor prints ``bo2: error: <describe()>`` on the
    terminal and exits with 130 (files already written stay).
    """
    import signal
    import socket
    import threading

    reader, writer = socket.socketpair()
    writer.setblocking(False)
    terminal = os.dup(2)
    done = threading.Event()

    def watch():
        while True:
            data = reader.recv(1)
            if done.is_set() or not data:
                return
            if data[0] == signal.SIGINT:
                os.write(terminal, f"bo2: error: {describe()}\n".encode())
                interrupt.leave()
                os._exit(130)

    previous = signal.signal(signal.SIGINT, lambda *_: None)
    previous_fd = signal.set_wakeup_fd(writer.fileno(), warn_on_full_buffer=False)
    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        signal.set_wakeup_fd(previous_fd)
        signal.signal(signal.SIGINT, previous)
        writer.send(b"\0")
        thread.join()
        reader.close()
        writer.close()
        os.close(terminal)
