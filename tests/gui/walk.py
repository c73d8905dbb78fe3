"""A walk through the artist's Blender, in a real window: run inside Blender by
``tests/gui/run.py`` (``blender --factory-startup --python tests/gui/walk.py -- ZIP OUT``).

Installs the extension's zip as a user does (Install from Disk), opens the demo room, picks BO2
Lighting, and checks what the window shows: each Properties tab's panels (drawn into a recording
layout with the editor's own context), the Shader Editor's tree, the previews, the viewport in
Rendered shading (the scene's world, the studio light, a look-dev view). A screenshot of each
step goes to OUT; the checks go to OUT/results.json, then Blender quits.
"""

import importlib
import json
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import panel_walk  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
ZIP, OUT = Path(ARGS[0]).resolve(), Path(ARGS[1]).resolve()
ROOM = Path(__file__).resolve().parents[2] / "demo_blends" / "room.blend"
CHART = ROOM.with_name("material_spheres.blend")
ENGINE = "BO2_LIGHTING"
checks: list[dict] = []
shots: list[str] = []


def check(name: str, ok: bool, detail="") -> bool:
    checks.append({"check": name, "ok": bool(ok), "detail": str(detail)[:2000]})
    print(f"[walk] {'ok  ' if ok else 'FAIL'} {name} {detail if not ok else ''}", flush=True)
    return ok


def screenshot(name: str, area=None) -> None:
    """The window as a PNG in OUT; with ``area``, that area alone (a Properties tab)."""
    path = OUT / f"{len(shots):02d}_{name}.png"
    crop = []
    if area is not None:
        top = window().height - area.y - area.height
        crop = ["-crop", f"{area.width}x{area.height}+{area.x}+{top}"]
    subprocess.run(["import", "-window", "root", *crop, str(path)], check=False)
    shots.append(path.name)


def window():
    return bpy.context.window_manager.windows[0]


def areas(kind: str):
    screen = window().screen
    return [a for a in screen.areas if a.type == kind]


def biggest(kind: str):
    return max(areas(kind), key=lambda a: a.width * a.height)


def module(name: str):
    """A module of the installed extension (``bl_ext.<repo>.bo2_lighting.addon...``)."""
    roots = [k for k in sys.modules if k.startswith("bl_ext.") and k.endswith(".bo2_lighting")]
    return importlib.import_module(f"{roots[0]}.{name}") if roots else None


def redraw():
    for area in window().screen.areas:
        area.tag_redraw()


def tab_check(label: str, tab: str, wanted: set[str]) -> None:
    """The Properties editor on ``tab`` (its own context): no title twice, no setting twice,
    and every property of ``wanted`` ("Struct.property") shown."""
    area = biggest("PROPERTIES")
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window(), area=area, region=region):
        panels = panel_walk.shown(bpy.context, tab)
    props = panel_walk.shown_properties(panels)
    titles = [c.bl_label or c.__name__ for c, _ in panels]
    check(f"{label}: panels shown", bool(panels), titles)
    check(f"{label}: no title twice", not panel_walk.duplicate_titles(panels), titles)
    twice = sorted({p for p in props if props.count(p) > 1})
    check(f"{label}: no setting twice", not twice, twice)
    missing = sorted(wanted - set(props))
    check(f"{label}: shows {', '.join(sorted(w.split('.')[1] for w in wanted))}", not missing,
          f"missing {missing}; shown {sorted(set(props))}")
    screenshot(label.lower().replace(" ", "_"), area)


def show_tab(obj, context_name: str):
    """Make ``obj`` active and show its tab ``context_name`` (the editor offers an object's
    tabs once it has drawn with that object active)."""
    if obj is not None:
        for o in bpy.context.view_layer.objects:
            o.select_set(False)
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        redraw()
        yield 1.0
    for _ in range(10):  # the editor offers the tab once it has drawn (slower under load)
        try:
            biggest("PROPERTIES").spaces.active.context = context_name
            break
        except TypeError:
            redraw()
            yield 1.0
    redraw()


def walk():
    """The steps; each ``yield`` gives the window that many seconds to draw."""
    OUT.mkdir(parents=True, exist_ok=True)
    yield 2.0
    # 1. Install from Disk, as a user does
    result = bpy.ops.extensions.package_install_files(filepath=str(ZIP), repo="user_default",
                                                      enable_on_install=True)
    check("the zip installs and enables", result == {"FINISHED"}, result)
    engine = bpy.types.RenderEngine.bl_rna_get_subclass_py(ENGINE)
    if not check("BO2 Lighting is a render engine", engine is not None):
        return
    import numba

    site = Path(bpy.utils.user_resource("EXTENSIONS", path=".local"))
    check("numba comes from the zip's wheels", Path(numba.__file__).is_relative_to(site),
          f"numba {numba.__version__} at {numba.__file__}")
    kernels = module("addon.core.kernels")
    try:
        kernels.check()
        check("the kernels' numba is accepted", True)
    except Exception as exc:  # noqa: BLE001
        check("the kernels' numba is accepted", False, exc)

    # 2. The demo room, BO2 picked
    bpy.ops.wm.open_mainfile(filepath=str(ROOM))
    yield 3.0
    scene = bpy.context.scene
    scene.render.engine = ENGINE
    added = []  # one light of each type, removed after their tabs are seen
    for kind in ("POINT", "SPOT", "SUN", "AREA"):
        if not any(o.type == "LIGHT" and o.data.type == kind for o in scene.objects):
            obj = bpy.data.objects.new(f"Walk {kind.title()}", bpy.data.lights.new(kind, kind))
            obj.location = (0.0, 0.0, 2.0)
            scene.collection.objects.link(obj)
            added.append(obj)
    for kind in ("SPHERE", "VOLUME"):
        if not any(o.type == "LIGHT_PROBE" and o.data.type == kind for o in scene.objects):
            obj = bpy.data.objects.new(f"Walk {kind.title()}",
                                       bpy.data.lightprobes.new(kind, kind))
            scene.collection.objects.link(obj)
    redraw()
    yield 2.0

    # 2b. The kernels are made ready in the background from the moment the zip was enabled;
    # the Render tab says so while they compile
    yield from show_tab(None, "RENDER")
    yield 1.5
    preparing = kernels.status()
    if preparing:
        screenshot("render_tab_compiling", biggest("PROPERTIES"))
    start = time.perf_counter()
    while kernels.status() and time.perf_counter() - start < 600:
        yield 1.0
    check("the kernels are made ready off the UI thread once the zip is enabled",
          kernels._worker is not None and kernels.loaded() and not kernels.status(),
          f"said {preparing!r} with the room open; ready {time.perf_counter() - start:.0f} s "
          "later")

    # 3. Every tab
    yield from show_tab(None, "RENDER")
    yield 1.5
    tab_check("Render tab", "render", {"BO2SceneSettings.samples",
                                       "BO2SceneSettings.shadow_resolution",
                                       "RenderSettings.preview_pixel_size",
                                       "CyclesRenderSettings.rolling_shutter_type",
                                       "BO2SceneSettings.bake_on",
                                       "BO2LightmapSettings.density",
                                       "BO2LookDevSettings.report_source",
                                       "BO2LookDevSettings.report_folder"})
    yield from show_tab(None, "OUTPUT")
    yield 1.0
    tab_check("Output tab", "output", {"RenderSettings.resolution_x"})
    yield from show_tab(None, "VIEW_LAYER")
    yield 1.0
    tab_check("View Layer tab", "view_layer", {"BO2ViewLayerSettings.use_pass_albedo"})
    yield from show_tab(None, "WORLD")
    yield 1.0
    tab_check("World tab", "world", set())
    mesh = next(o for o in scene.objects if o.type == "MESH" and o.active_material)
    yield from show_tab(mesh, "OBJECT")
    yield 1.0
    tab_check("Object tab", "object", {"Object.visible_camera", "Object.is_holdout",
                                       "Object.hide_probe_sphere", "Object.hide_probe_volume",
                                       "BO2ObjectSettings.lightmap_mode",
                                       "BO2ObjectSettings.lightmap_uv"})
    camera = next(o for o in scene.objects if o.type == "CAMERA")
    yield from show_tab(camera, "DATA")
    yield 1.0
    tab_check("Camera tab", "data", {"Camera.lens"})
    light_props = {"Light.color", "Light.energy", "Light.exposure", "Light.normalize",
                   "Light.use_temperature", "Light.use_shadow"}
    own = {"POINT": {"shadow_soft_size"}, "SPOT": {"shadow_soft_size", "spot_size",
                                                   "spot_blend"},
           "SUN": {"angle"}, "AREA": {"shape", "size"}}
    for kind, extra in own.items():
        light = next(o for o in scene.objects if o.type == "LIGHT" and o.data.type == kind)
        yield from show_tab(light, "DATA")
        yield 1.5
        rna = type(light.data).__name__
        wanted = {p.replace("Light.", f"{rna}.") for p in light_props}
        tab_check(f"{kind.title()} light tab", "data", wanted | {f"{rna}.{p}" for p in extra})
    bpy.data.batch_remove(added)
    for kind in ("SPHERE", "VOLUME"):
        probe = next(o for o in scene.objects if o.type == "LIGHT_PROBE"
                     and o.data.type == kind)
        yield from show_tab(probe, "DATA")
        yield 1.5
        rna = type(probe.data).__name__
        tab_check(f"{kind.title()} probe tab", "data",
                  {f"{rna}.influence_distance", f"{rna}.clip_start"})

    # 4. The material tab, its preview, the Shader Editor
    yield from show_tab(mesh, "MATERIAL")
    material = mesh.active_material
    material.preview_ensure()
    redraw()
    yield 1.0
    tab_check("Material tab", "material", {"Material.pass_index",
                                           "Material.use_backface_culling"})
    engine = module("addon.blender.engine")
    said = engine.listening() if engine else None
    renders = said.__enter__() if said else []  # what BO2's renders say, previews too
    with bpy.context.temp_override(window=window(), id=material):
        bpy.ops.ed.lib_id_generate_preview()  # as the asset browser asks for one
    start, lit = time.perf_counter(), {}
    while time.perf_counter() - start < 120 and len(lit) < 2:
        yield 0.5
        preview = material.preview
        for kind in ("icon", "image"):
            w, h = getattr(preview, f"{kind}_size")
            values = getattr(preview, f"{kind}_pixels_float")[:] if w * h else []
            if kind not in lit and values and max(values[0::4]) > 0.02:
                lit[kind] = (w, time.perf_counter() - start)
    if said:
        said.__exit__(None, None, None)
    times = [t.split()[-2] for t in renders if t.startswith("Preview rendered in")]
    check("the material's icon and preview are rendered by BO2", len(lit) == 2 and times,
          f"{lit} (size px, seconds after asking); BO2's preview renders took {times} s")
    if "image" in lit:  # the 128 px preview as BO2 rendered it, for the user guide
        w, h = material.preview.image_size
        image = bpy.data.images.new("preview", w, h, alpha=True)
        image.pixels[:] = material.preview.image_pixels_float[:]
        image.filepath_raw = str(OUT / "material_preview_128.png")
        image.file_format = "PNG"
        image.save()
    screenshot("material_preview", biggest("PROPERTIES"))

    view3d = biggest("VIEW_3D")
    view3d.ui_type = "ShaderNodeTree"
    redraw()
    yield 2.0
    space = view3d.spaces.active
    check("the Shader Editor shows the material's tree with BO2 picked",
          space.tree_type == "ShaderNodeTree" and space.node_tree == material.node_tree,
          f"tree_type {space.tree_type}, node_tree {space.node_tree}")
    screenshot("shader_editor")
    view3d.ui_type = "VIEW_3D"
    redraw()
    yield 1.0

    # 5. Bake the probes from the Render tab's button, as an artist does
    # relative to the .blend, as an artist's (the panel's screenshot shows no machine's path)
    scene.bo2.bake_folder = "//" + os.path.relpath(OUT / "bake", ROOM.parent) + "/"
    operators = module("addon.blender.bake_operators")
    started, seconds = yield from bake_all(bpy.ops.bo2.bake_probes,
                                           lambda: operators.BO2_OT_bake_probes.running)
    probes = module("addon.blender.probes")
    states = {o.name: probes.bake_state(o).state
              for o in probes.probe_objects(scene)}
    check("Bake All bakes every probe", started == {"RUNNING_MODAL"}
          and set(states.values()) == {"BAKED"},
          f"{started}, {states} after {seconds:.0f} s")

    # 5a. The bakes belong to the .blend: declared in its own folder and packed into it (the
    # default), unpacked and packed again by the Light Probes panel's buttons
    bake_files = module("addon.blender.bake_files")
    objs = probes.probe_objects(scene)
    own = bake_files.file_folder(scene)
    check("the bakes are in the .blend's own folder and packed into it",
          objs and own == (OUT / "bake" / ROOM.stem).resolve() and all(
              bake_files.packed(o) and bake_files.path(o).parent == own for o in objs),
          [str(bake_files.path(o)) for o in objs])
    unpacked = bpy.ops.bo2.unpack_bakes()
    written = [bake_files.path(o).is_file() and not bake_files.packed(o) for o in objs]
    packed = bpy.ops.bo2.pack_bakes()
    check("Unpack Bakes writes them back, Pack Bakes stores them again",
          unpacked == packed == {"FINISHED"} and all(written)
          and all(bake_files.packed(o) for o in objs), f"{unpacked} {written} {packed}")
    yield from show_tab(objs[0], "DATA")
    yield 1.5
    screenshot("probe_bake_packed", biggest("PROPERTIES"))

    # 5b. Then the lightmaps, from the Lightmaps panel's button; the panel and an object's
    started, seconds = yield from bake_all(bpy.ops.bo2.bake_lightmaps,
                                           lambda: operators._ModalBake.running)
    lightmaps = module("addon.blender.lightmaps")
    states = {o.name: lightmaps.state(o, scene)[0] for o in lightmaps.lightmap_objects(scene)}
    check("Bake All bakes every static object's lightmap", started == {"RUNNING_MODAL"}
          and states and set(states.values()) == {"BAKED"},
          f"{started}, {len(states)} objects: {set(states.values())} after {seconds:.0f} s")

    # 5c. Bake On: Dask Cluster, at the preferences' scheduler (one that ``run.py`` started, of
    # another Python): the bundled Dask reaches it, the bake says why it cannot run there in
    # one line, and the bakes stay as they were
    address = os.environ.get("BO2_GUI_SCHEDULER")
    if address:
        module("addon.blender.props").preferences().scheduler = address
        yield from preferences_shot()
        # what shipping does with the open file: a copy saved, packed by Blender's binary
        copy = OUT / "shipped.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(copy), copy=True, compress=False)
        plain = copy.read_bytes()[:4]
        module("addon.cluster.session").pack_copy(copy)
        check("a shipped copy is packed and saved by Blender's own binary, the open file kept",
              plain == b"BLEN" and copy.read_bytes()[:4] == b"\x28\xb5\x2f\xfd"
              and Path(bpy.data.filepath).resolve() == ROOM.resolve(),
              f"{plain!r} -> {copy.read_bytes()[:4]!r}, open {bpy.data.filepath}")
        scene.bo2.bake_on = "CLUSTER"
        started, seconds = yield from bake_all(bpy.ops.bo2.bake_probes,
                                               lambda: operators._ModalBake.running)
        screenshot("cluster_refused")
        said = yield from reports()
        yield from show_tab(None, "RENDER")
        yield 1.0
        properties = biggest("PROPERTIES")
        scroll(properties, 10)  # down to the Light Probes panel
        redraw()
        yield 1.5
        screenshot("render_tab_cluster", properties)
        scroll(properties, -40)
        scene.bo2.bake_on = "LOCAL"
        states = {o.name: probes.bake_state(o).state for o in probes.probe_objects(scene)}
        wanted = f"the Dask scheduler of {address} runs Python 3.11, this process Python 3."
        check("Bake On Dask Cluster reaches the preferences' scheduler; another Python is one "
              "error, the bakes kept", started == {"RUNNING_MODAL"} and wanted in said
              and "previous bakes kept" in said and set(states.values()) == {"BAKED"},
              f"{started}, {states}, said: {said[-600:]!r}")
    yield from show_tab(None, "RENDER")
    properties = biggest("PROPERTIES")
    scroll(properties, 12)  # down to the Lightmaps panel
    redraw()
    yield 1.5
    screenshot("render_tab_lightmaps", properties)
    scroll(properties, -40)
    floor = scene.objects.get("Floor") or mesh
    yield from show_tab(floor, "OBJECT")
    yield 1.5
    screenshot("object_tab_lightmap", properties)

    # 5d. The look-dev review of the open file's scenes, from the Look-Dev panel's button, at a
    # tenth of the resolution; this Blender's Python 3.14 has no FLIP: the page says why
    review = OUT / "review"
    scene.bo2.lookdev.report_folder = "//" + os.path.relpath(review, ROOM.parent) + "/"
    scene.bo2.lookdev.report_source = "SCENES"
    r = scene.render
    kept = (r.resolution_percentage, scene.bo2.samples, scene.cycles.samples)
    r.resolution_percentage, scene.bo2.samples, scene.cycles.samples = 10, 1, 4
    yield from show_tab(None, "RENDER")
    yield 1.5  # the tab drawn first: a region scrolls within what it has drawn
    window_region = next(r for r in properties.regions if r.type == "WINDOW")
    scroll(properties, 40)  # down to the Look-Dev panel, the last of BO2's
    redraw()
    yield 1.5
    screenshot("render_tab_review", properties)
    with bpy.context.temp_override(window=window(), area=properties, region=window_region):
        started = bpy.ops.bo2.review_report("INVOKE_DEFAULT")
    data, start = {}, time.perf_counter()
    while time.perf_counter() - start < 600:
        yield 2.0
        try:
            data = json.loads((review / "report.json").read_text())
        except (OSError, ValueError):
            continue
        if not data.get("pending") and data.get("scenes"):
            break
    names = [s["name"] for s in data.get("scenes", [])]
    check("Review Report renders the file's scenes onto one page", started == {"RUNNING_MODAL"}
          and names == [scene.name] and (review / "index.html").exists(),
          f"{started}; scenes {names}")
    check("without FLIP the page says why", data.get("flip") is None
          or "flip-evaluator" in data.get("flip", ""), data.get("flip"))
    r.resolution_percentage, scene.bo2.samples, scene.cycles.samples = kept
    scroll(properties, -40)

    # 6. The viewport in Rendered shading, through the camera
    viewports = module("addon.blender.viewport")
    shading = rendered_view()
    view = {}
    yield from wait_final(viewports, view, 300)
    live = view.get("live")
    image = live.session.image() if live is not None else None
    check("Rendered shading draws BO2's image", image is not None and image.samples > 0
          and not (live.error or live.session.error),
          f"after {view.get('seconds', 0):.1f} s: {live.status() if live else 'no view'}")
    screenshot("viewport_rendered")
    if live is None:
        return
    own = image.pixels

    region = next(r for r in biggest("VIEW_3D").regions if r.type == "WINDOW")
    scene.render.preview_pixel_size = "4"  # Blender's Pixel Size: a pixel per 4 x 4
    yield from wait_final(viewports, view, 120)
    check("Pixel Size 4 renders a quarter of the viewport's width",
          live.camera.width == -(-region.width // 4), f"{live.camera.width} of {region.width}")
    scene.render.preview_pixel_size = "AUTO"
    yield from wait_final(viewports, view, 120)

    shading.bo2_lookdev_view = "ALBEDO"  # the look-dev view: this viewport's own
    redraw()
    yield 3.0
    check("the look-dev view is the viewport's", live.session.view == "ALBEDO"
          and not hasattr(scene.bo2, "lookdev_view"), live.session.view)
    screenshot("viewport_lookdev_albedo")
    shading.bo2_lookdev_view = "LIGHTMAP_TEXELS"
    redraw()
    yield 3.0
    texels = live.session.image()
    check("the Lightmap Texels view shows the lightmaps' texels", texels is not None
          and live.session.view == "LIGHTMAP_TEXELS"
          and float(texels.pixels[..., :3].max()) > 0.2, live.status())
    screenshot("viewport_lightmap_texels")
    shading.bo2_lookdev_view = "COMBINED"

    shading.use_scene_world_render = False  # the studio light
    shading.studiolight_rotate_z = 1.0
    yield from wait_final(viewports, view, 120)
    studio = live.session.image()
    check("Scene World off lights the viewport with the studio HDRI",
          live.shading.world is not None and live.shading.world.texture is not None
          and studio is not None and studio.pixels.shape == own.shape
          and abs(float(studio.pixels.mean()) - float(own.mean())) > 1e-3, live.status())
    shading.use_scene_world_render = True
    yield from wait_final(viewports, view, 120)
    back = live.session.image()
    check("Scene World on restores the scene's world and probes", live.shading.world is None
          and back is not None and abs(float(back.pixels.mean()) - float(own.mean())) < 1e-4)

    # 6b. Device GPU: the viewport drawn on the GPU (Mesa's software GL here), the shadow
    # maps' depths drawn there too; an object moved redraws them
    yield from gpu_view(scene, live)

    # 7. Look-dev under the studio light, on the material chart (an open scene)
    bpy.ops.wm.open_mainfile(filepath=str(CHART))
    yield 3.0
    bpy.context.scene.render.engine = ENGINE
    shading = rendered_view()
    shading.use_scene_world_render = False
    shading.studiolight_rotate_z = 2.0
    view = {}
    yield from wait_final(viewports, view, 300)
    live = view.get("live")
    image = live.session.image() if live is not None else None
    check("the material chart under the studio light", image is not None and image.final
          and live.shading.world is not None and not (live.error or live.session.error),
          live.status() if live else "no view")
    screenshot("viewport_studio_light")

    # 8. A world of nodes (a gradient): rendered by Cycles after the edit, then read as a world
    world = bpy.data.worlds.new("Walk Gradient")
    nt = world.node_tree
    coords, split = nt.nodes.new("ShaderNodeTexCoord"), nt.nodes.new("ShaderNodeSeparateXYZ")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.35, 0.2, 0.1, 1.0)
    ramp.color_ramp.elements[1].color = (0.3, 0.55, 1.0, 1.0)
    nt.links.new(coords.outputs["Generated"], split.inputs[0])
    nt.links.new(split.outputs["Z"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    bpy.context.scene.world = world
    shading.use_scene_world_render = True
    worlds = module("addon.blender.worlds")
    start = time.perf_counter()
    while worlds.lookup(bpy.context.scene, world) is None and time.perf_counter() - start < 60:
        yield 1.0
    check("a world of nodes is rendered by Cycles after the edit",
          worlds.lookup(bpy.context.scene, world) is not None and not worlds.direct(world))
    yield from wait_final(viewports, view, 300)
    live = view.get("live")
    image = live.session.image() if live is not None else None
    check("the viewport reads it", image is not None and image.final
          and live.scene is not None and live.scene.world.texture is not None,
          live.status() if live else "no view")
    screenshot("viewport_world_of_nodes")
    yield from show_tab(None, "WORLD")
    yield 1.0
    tab_check("World tab (nodes)", "world",
              {"World.sun_threshold", "World.sun_angle", "World.use_sun_shadow"})


def gpu_view(scene, live):
    """Device GPU in Rendered shading: the frame drawn there, then the table moved: the
    frame prepared anew with its shadow maps' depths left to the GPU, its shadow drawn
    anew there."""
    scene.bo2.device = "GPU"

    def changed(frame, before):
        """Whether ``frame``'s geometry is not ``before``'s (an object moved since)."""
        return (frame is not before and (frame.positions.shape != before.positions.shape
                                         or not np.array_equal(frame.positions, before.positions)))

    def drawn(timeout, replaces=None):
        """Wait until the GPU has drawn every sample of a frame (``replaces``: a frame prepared
        before; wait for one of other geometry whose shadow maps were left to the GPU, as a
        moved object's frame is)."""
        start = time.perf_counter()
        while time.perf_counter() - start < timeout:
            redraw()
            yield 1.0
            frame = live.session.frame()
            if live.gpu_failure or (
                    frame is not None and live.gpu is not None and not live.session.busy
                    and not live.gpu_busy and (replaces is None or (
                        changed(frame[0], replaces) and any(
                            m is not None and m.on_gpu for m in frame[0].shadow_maps)))):
                break
        return time.perf_counter() - start

    seconds = yield from drawn(300)
    frame = live.session.frame()
    maps = [m for m in frame[0].shadow_maps if m is not None] if frame else []
    # the frame the CPU prepared is kept (its shadow maps uploaded): only who draws it changed
    check("Device GPU draws the viewport on the GPU",
          frame is not None and not live.gpu_failure and "GPU" in live.status() and maps,
          f"after {seconds:.1f} s: {live.status()}; maps drawn on the GPU: "
          f"{sum(m.on_gpu for m in maps)} of {len(maps)}")
    screenshot("viewport_gpu")
    table = bpy.data.objects.get("Table top")
    if table is None or frame is None:
        scene.bo2.device = "AUTO"
        return
    table.location.x -= 0.6
    table.location.z += 0.3
    seconds = yield from drawn(300, replaces=frame[0])
    moved = live.session.frame()
    screenshot("viewport_gpu_table_moved")
    before, after = (bpy.data.images.load(str(OUT / shots[k])) for k in (-2, -1))
    diff = float(np.abs(np.asarray(before.pixels[:]) - np.asarray(after.pixels[:])).mean())
    check("a moved object's shadow is drawn anew on the GPU",
          moved is not None and moved[0] is not frame[0] and not live.gpu_failure
          and all(m.on_gpu for m in moved[0].shadow_maps if m is not None) and diff > 1e-3,
          f"after {seconds:.1f} s: {live.status()}; mean change {diff:.4f}")
    table.location.x += 0.6
    table.location.z -= 0.3
    scene.bo2.device = "AUTO"
    yield from drawn(300)


def preferences_shot():
    """The add-on's preferences in the Preferences editor (the 3D viewport shown as one for a
    moment, the add-on expanded), as a screenshot."""
    area = biggest("VIEW_3D")
    area.ui_type = "PREFERENCES"
    bpy.context.preferences.active_section = "ADDONS"
    bpy.context.window_manager.addon_search = "BO2"
    name = next(n for n in bpy.context.preferences.addons.keys() if n.endswith("bo2_lighting"))
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window(), area=area, region=region):
        bpy.ops.preferences.addon_expand(module=name)
    redraw()
    yield 1.5
    screenshot("addon_preferences", area)
    with bpy.context.temp_override(window=window(), area=area, region=region):
        bpy.ops.preferences.addon_expand(module=name)
    bpy.context.window_manager.addon_search = ""
    area.ui_type = "VIEW_3D"
    redraw()
    yield 0.5


def scroll(area, notches: int) -> None:
    """Scroll ``area``'s main region down ``notches`` wheel steps (up when negative)."""
    region = next(r for r in area.regions if r.type == "WINDOW")
    step = bpy.ops.view2d.scroll_down if notches > 0 else bpy.ops.view2d.scroll_up
    with bpy.context.temp_override(window=window(), area=area, region=region):
        for _ in range(abs(notches)):
            step(deltay=120)


def reports():
    """The window's reports, as the Info editor lists them (the Timeline shown as one for a
    moment, its reports copied to the clipboard)."""
    area = biggest("DOPESHEET_EDITOR")
    kind = area.ui_type
    area.ui_type = "INFO"
    redraw()
    yield 0.5
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window(), area=area, region=region):
        bpy.ops.info.select_all(action="SELECT")
        bpy.ops.info.report_copy()
    area.ui_type = kind
    return bpy.context.window_manager.clipboard


def bake_all(operator, running):
    """Invoke a modal bake ``operator`` (mode All) over the 3D viewport, as its button does,
    and wait up to 600 s while ``running()``; returns (what the invoke returned, seconds)."""
    view3d = biggest("VIEW_3D")
    region = next(r for r in view3d.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window(), area=view3d, region=region):
        started = operator("INVOKE_DEFAULT", mode="ALL")
    start = time.perf_counter()
    while time.perf_counter() - start < 600:
        yield 2.0
        if not running():
            break
    return started, time.perf_counter() - start


def rendered_view():
    """The biggest 3D viewport in Rendered shading through the scene camera, overlays off;
    its shading."""
    area = biggest("VIEW_3D")
    space = area.spaces.active
    space.region_3d.view_perspective = "CAMERA"
    space.overlay.show_overlays = False
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window(), area=area, region=region):
        bpy.ops.view3d.view_center_camera()
    space.shading.type = "RENDERED"
    redraw()
    return space.shading


def wait_final(viewports, view: dict, timeout: float):
    """Wait until a live BO2 viewport's image is final; ``view`` gets it ("live") and the
    seconds it took."""
    start = time.perf_counter()
    yield 2.0
    while time.perf_counter() - start < timeout:
        redraw()
        live = next(iter(viewports._live), None) if viewports else None
        image = live.session.image() if live is not None else None
        view["live"], view["seconds"] = live, time.perf_counter() - start
        if image is not None and image.final and not live.session.busy:
            return
        yield 1.0


def run(steps):
    try:
        delay = next(steps)
    except StopIteration:
        finish()
        return None
    except Exception:  # noqa: BLE001 - a failed step is a failed check, then the end
        check("the walk runs to its end", False, traceback.format_exc())
        finish()
        return None
    return delay


def finish():
    (OUT / "results.json").write_text(json.dumps({"checks": checks, "screenshots": shots},
                                                 indent=1))
    bpy.ops.wm.quit_blender()


_steps = walk()
bpy.app.timers.register(lambda: run(_steps), first_interval=3.0, persistent=True)
