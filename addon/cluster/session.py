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

from . import names, tasks

CONNECT_SECONDS = 8.0  # an unreachable scheduler is said within this long (and 10 s of the start)
POLL_SECONDS = 0.1  # how often Ctrl-C and the scheduler are looked at while tasks run (and a
#                    modal bake redraws: ``as_done``'s ticks)
PACK_SECONDS = 600.0  # the packing of a shipped copy (``pack_copy``) ends within this long
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
        self.limits = {}  # {worker: its memory limit, bytes}
        try:
            self._names()
            self._check(timeout)
        except BaseException:
            self.close()
            raise

    def _names(self) -> None:
        """The scheduler (which unpickles the tasks) and this process take the package's
        names of the other side as theirs (``names``): the extension's here, pip's there;
        ClusterError when the scheduler or a worker runs another Python (pickles of code
        do not cross Pythons)."""
        import sys

        import cloudpickle

        mine = "{}.{}".format(*sys.version_info[:2])
        with self.talking():
            found = self.client.get_versions(check=False)
        hosts = {"the Dask scheduler": found["scheduler"],
                 **{f"worker {a}": w for a, w in sorted(found["workers"].items())}}
        for who, versions in hosts.items():
            theirs = ".".join(str(versions["host"].get("python", "?")).split(".")[:2])
            if theirs != mine:
                raise ClusterError(f"{who} of {self.address} runs Python {theirs}, this "
                                   f"process Python {mine}: Dask's clients, scheduler and "
                                   "workers need one Python (Blender 4.5 and 5.0: 3.11; "
                                   "5.1 and 5.2: 3.13)")
        names.install()
        cloudpickle.register_pickle_by_value(names)
        try:
            with self.talking():
                self.client.run_on_scheduler(names.install, "bo2_lighting")
        except Exception as exc:  # noqa: BLE001 - a scheduler that runs no client code
            if isinstance(exc, ClusterError):
                raise
            raise ClusterError(f"the Dask scheduler at {self.address} did not take BO2 "
                               f"Lighting's names ({_reason(exc)})") from None
        finally:
            cloudpickle.unregister_pickle_by_value(names)

    def _check(self, timeout: float) -> None:
        try:
            self.client.wait_for_workers(1, timeout=timeout)
        except (TimeoutError, OSError):
            if self._workers():  # (all paused: Dask counts running workers only)
                raise ClusterError(f"every worker of {self.address} is paused by Dask, out "
                                   f"of memory ({self.memory_limit()})") from None
            raise ClusterError(f"the Dask scheduler at {self.address} has no workers (start "
                               f"them with: bo2 worker {self.address})") from None
        try:
            found = self.client.run(tasks.worker_identity)
        except Exception as exc:  # noqa: BLE001 - whatever a worker without us raises
            raise ClusterError(f"the workers of {self.address} cannot run BO2 Lighting "
                               f"({_reason(exc)}): start them in an environment with bpy and "
                               f"this package (bo2 worker {self.address})") from None
        self.limits = {a: w.get("memory_limit") or 0 for a, w in self._workers().items()}
        for worker, who in sorted(found.items()):
            if who != self.identity:
                raise ClusterError(f"worker {worker} runs {tasks.describe(who)}; this machine "
                                   f"runs {tasks.describe(self.identity)}: install the same "
                                   "on every worker")

    def _workers(self) -> dict:
        """{address: the scheduler's information} of every worker, paused ones too."""
        return self.client.scheduler_info(n_workers=-1)["workers"]

    def close(self) -> None:
        try:
            self.client.close(timeout=2)
        except Exception:  # noqa: BLE001, S110 - a lost scheduler: nothing to close
            pass

    def ship(self) -> None:
        """Send the open .blend to the workers as it is now (unsaved changes too): a copy,
        every external file and linked library packed into it by a Blender of its own
        (``pack_copy``); the open file is left as it is."""
        import bpy

        name = Path(bpy.data.filepath).name or "untitled.blend"
        with tempfile.TemporaryDirectory(prefix="bo2_ship_") as tmp:
            copy = Path(tmp) / name
            bpy.ops.wm.save_as_mainfile(filepath=str(copy), copy=True)  # (paths remapped)
            pack_copy(copy)
            data = copy.read_bytes()
        digest = hashlib.sha256(data).hexdigest()
        self.blend = (self.scatter(data), digest, name)

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

    def as_done(self, futures: list
                ) -> Iterator[tuple[int, object, ClusterError | None] | None]:
        """Wait for ``futures``: yields (index, result, None) or (index, None, the task's
        error) as each ends, and None every ``POLL_SECONDS`` that none did (a modal bake's
        tick). Ctrl-C (``interrupt``) cancels those left and raises KeyboardInterrupt; the
        scheduler lost raises ClusterError, those left cancelled."""
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
                    yield None
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
        each one's, 1 by default) as they end and at its ticks, returns their results in
        order; the first failed task raises its ClusterError, the others cancelled."""
        sizes = sizes or [1] * len(futures)
        results, done = [None] * len(futures), 0
        waiting = self.as_done(futures)
        for ended in waiting:
            if ended is None:
                yield done
                continue
            k, result, error = ended
            if error is not None:
                waiting.throw(error)
            results[k] = result
            done += sizes[k]
            yield done
        return results

    def result(self, future):
        """``future``'s result once it ends (``as_done``); its ClusterError if it failed."""
        for ended in self.as_done([future]):
            if ended is not None:
                _, result, error = ended
                if error is not None:
                    raise error
                return result

    def memory_limit(self) -> str:
        """The workers' memory limit, in words."""
        with contextlib.suppress(Exception):  # (the workers that joined since)
            self.limits.update({a: w.get("memory_limit") or 0
                                for a, w in self._workers().items()})
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
    ``PAUSED_SECONDS`` (Dask's setting ``bo2.paused-seconds``, or DASK_BO2__PAUSED_SECONDS):
    the tasks would wait for ever, so ClusterError (``check``)."""

    def __init__(self, cluster: Cluster):
        import dask

        self.cluster, self.since, self.looked = cluster, None, 0.0
        self.limit = float(dask.config.get("bo2.paused-seconds", PAUSED_SECONDS))

    def check(self) -> None:
        import time

        now = time.monotonic()
        if now - self.looked < 5.0:
            return
        self.looked = now
        try:
            states = [w.get("status") for w in self.cluster._workers().values()]
        except Exception:  # noqa: BLE001 - the scheduler's loss is seen by the caller
            return
        if not states or any(s != "paused" for s in states):
            self.since = None
        elif self.since is None:
            self.since = now
        elif now - self.since > self.limit:
            raise ClusterError(f"every worker has been paused by Dask for "
                               f"{self.limit:.0f} s, out of memory "
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


PACK = """
import bpy
for step in (bpy.ops.file.pack_libraries, bpy.ops.file.pack_all,
             bpy.ops.file.make_paths_absolute):
    try:
        step()
    except RuntimeError:  # a missing file: the workers miss it too
        pass
bpy.ops.wm.save_mainfile(compress=True)
"""


def pack_copy(path: Path) -> None:
    """Pack into the saved .blend ``path`` its linked libraries' data (an asset library's)
    and its external files (textures, fonts, sounds), and make absolute the paths of what
    cannot be packed (a movie, a cache: a shared disk's), in a Blender of its own: this
    process's, open in the UI or read by a command, is left as it is. ClusterError if that
    Blender fails."""
    import subprocess
    import sys

    import bpy

    if bpy.app.binary_path:  # Blender itself
        command = [bpy.app.binary_path, "--background", "--factory-startup", str(path),
                   "--python-exit-code", "1", "--python-expr", PACK]
    else:  # the bpy module
        command = [sys.executable, "-c", "import sys\nimport bpy\nbpy.ops.wm.open_mainfile("
                   "filepath=sys.argv[1], load_ui=False)\n" + PACK, str(path)]
    try:
        run = subprocess.run(command, capture_output=True, text=True, timeout=PACK_SECONDS,
                             stdin=subprocess.DEVNULL)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ClusterError(f"could not pack {path.name} for the workers ({_reason(exc)})"
                           ) from None
    if run.returncode != 0:
        lines = [line for line in run.stderr.splitlines() if line.strip()] or ["no message"]
        raise ClusterError(f"could not pack {path.name} for the workers ({lines[-1].strip()})")


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) < 300 else text[:297] + "..."
