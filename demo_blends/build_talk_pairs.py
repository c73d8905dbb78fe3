"""Build the scenes of the talk's old-versus-new pairs: ``pair_<name>.blend`` for each of
normalization, prefilter and env_brdf (``tools/render_old_vs_new.py`` renders them; the direct
terms' pair uses ``old_vs_new.blend``). Each is made so that its pair shows what the slides show:

- normalization ("Environment map normalization: old method / new method"): a dim room lit
  through a window on one side; a row of blurry metal spheres from the window into the room
  and one reflection probe in the middle. BO1 scales a reflection by the point's average
  irradiance, the same on every side of a sphere, so the sides facing away from the window
  glow with the window's light; BO2 scales by the irradiance at the normal, so they stay dark;
- prefilter ("Environment map pre-filtering"): chrome spheres of rising gloss in a dark room
  with bright light strips, reflected by one probe: the angular Gaussian's and the cosine
  power's blur differ most at middle gloss;
- env_brdf ("Environment BRDF"): a dark dielectric floor in strips of rising gloss under a
  bright sky, seen at grazing angles: BO1's environment Fresnel ignores roughness, so the rough
  strips brighten towards the horizon, where the environment BRDF keeps them dim.

Run with a Python that has ``bpy``:  python demo_blends/build_talk_pairs.py [OUT_DIR]
"""

import math
import sys
from pathlib import Path

import bpy
from scene_kit import ball, bo2_material, camera, closed_room, empty_scene, light, probe, sky, slab

HERE = Path(__file__).resolve().parent
PAIRS = ("normalization", "prefilter", "env_brdf")


def new_scene(lens: float, location, rotation_deg):
    scene = empty_scene()
    scene.cycles.samples = 64
    scene.bo2.probes.volume_face_size = "16"
    camera(lens, location, rotation_deg)
    return scene


def room_probe(name, lo, hi, resolution):
    """A reflection probe in the middle of the box ``lo``-``hi``, its reflections corrected to
    the box, and a volume of ``resolution`` samples filling it."""
    centre = [(a + b) / 2 for a, b in zip(lo, hi, strict=True)]
    half = [(b - a) / 2 for a, b in zip(lo, hi, strict=True)]
    refl = probe("SPHERE", f"{name} reflection", centre, scale=half,
                 influence_distance=2.0 * max(half), falloff=0.1)
    refl.data.use_custom_parallax = True
    refl.data.parallax_type = "BOX"
    refl.data.parallax_distance = 1.0
    probe("VOLUME", f"{name} irradiance", centre, scale=half, resolution_x=resolution[0],
          resolution_y=resolution[1], resolution_z=resolution[2], influence_distance=0.2)


def normalization():
    scene = new_scene(22, (2.7, -2.3, 1.3), (78, 0, 62))
    wall = bo2_material("Dark wall", (0.25, 0.25, 0.25), (0.04,) * 3, 0.3)
    closed_room((-3.0, -2.5, 0.0), (3.0, 2.5, 3.0), wall, window=(-1.6, 1.6, 0.6, 2.6))
    metal = bo2_material("Blurry metal", (0.0, 0.0, 0.0), (0.9, 0.9, 0.9), 0.45)
    for i, x in enumerate((-2.2, -1.1, 0.0, 1.1, 2.2)):
        ball(f"Sphere {i}", 0.45, (x, 0.3, 0.45), metal)
    sky((1.5, 1.8, 2.4))
    light("SUN", "Sun", (-6, 0, 5), (math.radians(60), 0, math.radians(-90)), energy=4.0,
          angle=math.radians(1.0))
    room_probe("Room", (-3.0, -2.5, 0.0), (3.0, 2.5, 3.0), (8, 6, 4))
    return scene


def prefilter():
    scene = new_scene(26, (0.0, -4.8, 1.5), (80, 0, 0))
    dark = bo2_material("Black room", (0.02, 0.02, 0.02), (0.04,) * 3, 0.2)
    closed_room((-5.0, -5.0, 0.0), (5.0, 5.0, 4.0), dark)
    strip = bo2_material("Light strip", (0.0, 0.0, 0.0), (0.0,) * 3, 0.0, (1.0, 0.95, 0.9),
                         40.0)
    for i, (lo, hi) in enumerate([((-4.0, 4.9, 0.5), (-3.6, 5.0, 3.5)),
                                  ((-0.8, 4.9, 0.5), (-0.4, 5.0, 3.5)),
                                  ((2.4, 4.9, 0.5), (2.8, 5.0, 3.5)),
                                  ((-4.0, -1.0, 3.9), (4.0, -0.6, 4.0)),
                                  ((4.9, -3.0, 1.8), (5.0, 3.0, 2.1))]):
        slab(f"Strip {i}", lo, hi, strip)
    for i, gloss in enumerate((0.4, 0.55, 0.7, 0.85, 1.0)):
        ball(f"Chrome {gloss}", 0.42, (-2.2 + 1.1 * i, 0.0, 1.0),
             bo2_material(f"Chrome {gloss}", (0.0,) * 3, (0.95, 0.95, 0.95), gloss))
    slab("Plinth", (-2.8, -0.5, 0.0), (2.8, 0.5, 0.58), dark)
    sky((0.0, 0.0, 0.0))
    room_probe("Dark room", (-5.0, -5.0, 0.0), (5.0, 5.0, 4.0), (4, 4, 3))
    return scene


def env_brdf():
    scene = new_scene(28, (0.0, -6.0, 0.35), (86, 0, 0))
    bpy.ops.mesh.primitive_plane_add(size=40.0, location=(0.0, 14.0, 0.0))
    bpy.context.object.name = "Ground"
    bpy.context.object.data.materials.append(
        bo2_material("Ground", (0.05, 0.05, 0.05), (0.04,) * 3, 0.3))
    for i, gloss in enumerate((0.1, 0.3, 0.5, 0.7, 0.9)):
        x = -3.2 + 1.6 * i
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(x, 14.0, 0.002))
        strip = bpy.context.object
        strip.name = f"Strip {gloss}"
        strip.scale = (1.4, 40.0, 1.0)
        strip.data.materials.append(
            bo2_material(f"Floor {gloss}", (0.03, 0.03, 0.03), (0.04,) * 3, gloss))
    sky((1.0, 1.1, 1.3))
    probe("SPHERE", "Sky reflection", (0.0, 0.0, 1.0), influence_distance=60.0,
          use_custom_parallax=True, parallax_distance=1.0e4)
    return scene


if __name__ == "__main__":
    out = Path(sys.argv[-1]) if len(sys.argv) > 1 and not sys.argv[-1].endswith(".py") else HERE
    out.mkdir(parents=True, exist_ok=True)
    for name in PAIRS:
        globals()[name]()
        path = out / f"pair_{name}.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
        print(f"wrote {path}")
