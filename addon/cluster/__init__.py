"""Bakes, reviews and frames on a Dask cluster (``distributed``): the ``bo2`` commands'
``--scheduler ADDRESS``.

We do not schedule: Dask does. The machine that runs the command (the client) opens the
.blend as it does alone, then ships a copy of it with every external file packed in
(``session.Cluster.ship``: the file travels, so the workers need no shared disk) and submits
tasks; each worker opens that copy once (``tasks``) and keeps it open for the tasks that
follow. A probe bake runs as it does alone (``core.bakes.bake.Bake``) with its captures sent
out (``session.ProbeRunner``): the volumes' samples in blocks and the reflection probes one
each, a bounce's results gathered before the next is sent. Frames are tasks of ``bo2
render``, scenes tasks of ``bo2 report``. The client writes every file, as alone: all or
nothing, atomically.

Workers are ``dask worker`` processes in an environment with ``bpy`` and this package, one
task at a time each (``bo2 worker ADDRESS``: ``dask worker --nthreads 1 --preload
bo2_lighting.addon.cluster.tasks``); a worker's package, code and Blender must be the
client's (``tasks.identity``), checked before any work is sent and by every task.
"""
