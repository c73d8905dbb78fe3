"""``addon/cli/patterns.py``, in-process: ``--frames`` lists and ``-o`` path patterns.

Expected values are written out by hand from the documented rules (``bo2 render --help``):
{scene} and {frame} filled in, the last run of ``#`` in the file name is the frame padded to
its length, every image needs its own path.
"""

from pathlib import Path

import pytest

from bo2_lighting.addon.cli import patterns

# --- frame lists -------------------------------------------------------------------------------


@pytest.mark.parametrize("text, frames", [
    ("7", [7]),
    ("0", [0]),
    ("1-10", [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]),
    ("5-5", [5]),
    ("1,3,5-7", [1, 3, 5, 6, 7]),
    ("1-10x2", [1, 3, 5, 7, 9]),
    ("1-10x3", [1, 4, 7, 10]),
    ("1-2x5", [1]),
    ("1-5x2,8", [1, 3, 5, 8]),
    ("10,1-3", [10, 1, 2, 3]),  # in the order given
    ("3,1-4,3", [3, 1, 2, 4]),  # each frame once, where it first appears
    ("-3--1", [-3, -2, -1]),
    ("-2-1", [-2, -1, 0, 1]),
    (" 1 , 2 ", [1, 2]),
    ("1048574", [1048574]),  # Blender's last frame
    ("-1048574", [-1048574]),
])
def test_frame_list(text, frames):
    assert patterns.frame_list(text) == frames


@pytest.mark.parametrize("text", ["", "one", "1,,2", "1-2-3", "1-10x", "x2", "1.5", "1 - 3",
                                  "1-3y2", "+1"])
def test_frame_list_bad_syntax(text):
    with pytest.raises(ValueError, match="invalid frames .* expected e.g. 7, 1-10"):
        patterns.frame_list(text)


@pytest.mark.parametrize("text, item", [
    ("5-1", "5-1"),  # backwards
    ("1-9x0", "1-9x0"),  # no step
    ("1,2,7-3", "7-3"),  # the bad item is named
    ("1048575", "1048575"),  # beyond Blender's frames
    ("-1048575-0", "-1048575-0"),
    ("1-2000000", "1-2000000"),
])
def test_frame_list_bad_range(text, item):
    with pytest.raises(ValueError, match=f"invalid frame range '{item}': A-BxSTEP needs A <= B"):
        patterns.frame_list(text)


# --- output paths ------------------------------------------------------------------------------


@pytest.mark.parametrize("pattern, scene, frame, path", [
    ("out.png", "shot", 7, "out.png"),
    ("{scene}.png", "shot", 7, "shot.png"),
    ("out/{scene}.{frame}.exr", "a", 7, "out/a.7.exr"),
    ("{scene}_{frame:04d}.png", "a", 7, "a_0007.png"),
    ("{frame:03d}.png", "a", 1234, "1234.png"),  # padding is a minimum width
    ("{frame!r}.png", "a", 7, "7.png"),
    ("{{x}}_{frame}.png", "a", 7, "{x}_7.png"),  # doubled braces are braces
    ("{scene}/{scene}_{frame}.png", "a", 2, "a/a_2.png"),
    # Runs of '#': the frame padded to the run's length.
    ("shot_####.png", "a", 7, "shot_0007.png"),
    ("shot_#.png", "a", 7, "shot_7.png"),
    ("shot_##.png", "a", 12345, "shot_12345.png"),
    ("shot_####.png", "a", -7, "shot_-007.png"),
    ("{scene}_###.exr", "b", 42, "b_042.exr"),
    # Only the last run of '#' in the file name is the frame (Blender's rule).
    ("a##_b###.png", "s", 7, "a##_b007.png"),
    ("##{scene}", "x", 2, "02x"),
    ("a/b#/c_##.png", "s", 3, "a/b#/c_03.png"),
    ("a/b#/{scene}.png", "s", 3, "a/b#/s.png"),  # the file name has none: folders keep theirs
    ("renders##/shot.png", "s", 3, "renders##/shot.png"),
    # A '#' that comes from a filled-in value is text, not the frame.
    ("{scene}.png", "x#y", 5, "x#y.png"),
    ("{scene}_#.png", "x#y", 5, "x#y_5.png"),
])
def test_output_path(pattern, scene, frame, path):
    assert patterns.output_path(pattern, scene, frame) == Path(path)


@pytest.mark.parametrize("pattern", ["out.png", "{scene}.png", "{scene}_{frame:04d}.png",
                                     "shot_####.png", "{{x}}.png", "{frame!s}.png"])
def test_check_pattern_accepts(pattern):
    patterns.check_pattern(pattern)


@pytest.mark.parametrize("pattern, message", [
    ("{name}.png", "unknown field {name}, use {scene} and {frame}"),
    ("{}.png", "unknown field {}"),
    ("{0}.png", "unknown field {0}"),
    ("{scene.x}.png", "unknown field {scene.x}"),
    ("{frame:{x}}.png", "unknown field {frame}"),  # no nested fields
    ("{scene:03d}.png", "Unknown format code 'd'"),  # a spec that does not fit the value
    ("{.png", "expected '}' before end of string"),
    ("}.png", "Single '}'"),
])
def test_check_pattern_rejects(pattern, message):
    with pytest.raises(ValueError) as info:
        patterns.check_pattern(pattern)
    assert message in str(info.value)


@pytest.mark.parametrize("pattern, uses", [
    ("{scene}.png", False), ("{frame}.png", True), ("{frame:04d}.png", True),
    ("####.png", True), ("a#/{scene}.png", False), ("out.png", False),
])
def test_uses_frame(pattern, uses):
    assert patterns.uses_frame(pattern) is uses


# --- planning: every image its own path --------------------------------------------------------

A, B = Path("shots/a.blend"), Path("shots/b.blend")


def test_plan_paths_and_labels():
    planned = patterns.plan("out/{scene}_{frame}.png", [A, B], [1, 2])
    assert list(planned.values()) == [
        (Path("out/a_1.png"), "shots/a.blend frame 1"),
        (Path("out/a_2.png"), "shots/a.blend frame 2"),
        (Path("out/b_1.png"), "shots/b.blend frame 1"),
        (Path("out/b_2.png"), "shots/b.blend frame 2"),
    ]
    assert list(planned) == [patterns.path_key(p) for p, _ in planned.values()]


def test_plan_current_frames():
    planned = patterns.plan("{scene}.png", [A, B], None)
    assert list(planned.values()) == [(Path("a.png"), "shots/a.blend"),
                                      (Path("b.png"), "shots/b.blend")]


def test_plan_hash_frames():
    planned = patterns.plan("r/{scene}.####.exr", [A], patterns.frame_list("1-5x2"))
    assert [p for p, _ in planned.values()] == [Path("r/a.0001.exr"), Path("r/a.0003.exr"),
                                                Path("r/a.0005.exr")]


@pytest.mark.parametrize("pattern, blends, frames, message", [
    ("{scene}.png", [A, A], None,
     "-o '{scene}.png' gives a.png for both shots/a.blend and shots/a.blend; "
     "use {scene}, {frame} or #### so that every image has its own path"),
    ("{scene}.png", [A, Path("other/a.blend")], None,  # the same name in two folders
     "gives a.png for both shots/a.blend and other/a.blend;"),
    ("{scene}.png", [A], [1, 2, 3], "gives a.png for both shots/a.blend frame 1 and "
     "shots/a.blend frame 2;"),
    ("x/b#/{scene}.png", [A], [1, 2], "gives x/b#/a.png for both"),  # '#' in a folder
    ("{frame}.png", [A, B], None,  # current frames: assumed the same in every file
     "gives the same path for both shots/a.blend and shots/b.blend;"),
    ("d/{scene}/../x_{frame}.png", [A, B], [1],  # two spellings of one file
     "gives d/b/../x_1.png for both shots/a.blend frame 1 and shots/b.blend frame 1;"),
])
def test_plan_duplicates(pattern, blends, frames, message):
    with pytest.raises(ValueError) as info:
        patterns.plan(pattern, blends, frames)
    assert message in str(info.value)


def test_path_key():
    assert patterns.path_key(Path("a/../b.png")) == patterns.path_key(Path("b.png"))
    assert patterns.path_key(Path("./b.png")) == patterns.path_key(Path("b.png"))
    assert patterns.path_key(Path("b.png")) != patterns.path_key(Path("c.png"))
