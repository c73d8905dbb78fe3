"""``python -m bo2_lighting.addon.cli``: the ``bo2`` command."""

from . import main

raise SystemExit(main())
