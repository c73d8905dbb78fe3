"""Build the node group asset library ``node_groups/bo2_node_groups.blend`` from the specs.

Usage: python tools/build_node_library.py [OUT.blend]

Run with the oldest supported Blender (the ``.venv45`` bpy, Blender 4.5), so that every
supported version opens the file. Prints the groups written.
"""

import sys
from pathlib import Path


def main() -> int:
    import bpy

    import bo2_lighting
    from bo2_lighting.addon.blender import library

    bo2_lighting.register()
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else library.LIBRARY_FILE
    names = library.build(out)
    print(f"{out} (Blender {bpy.app.version_string}): {', '.join(names)}")
    bo2_lighting.unregister()
    return 0


if __name__ == "__main__":
    sys.exit(main())
