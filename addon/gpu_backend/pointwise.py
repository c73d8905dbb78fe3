"""One GLSL computation over N points: the inputs as textures, a compute shader per point, the
outputs read back. How each stage's GLSL is held to the core's kernels point for point, and how
points shaded on the CPU's G-buffer reach the GPU's shading."""

from __future__ import annotations

import numpy as np

from . import programs, textures


def run(sources: tuple[str, ...], body: str, inputs: dict[str, np.ndarray],
        outputs: tuple[str, ...], *, defines: dict | None = None, structs: tuple = (),
        prelude: str = "", functions: str = "", blocks: tuple = (), samplers: tuple = (),
        key=None) -> dict:
    """Evaluate ``body`` at each of N points.

    sources: ``glsl/`` files declaring the functions ``body`` calls
    body:    GLSL run per point: reads a ``vec4`` per input (same name), sets a ``vec4`` per
             output (same name, zero at first); ``index`` is the point's number
    inputs:  name -> (N, C<=4) float32 (int data: pass its bits with ``.view(np.float32)``)
    outputs: names of the (N, 4) float32 results
    functions: GLSL after the sources, before ``main`` (what ``body`` calls besides them)
    blocks:  (struct name, member, bytes) uniform buffers; samplers: (type, name, texture)
    key:     what names this program among the compiled ones (default: its text)
    returns: {output name: (N, 4) float32}
    """
    n = len(next(iter(inputs.values())))
    program = programs.Program(
        "compute", tuple(sources), functions + _main(body, tuple(inputs), outputs),
        defines=dict(defines or {}), structs=tuple(structs), prelude=prelude,
        blocks=tuple((s, m) for s, m, _ in blocks),
        samplers=tuple((t, name) for t, name, _ in samplers) +
        tuple(("FLOAT_2D", f"in_{name}") for name in inputs),
        images=tuple(("RGBA32F", "FLOAT_2D", f"out_{name}") for name in outputs),
        constants=(("INT", "count"), ("INT", "width")), group=(64, 1))
    shader = programs.compiled(program, key if key is not None else (
        program.main, program.sources, tuple(sorted(program.defines.items())), prelude,
        tuple(s for s, _ in program.samplers)))
    if not n:
        return {name: np.zeros((0, 4), np.float32) for name in outputs}
    import gpu

    feeds = {name: textures.rows(a) for name, a in inputs.items()}
    width = next(iter(feeds.values())).width
    height = -(-n // width)
    results = {name: gpu.types.GPUTexture((width, height), format="RGBA32F")
               for name in outputs}
    shader.bind()
    buffers = [gpu.types.GPUUniformBuf(data) for _, _, data in blocks]  # alive until drawn
    for (_, member, _), buffer in zip(blocks, buffers, strict=True):
        shader.uniform_block(member.partition("[")[0], buffer)
    for _, name, texture in samplers:
        shader.uniform_sampler(name, texture)
    for name, texture in feeds.items():
        shader.uniform_sampler(f"in_{name}", texture)
    for name, texture in results.items():
        shader.image(f"out_{name}", texture)
    shader.uniform_int("count", n)
    shader.uniform_int("width", width)
    gpu.compute.dispatch(shader, -(-width // 64), height, 1)
    return {name: textures.read_rows(t, n) for name, t in results.items()}


def _main(body: str, inputs: tuple[str, ...], outputs: tuple[str, ...]) -> str:
    fetch = "".join(f"  vec4 {name} = texelFetch(in_{name}, c, 0);\n" for name in inputs)
    zero = "".join(f"  vec4 {name} = vec4(0.0);\n" for name in outputs)
    store = "".join(f"  imageStore(out_{name}, c, {name});\n" for name in outputs)
    return ("void main()\n{\n  ivec2 c = ivec2(gl_GlobalInvocationID.xy);\n"
            "  int index = c.y * width + c.x;\n"
            "  if (c.x >= width || index >= count) {\n    return;\n  }\n"
            f"{fetch}{zero}{body}\n{store}}}\n")
