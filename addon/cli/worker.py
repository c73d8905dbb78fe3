"""``bo2 worker``: a Dask worker for the ``bo2`` commands' ``--scheduler`` (``cluster``), this
process replaced by ``dask worker`` with one task at a time per process and Blender loaded at
its start."""

from __future__ import annotations

import os
import sys

from . import CommandError

PRELOAD = "bo2_lighting.addon.cluster.tasks"


def command(args) -> list[str]:
    """The ``dask worker`` command line of ``bo2 worker``'s arguments."""
    line = [sys.executable, "-m", "distributed.cli.dask_worker", args.address,
            "--nthreads", "1", "--preload", PRELOAD, "--nworkers", str(args.nworkers)]
    if args.memory_limit:
        line += ["--memory-limit", args.memory_limit]
    if args.name:
        line += ["--name", args.name]
    return line


def run(args) -> int:
    """Become a Dask worker of the scheduler at ``args.address``."""
    try:
        import bpy  # noqa: F401
        import distributed  # noqa: F401
    except ImportError as exc:
        raise CommandError(f"a worker needs {exc.name}: pip install 'bo2-lighting[cluster]' "
                           "and bpy in this environment") from None
    sys.stdout.flush()
    os.execv(sys.executable, command(args))
    return 0  # (not reached)
