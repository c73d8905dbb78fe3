"""``bo2 export-probes``: every baked probe of a .blend file, and its world, as a game engine
loads them: the reflection probes' prefiltered chains (KTX2, DDS or OpenEXR; ``engine_export``)
and one ``probes.json`` with each probe's SH, placement, parallax proxy and influence, in the
engine's axes (Y up, as glTF)."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from . import BadInput, CommandError, load_blend


def _to_y_up(matrix) -> list:
    """A (4, 4) local-to-world transform whose world is the engine's (Y up): C M. The local
    axes stay the probe's own, so a volume's samples keep their (x, y, z) indices."""
    from ..core.files import gpu_textures

    c = np.eye(4)
    c[:3, :3] = gpu_textures.Y_UP
    return (c @ np.asarray(matrix, np.float64)).tolist()


def _sh(coefficients) -> list:
    from ..core.files import gpu_textures
    from ..core.formulas import sh

    return sh.rotate(np.asarray(coefficients, np.float64), gpu_textures.Y_UP).tolist()


def _chain(out: Path, stem: str, name: str, fmt: str, mips: list, coefficients,
           extra: dict) -> dict:
    """Write one bo2 chain as ``<stem>.<fmt>``; its manifest entry."""
    from ..core.files import engine_export
    from ..core.formulas import prefilter

    size = mips[0].shape[1]
    meta = engine_export.chain_metadata(
        "bo2", prefilter.mip_powers(size)[:len(mips)], size,
        np.asarray(_sh(coefficients)), probe=name, **extra)
    if fmt == "json":
        return {"chain": None, "chain_metadata": meta}
    path = out / f"{stem}.{fmt}"
    try:
        files = engine_export.write_chain(path, mips, meta)
    except OSError as exc:
        raise BadInput(f"{path}: cannot write ({exc.strerror})") from None
    return {"chain": files[0].name, "chain_metadata": meta}


def _stem(index: int, name: str) -> str:
    """A file name of probe ``index`` that no other probe, the world or the manifest takes,
    whatever the names and the file system's case rules."""
    safe = "".join(c if c.isascii() and (c.isalnum() or c in "-_.") else "_" for c in name)
    return f"probe{index:02d}_{safe}"


def run(args) -> int:
    """Export the baked probes of a .blend file into ``-o`` DIR."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise BadInput(f"{out}: is a file, not a folder")
    scene = load_blend(Path(args.scene))
    from ..blender import extract, probes
    from ..core.files import gpu_textures
    from ..core.render.job import Warnings

    start = time.perf_counter()
    warnings = Warnings()
    world = extract.extract_world(scene, warnings)
    objs = probes.probe_objects(scene)
    states = {o.name: probes.bake_state(o) for o in objs}
    loaded = probes.load_probes(scene, world, warnings)
    for message in warnings:
        print(f"bo2: warning: {message}", file=sys.stderr)
    if objs and not loaded.reflection and not loaded.volumes:
        raise CommandError(f"{args.scene}: none of its {len(objs)} light probes is baked "
                           f"({', '.join(f'{n}: {s.state.lower()}' for n, s in states.items())})"
                           "; run bo2 bake first")
    try:
        out.mkdir(parents=True, exist_ok=True)
        entries = []
        world_entry = {"kind": "world", "name": scene.world.name if scene.world else "World",
                       "sh": _sh(loaded.world_sh),
                       "color": None if loaded.world_color is None
                       else [float(x) for x in loaded.world_color],
                       **_chain(out, "world", "world", args.format, loaded.world_mips["bo2"],
                                loaded.world_sh, {"kind": "world"})}
        for k, p in enumerate(loaded.reflection):
            entries.append({
                "kind": "reflection", "name": p.name,
                "position": (gpu_textures.Y_UP @ np.asarray(p.position, np.float64)).tolist(),
                "influence_radius": float(p.radius), "falloff": float(p.falloff),
                "parallax": p.proxy, "parallax_to_world": None if p.proxy_to_world is None
                else _to_y_up(p.proxy_to_world),
                "sh": _sh(p.sh), "baked": states[p.name].meta.get("bake_time"),
                **_chain(out, _stem(k, p.name), p.name, args.format, p.mips["bo2"], p.sh,
                         {"kind": "reflection"})})
        for v in loaded.volumes:
            grid = np.asarray(v.sh, np.float64)
            turned = np.stack([_sh(c) for c in grid.reshape(-1, 9, 3)]).reshape(grid.shape)
            entries.append({
                "kind": "irradiance_volume", "name": v.name,
                "local_to_world": _to_y_up(v.local_to_world),
                "grid": "samples span the local cube [-1, 1]^3, index (x, y, z) along the local "
                        "axes of local_to_world",
                "resolution": [int(r) for r in v.resolution],
                "influence": float(v.influence), "falloff": float(v.falloff),
                "normal_bias": float(v.normal_bias), "view_bias": float(v.view_bias),
                "facing_bias": None if v.facing_bias is None else float(v.facing_bias),
                "validity": None if v.validity is None
                else np.asarray(v.validity, np.float64).ravel().tolist(),
                "sh": turned.tolist(), "baked": states[v.name].meta.get("bake_time")})
        manifest = {"scene": str(args.scene),
                    "axes": "world Y up: Blender's (x, y, z) as (x, z, -y); transforms map the "
                            "probes' own local axes to it",
                    "units": "metres; radiance SH of sh.basis (docs/sh.md)",
                    "format": args.format, "world": world_entry, "probes": entries}
        from ..core.system import atomic

        atomic.write_text(out / "probes.json", json.dumps(manifest, indent=1) + "\n")
    except OSError as exc:
        raise BadInput(f"{out}: cannot write ({exc.strerror})") from None
    print(f"exported {len(entries)} probe{'s' * (len(entries) != 1)} and the world into {out} "
          f"({args.format}) in {time.perf_counter() - start:.2f} s")
    return 0
