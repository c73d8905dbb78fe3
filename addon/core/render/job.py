"""A render job: the scene, its settings, the threads, the progress, the stop and one warning
sink, handed to every stage of the render (``pipeline``), of a probe capture or a lightmap
bake.

The host (Blender's engine, the viewport's session, a bake, the command line) makes the job,
runs stages with it and reads ``job.warnings`` afterwards: no result travels any other way.
"""

from __future__ import annotations

import dataclasses
import os
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor, wait
from dataclasses import dataclass, field

from ..scene import RenderSettings, Scene

__all__ = ["Cancelled", "Message", "RenderJob", "Warnings", "thread_count"]

KINDS = ("WARNING", "INFO", "ERROR")


class Cancelled(Exception):
    """The host asked the render to stop."""


@dataclass(frozen=True)
class Message:
    """One thing the user should read: ``kind`` one of ``KINDS`` (Blender's report types)."""

    text: str
    kind: str = "WARNING"


class Warnings:
    """The one sink of a job's messages: each distinct text once, in order (``messages``;
    iterating gives their texts); ``forward`` (e.g. the engine's ``report``) is called with
    each new ``Message`` as it comes, on the thread of whoever adds it."""

    def __init__(self, forward: Callable[[Message], None] | None = None) -> None:
        self.messages: list[Message] = []
        self._texts: set[str] = set()
        self._lock = threading.Lock()
        self.forward = forward

    def add(self, text: str, kind: str = "WARNING") -> None:
        if kind not in KINDS:
            raise ValueError(f"a message's kind is one of {KINDS}, not {kind!r}")
        with self._lock:
            if text in self._texts:
                return
            self._texts.add(text)
            message = Message(text, kind)
            self.messages.append(message)
        if self.forward is not None:
            self.forward(message)

    def extend(self, texts: Iterable[str], kind: str = "WARNING") -> None:
        for text in texts:
            self.add(text, kind)

    def texts(self) -> list[str]:
        """The messages' texts, in order."""
        return [m.text for m in self.messages]

    def __iter__(self) -> Iterator[str]:
        return iter(self.texts())

    def __contains__(self, text: object) -> bool:
        return text in self._texts

    def __len__(self) -> int:
        return len(self.messages)


def thread_count(settings: RenderSettings) -> int:
    """Threads a render uses: ``settings.threads``, or one per CPU core when that is 0."""
    return max(1, int(settings.threads) or os.cpu_count() or 1)


@dataclass
class RenderJob:
    """What every stage of a render shares.

    scene:       the scene rendered (``scene.settings`` are the job's settings)
    progress:    called with the finished fraction in [0, 1], on the calling thread
    should_stop: polled often on the calling thread; True makes the stages raise ``Cancelled``
    warnings:    the sink of every message (``Warnings``); a job made from another shares it
    """

    scene: Scene
    progress: Callable[[float], None] | None = None
    should_stop: Callable[[], bool] | None = None
    warnings: Warnings = field(default_factory=Warnings)

    @property
    def settings(self) -> RenderSettings:
        return self.scene.settings

    @property
    def threads(self) -> int:
        return thread_count(self.scene.settings)

    def warn(self, text: str, kind: str = "WARNING") -> None:
        self.warnings.add(text, kind)

    def poll(self) -> None:
        """Raise ``Cancelled`` when the host asks to stop."""
        if self.should_stop is not None and self.should_stop():
            raise Cancelled()

    def on(self, scene: Scene, progress: Callable[[float], None] | None = None) -> RenderJob:
        """A job of ``scene`` with this one's stop and warning sink (a capture's faces, a
        bake's charts), reporting its progress to ``progress``."""
        return dataclasses.replace(self, scene=scene, progress=progress)

    def ordered(self, jobs: Iterable[Callable[[], object]], stop: threading.Event,
                poll: Callable[[], None] | None = None) -> Iterator:
        """Run ``jobs`` on the job's threads, at most two per thread queued, and yield their
        results in order. ``poll`` (default ``self.poll``) runs on the calling thread at
        least ten times a second while it waits and may raise (``Cancelled``); on any exit
        ``stop`` is set, the queued jobs are dropped and the running ones are waited for
        (jobs should return soon once it is set)."""
        return run_ordered(jobs, self.threads, self.poll if poll is None else poll, stop)


def run_ordered(jobs: Iterable[Callable[[], object]], threads: int, poll: Callable[[], None],
                stop: threading.Event) -> Iterator:
    """``RenderJob.ordered`` on ``threads`` threads."""
    if threads <= 1:
        try:
            for job in jobs:
                poll()
                yield job()
        finally:
            stop.set()
        return
    jobs = iter(jobs)
    pending: deque = deque()
    with ThreadPoolExecutor(threads, thread_name_prefix="bo2-render") as pool:
        try:
            while True:
                while len(pending) < 2 * threads and (job := next(jobs, None)) is not None:
                    pending.append(pool.submit(job))
                if not pending:
                    return
                poll()
                while not wait([pending[0]], timeout=0.1).done:
                    poll()
                yield pending.popleft().result()
        finally:
            stop.set()
            for future in pending:
                future.cancel()
