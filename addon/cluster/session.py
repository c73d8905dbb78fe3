"""The client's side of a Dask cluster: the connection and its checks, the shipped .blend, tasks
submitted and gathered in order with progress, Ctrl-C and the cluster's faults as one error.

Faults: a worker lost while it runs a task loses nothing (Dask runs the task again on another
worker); a task that workers die of in turn (out of memory, say; Dask's allowed failures) is
one error with their memory limit; the scheduler lost is one error. Nothing is written by
these functions: the commands write their files once every task is done, so a failure leaves
the previous files as they were.
"""

from __future__ import annotations

import contextlib
import hashlib
import tempfile
from collections.abc import Iterator
from pathlib import Path

from . import tasks

CONNECT_SECONDS = 8.0  # an unreachable scheduler is said within this long (and 10 s of the start)
POLL_SECONDS = 0.25  # how often Ctrl-C and the scheduler are looked at while tasks run
LOOK_BLOCK = 64  # volume samples' looks per task
SHOT_BLOCK = 32  # volume samples' captures per task (a reflection probe's: one per task)
GATHER_BLOCK = 8  # lightmap gather jobs per task (``lightmap_bake.GATHER_CHUNK`` texels each)


class ClusterError(Exception):
    """A failure of the cluster, in one line."""


class Cluster:
    """A connection to the Dask scheduler at ``address`` whose workers run this package and
    this Blender (``tasks.identity``); ClusterError when it cannot be reached within
    ``CONNECT_SECONDS``, has no worker by then, or a worker differs."""

    def __init__(self, address: str, timeout: float = CONNECT_SECONDS):
        try:
            from distributed import Client
        except ImportError:
            raise ClusterError("--scheduler needs Dask: pip install 'bo2-lighting[cluster]' "
                               "(dask and distributed)") from None
        import logging

        for logger in ("distributed", *(n for n in logging.root.manager.loggerDict
                                        if n.startswith("distributed."))):
            logging.getLogger(logger).setLevel(logging.CRITICAL)  # its errors are ours to say
        self.address = address
        self.identity = tasks.identity()
        try:
            self.client = Client(address, timeout=timeout)  # (the default: wait() takes it)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ClusterError(f"cannot reach the Dask scheduler at {address} within "
                               f"{timeout:.0f} s ({_reason(exc)})") from None
        self.blend = None  # (future of the shipped .blend's bytes, its digest, its name)
        try:
            self._check(timeout)
        except BaseException:
            self.close()
            raise

    def _check(self, timeout: float) -> None:
        try:
            self.client.wait_for_workers(1, timeout=timeout)
        except (TimeoutError, OSError):
            raise ClusterError(f"the Dask scheduler at {self.address} has no workers (start "
                               f"them with: bo2 worker {self.address})") from None
        try:
            found = self.client.run(tasks.worker_identity)
        except Exception as exc:  # noqa: BLE001 - whatever a worker without us raises
            raise ClusterError(f"the workers of {self.address} cannot run BO2 Lighting "
                               f"({_reason(exc)}): start them in an environment with bpy and "
                               f"this package (bo2 worker {self.address})") from None
        self.limits = {a: w.get("memory_limit") or 0 for a, w in
                       self.client.scheduler_info(n_workers=-1)["workers"].items()}
        for worker, who in sorted(found.items()):
            if who != self.identity:
                raise ClusterError(f"worker {worker} runs {tasks.describe(who)}; this machine "
                                   f"runs {tasks.describe(self.identity)}: install the same "
                                   "on every worker")

    def close(self) -> None:
        try:
            self.client.close(timeout=2)
        except Exception:  # noqa: BLE001, S110 - a lost scheduler: nothing to close
            pass

    def ship(self, path: Path):
        """Send the open .blend ``path`` to the workers with every external file and linked
        library packed in (a copy: the open file is opened again as it was); returns its
        scene, open again."""
        import bpy

        with tempfile.TemporaryDirectory(prefix="bo2_ship_") as tmp:
            copy = Path(tmp) / path.name
            # linked libraries' data too (an asset library's); what cannot be packed (a
            # movie, a cache) keeps its absolute path: a shared disk's
            for step in (bpy.ops.file.pack_libraries, bpy.ops.file.pack_all,
                         bpy.ops.file.make_paths_absolute):
                try:
                    step()
                except RuntimeError:  # a missing file: the workers miss it too, as here
                    pass
            bpy.ops.wm.save_as_mainfile(filepath=str(copy), copy=True, compress=True)
            data = copy.read_bytes()
        bpy.ops.wm.open_mainfile(filepath=str(path.resolve()), load_ui=False)
        digest = hashlib.sha256(data).hexdigest()
        self.blend = (self.scatter(data), digest, path.name)
        return bpy.context.scene

    def submit(self, fn, *args):
        """A task of ``fn(identity, blend, digest, name, *args)`` on the shipped .blend, or
        of ``fn(identity, *args)`` when none is shipped."""
        shipped = () if self.blend is None else self.blend
        with self.talking():
            return self.client.submit(fn, self.identity, *shipped, *args, pure=False)

    def scatter(self, data):
        """``data`` sent to the workers (the tasks that take it fetch it from a worker that
        has it): its future. A task that returns it, not Dask's scatter: the scheduler keeps
        the task, so data lost with every worker that held it is made again."""
        with self.talking():
            return self.client.submit(tasks.hold, data, pure=False)

    @contextlib.contextmanager
    def talking(self):
        """A call to the scheduler: its loss is ClusterError."""
        from concurrent.futures import CancelledError

        try:
            yield
        except (OSError, CancelledError) as exc:
            raise ClusterError(f"lost the Dask scheduler at {self.address} "
                               f"({_reason(exc)})") from None

    def as_done(self, futures: list) -> Iterator[tuple[int, object, ClusterError | None]]:
        """Wait for ``futures``: yields (index, result, None) or (index, None, the task's
        error) as each ends. Ctrl-C (``interrupt``) cancels those left and raises
        KeyboardInterrupt; the scheduler lost raises ClusterError, those left cancelled."""
        from concurrent.futures import CancelledError

        from distributed import wait

        from ..blender import interrupt

        index = {f.key: k for k, f in enumerate(futures)}
        pending = set(futures)
        paused = Paused(self)
        try:
            while pending:
                interrupt.check()
                if self.client.status not in ("running", "connecting"):
                    raise ClusterError(f"lost the Dask scheduler at {self.address}")
                paused.check()
                try:
                    finished, pending = wait(pending, timeout=POLL_SECONDS,
                                             return_when="FIRST_COMPLETED")
                except TimeoutError:  # (none ended yet; or the scheduler's loss, seen above)
                    continue
                except (OSError, CancelledError, ValueError) as exc:
                    # (the scheduler gone: its tasks cancelled, or the client closed, which
                    # wait() says as "no clients found")
                    why = (_reason(exc) if isinstance(exc, OSError)
                           else "its tasks were cancelled")
                    raise ClusterError(f"lost the Dask scheduler at {self.address} ({why})"
                                       ) from None
                for f in finished:
                    if f.status == "finished":
                        yield index[f.key], f.result(), None
                    else:
                        yield index[f.key], None, self._failure(f)
        except BaseException:
            try:
                self.client.cancel(list(pending))
            except Exception:  # noqa: BLE001, S110 - a lost scheduler cancels them itself
                pass
            raise

    def gather(self, futures: list, sizes: list[int] | None = None) -> Iterator[int]:
        """Wait for ``futures`` (``as_done``): yields the work finished so far (``sizes``:
        each one's, 1 by default) as they end, returns their results in order; the first
        failed task raises its ClusterError, the others cancelled."""
        sizes = sizes or [1] * len(futures)
        results, done = [None] * len(futures), 0
        waiting = self.as_done(futures)
        for k, result, error in waiting:
            if error is not None:
                waiting.throw(error)
            results[k] = result
            done += sizes[k]
            yield done
        return results

    def result(self, future):
        """``future``'s result once it ends (``as_done``); its ClusterError if it failed."""
        for _, result, error in self.as_done([future]):
            if error is not None:
                raise error
            return result

    def memory_limit(self) -> str:
        """The workers' memory limit, in words."""
        with contextlib.suppress(Exception):  # (the workers that joined since)
            self.limits.update({a: w.get("memory_limit") or 0 for a, w in
                                self.client.scheduler_info(n_workers=-1)["workers"].items()})
        limits = [v for v in self.limits.values() if v]
        return (f"their memory limit is {min(limits) / 2**30:.2f} GiB" if limits
                else "they have no memory limit")

    def _failure(self, future) -> ClusterError:
        from distributed import KilledWorker

        if future.status == "cancelled":
            return ClusterError(f"lost the Dask scheduler at {self.address} (the task was "
                                "cancelled)")
        exc = future.exception()
        if isinstance(exc, KilledWorker):
            return ClusterError(f"a task ended {exc.allowed_failures + 1} workers in turn "
                                f"(killed, or out of memory: {self.memory_limit()})")
        return ClusterError(f"a worker failed: {_reason(exc)}")

    def lightmap_runner(self):
        """The runner of a lightmap bake's gathers on the workers
        (``core.bakes.lightmap_bake.steps``)."""
        return LightmapRunner(self)

    def probe_runner(self, backend: str, focus):
        """The runner of a probe bake's captures on the workers (``core.bakes.bake.Bake``):
        by ``backend``, the suns' shadows sharp over ``focus``."""
        return ProbeRunner(self, backend, focus)


class Paused:
    """Every worker paused by Dask (past 80% of its memory limit, it takes no new task) for
    ``PAUSED_SECONDS``: the tasks would wait for ever, so ClusterError (``check``)."""

    def __init__(self, cluster: Cluster):
        self.cluster, self.since, self.looked = cluster, None, 0.0

    def check(self) -> None:
        import time

        now = time.monotonic()
        if now - self.looked < 5.0:
            return
        self.looked = now
        try:
            states = [w.get("status") for w in self.cluster.client.scheduler_info(
                n_workers=-1)["workers"].values()]
        except Exception:  # noqa: BLE001 - the scheduler's loss is seen by the caller
            return
        if not states or any(s != "paused" for s in states):
            self.since = None
        elif self.since is None:
            self.since = now
        elif now - self.since > PAUSED_SECONDS:
            raise ClusterError(f"every worker has been paused by Dask for "
                               f"{PAUSED_SECONDS:.0f} s, out of memory "
                               f"({self.cluster.memory_limit()})")


PAUSED_SECONDS = 60.0


class ProbeRunner:
    """``core.bakes.bake.Here``'s generators, on the cluster: the jobs in blocks, a task
    each; the probes lighting a bounce's captures sent to every worker once."""

    def __init__(self, cluster: Cluster, backend: str, focus):
        self.cluster, self.backend = cluster, backend
        self.focus = tuple(tuple(float(v) for v in side) for side in focus)

    def looks(self, jobs: list) -> Iterator[int]:
        return (yield from self._run(tasks.looks, jobs, [LOOK_BLOCK] * len(jobs)))

    def shots(self, jobs: list, seen) -> Iterator[int]:
        seen = self.cluster.scatter(seen)
        return (yield from self._run(tasks.shots, jobs, [1 if j.kind == "reflection"
                                                         else SHOT_BLOCK for j in jobs], seen))

    def _run(self, fn, jobs: list, blocks: list[int], *shared) -> Iterator[int]:
        parts, k = [], 0
        while k < len(jobs):
            parts.append(jobs[k:k + blocks[k]])
            k += len(parts[-1])
        futures = [self.cluster.submit(fn, self.backend, self.focus, *shared, part)
                   for part in parts]
        found = yield from self.cluster.gather(futures, [len(p) for p in parts])
        return [r for part in found for r in part]



class LightmapRunner:
    """``core.bakes.lightmap_bake.Here``'s generator on the cluster: the gathers' context sent
    once (the texels, the scene's BVH: nothing of the .blend is needed), each bounce's
    radiance once, ``GATHER_BLOCK`` jobs a task."""

    def __init__(self, cluster: Cluster):
        self.cluster, self.sent = cluster, None  # (the context, its future)

    def gathers(self, g, jobs: list, rays: int, radiance) -> Iterator[int]:
        if self.sent is None or self.sent[0] is not g:
            self.sent = (g, self.cluster.scatter(g))
        shared = self.cluster.scatter(radiance)
        parts = [jobs[k:k + GATHER_BLOCK] for k in range(0, len(jobs), GATHER_BLOCK)]
        futures = [self.cluster.submit(tasks.gathers, self.sent[1], shared, rays, part)
                   for part in parts]
        found = yield from self.cluster.gather(
            futures, [sum(hi - lo for _, lo, hi in part) * rays for part in parts])
        return [r for part in found for r in part]


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) < 300 else text[:297] + "..."
