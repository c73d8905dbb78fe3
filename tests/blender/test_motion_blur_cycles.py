"""Motion blur (Render > Motion Blur) against Cycles and against the closed form: a card that
moves 1 m per frame along x (linear keys), seen from above by an orthographic camera, with
Shutter 0.5 at Position Center, Start and End; and a still card under a camera that moves.
The streak's coverage along x is the share of the shutter the card covers each point, the
overlap of two intervals.
"""

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, film, principled, render_on_devices, render_passes

W, H = 160, 40
SCALE = 4.0  # metres across the frame
CARD = 0.6
SPEED = 1.0  # metres per frame


def build(position="CENTER", camera_moves=False):
    scene = bpy.context.scene
    film(scene, W, H)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    scene.render.motion_blur_position = position
    bpy.ops.mesh.primitive_plane_add(size=CARD)
    card = bpy.context.object
    card.data.materials.append(principled("Card"))
    cam = add_ortho_camera(scene, SCALE, height=2.0)
    mover = cam if camera_moves else card
    sign = -1.0 if camera_moves else 1.0
    for frame, x in ((1, -1.0), (3, 1.0)):
        mover.location.x = sign * x * SPEED
        mover.keyframe_insert("location", index=0, frame=frame)
    linear_keys(scene)
    scene.frame_set(2)
    return scene


def linear_keys(scene):
    """Blender 5's layered actions keep their curves in channel bags: every key linear."""
    for obj in scene.objects:
        action = obj.animation_data.action if obj.animation_data else None
        if action is None:
            continue
        curves = list(getattr(action, "fcurves", []))
        for layer in getattr(action, "layers", []):
            for strip in layer.strips:
                for bag in strip.channelbags:
                    curves += list(bag.fcurves)
        for fc in curves:
            for key in fc.keyframe_points:
                key.interpolation = "LINEAR"


def coverage(x, start, travel=0.5 * SPEED, width=CARD):
    lo = np.clip((x - width / 2 - start) / travel, 0.0, 1.0)
    hi = np.clip((x + width / 2 - start) / travel, 0.0, 1.0)
    return hi - lo


OPENS = {"CENTER": -0.25, "START": 0.0, "END": -0.5}  # the card's x when the shutter opens


@pytest.mark.parametrize(("position", "camera_moves"), [("CENTER", False), ("START", False),
                                                         ("END", False), ("CENTER", True)])
def test_the_streak_matches_cycles_and_the_closed_form(addon, position, camera_moves):
    """The alpha along the frame's middle row within 0.08 of the closed form and of Cycles
    at every pixel (64 samples: steps of 1/64, and the pixel filter), its mean within 0.01;
    the streak as long as the card's width and its travel."""
    scene = build(position, camera_moves)
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=128)["Combined"]
    x = (np.arange(W) + 0.5) / W * SCALE - SCALE / 2
    row = H // 2
    expected = coverage(x, OPENS[position])
    a, b = ours[row, :, 3], cycles[row, :, 3]
    print(position, camera_moves, "BO2", np.round(a[60:100], 2))
    print(position, camera_moves, "Cycles", np.round(b[60:100], 2))
    for name, got in (("closed form", expected), ("Cycles", b)):
        assert np.abs(a - got).max() < 0.08, name
        assert abs(a.mean() - got.mean()) < 0.01, name
    assert (a > 0.02).sum() >= (CARD + 0.5 * SPEED - 0.1) / SCALE * W  # streaked


def test_motion_blur_off_renders_the_frame_sharp(addon):
    scene = build()
    scene.render.use_motion_blur = False
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=16)["Combined"]
    x = (np.arange(W) + 0.5) / W * SCALE - SCALE / 2
    inside = np.abs(x) < CARD / 2 - 0.05
    outside = np.abs(x) > CARD / 2 + 0.05
    assert (ours[H // 2, inside, 3] == 1.0).all() and (ours[H // 2, outside, 3] == 0.0).all()


def test_changing_geometry_renders_still_with_one_warning(addon):
    """A Build modifier adds faces every frame: the card cannot be followed over the shutter,
    so it renders as the frame shows it, with one warning; a card with one key (nothing to
    move between) renders sharp without any."""
    from bo2_lighting.addon.blender import engine

    scene = build()
    card = scene.objects["Plane"]
    bpy.ops.object.select_all(action="DESELECT")
    card.select_set(True)
    bpy.context.view_layer.objects.active = card
    bpy.ops.object.modifier_add(type="SUBSURF")
    card.modifiers[-1].subdivision_type = "SIMPLE"
    card.modifiers[-1].levels = card.modifiers[-1].render_levels = 3
    build_faces = card.modifiers.new("Build", "BUILD")
    build_faces.frame_start, build_faces.frame_duration = 1.0, 4.0
    scene.frame_set(2)
    with engine.listening() as said:
        image = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=8)["Combined"]
    warned = [t for t in said.texts() if "changes over the shutter" in t]
    assert len(warned) == 1 and "Plane" in warned[0], said.texts()
    assert np.isfinite(image).all()
    alpha = image[..., 3]
    assert ((alpha > 0.0) & (alpha < 1.0)).sum() < 0.05 * alpha.size  # no streak


def test_one_key_is_no_motion(addon):
    from bo2_lighting.addon.blender import engine

    scene = build()
    card = scene.objects["Plane"]
    card.animation_data_clear()
    card.location.x = 0.0
    card.keyframe_insert("location", index=0, frame=1)
    with engine.listening() as said:
        image = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=16)["Combined"]
    assert not [t for t in said.texts() if "shutter" in t], said.texts()
    x = (np.arange(W) + 0.5) / W * SCALE - SCALE / 2
    assert (image[H // 2, np.abs(x) < CARD / 2 - 0.05, 3] == 1.0).all()
    assert (image[H // 2, np.abs(x) > CARD / 2 + 0.05, 3] == 0.0).all()


def test_the_gpu_draws_the_streak_and_its_shadow_as_the_cpu(addon):
    """Device GPU: the card's streak and its shadow's as the CPU draws them (where there is
    no GPU context: the CPU, said so)."""
    images = render_on_devices(shadow_build(), ["Combined"], samples=16)
    if images is not None:
        np.testing.assert_allclose(images["GPU"]["Combined"], images["CPU"]["Combined"],
                                   atol=0.02)


def test_deformation_off_keeps_the_transforms_motion(addon):
    """Object > Motion Blur > Deformation off: the card still streaks by its transform (the
    frame's corners carried by each step's matrix); Motion Blur off: it renders sharp."""
    scene = build()
    card = scene.objects["Plane"]
    card.cycles.use_deform_motion = False
    x = (np.arange(W) + 0.5) / W * SCALE - SCALE / 2
    alpha = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"][H // 2,
                                                                                          :, 3]
    assert np.abs(alpha - coverage(x, OPENS["CENTER"])).mean() < 0.02
    card.cycles.use_motion_blur = False
    alpha = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=16)["Combined"][H // 2,
                                                                                          :, 3]
    assert (alpha[np.abs(x) < CARD / 2 - 0.05] == 1.0).all()


def shadow_build(sun_angle_deg=45.0):
    """The card of ``build`` 1 m above a white floor, under a sun tilted by ``sun_angle_deg``
    towards +y (its shadow falls 1 m from it at 45 degrees), seen from 3 m above; the view
    spans y in [-0.5, 1.5]."""
    scene = build()
    film(scene, W, 2 * H, transparent=False)
    card = scene.objects["Plane"]
    card.location.z = 1.0
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bpy.context.object.data.materials.append(principled("Floor", roughness=1.0))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, 0.0
    sun.rotation_euler = (np.radians(sun_angle_deg), 0.0, 0.0)
    scene.collection.objects.link(sun)
    scene.camera.location = (0.0, 0.5, 3.0)
    scene.frame_set(2)
    return scene


def test_a_moving_cards_shadow_streaks_as_cycles_and_the_closed_form(addon):
    """The card's shadow on the floor streaks as the card does: along the row through the
    shadow's middle, the share of the sun it takes within 0.15 of Cycles' and of the closed
    form (the coverage of the card's travel) at every pixel (the shutter shaded in
    ``SHUTTER_TIMES`` shares: steps of 1/16), its mean within 0.02; the card itself lit as in
    Cycles (it never shadows itself from another time)."""
    scene = shadow_build()
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=128)["Combined"]
    x = (np.arange(W) + 0.5) / W * SCALE - SCALE / 2
    y = 1.5 - (np.arange(2 * H) + 0.5) / (2 * H) * 2.0  # row 0 at the top
    shadow_row, card_row = int(np.argmin(np.abs(y - 1.0))), int(np.argmin(np.abs(y)))
    expected = coverage(x, OPENS["CENTER"])

    def taken(image):  # the share of the sun the card takes from the floor along the row
        lum = image[shadow_row, :, :3].mean(-1)
        lit = np.median(lum[np.abs(x) > 1.2])
        return 1.0 - lum / lit

    a, b = taken(ours), taken(cycles)
    print("BO2", np.round(a[60:100], 2))
    print("Cycles", np.round(b[60:100], 2))
    for name, got in (("closed form", expected), ("Cycles", b)):
        assert np.abs(a - got).max() < 0.15, name
        assert abs(a.mean() - got.mean()) < 0.02, name
    covered = expected > 0.99  # where the card is seen over the whole shutter
    card_ours, card_cycles = (im[card_row, covered, :3].mean() for im in (ours, cycles))
    print("card", card_ours, card_cycles)
    assert abs(card_ours / card_cycles - 1.0) < 0.1


@pytest.mark.parametrize("duration", [0.0, 0.1])
def test_a_rolling_shutter_slants_the_streak_as_cycles(addon, duration):
    """Render > Motion Blur > Rolling Shutter Top-Bottom: a card taller than the frame moves
    0.5 m (20 px) over the shutter; row r (top first) is read at ((r + 1) / H - 1/2)(1 - d)
    + 1/2 of the shutter, spread by the Duration d (Cycles' camera kernel). Its alpha within
    0.15 of Cycles' and of that closed form at every pixel (the pixel filter across the
    edges, which the closed form leaves out), the mean within 0.005; the card's centre moves
    0.5 (1 - d) m from the top row to the bottom one."""
    scene = build()
    bpy.data.objects["Plane"].scale.y = 2.0
    scene.cycles.rolling_shutter_type = "TOP"
    scene.cycles.rolling_shutter_duration = duration
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"][..., 3]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=128)["Combined"][..., 3]
    x = (np.arange(W) + 0.5) / W * SCALE - SCALE / 2
    expected = np.empty((H, W))
    travel = 0.5 * SPEED
    for r in range(H):
        t_row = ((r + 1) / H - 0.5) * (1.0 - duration) + 0.5
        if duration > 0.0:
            expected[r] = coverage(x, OPENS["CENTER"] + travel * (t_row - duration / 2),
                                   travel * duration)
        else:  # the card's edges at the row's time, across their pixel
            centre = OPENS["CENTER"] + travel * t_row
            expected[r] = np.clip((CARD / 2 - np.abs(x - centre)) * W / SCALE + 0.5, 0, 1)
    for name, got in (("closed form", expected), ("Cycles", cycles)):
        error = np.abs(ours - got)
        print(duration, name, round(float(error.max()), 3), round(float(error.mean()), 4))
        assert error.max() < 0.15 and error.mean() < 0.005, name
    centre = (ours * x).sum(1) / ours.sum(1)
    slope = np.polyfit(np.arange(H), centre, 1)[0] * H
    assert abs(slope - travel * (1.0 - duration)) < 0.02


def test_a_rolling_shutter_renders_on_the_cpu_saying_why(addon):
    from bo2_lighting.addon.blender import engine

    scene = build()
    scene.cycles.rolling_shutter_type = "TOP"
    scene.bo2.device = "GPU"
    with engine.listening() as said:
        render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=4)
    texts = " ".join(said.texts())
    assert "Rendered on the CPU" in texts and ("rolling shutter" in texts
                                                or "no GPU context" in texts), texts
