"""Shader programs: the ``.glsl`` sources of ``glsl/`` joined with their defines and uniform
structs into ``gpu.types.GPUShaderCreateInfo``, compiled once per session.

A shader that fails to compile raises ``ShaderError`` naming the driver's first error line
(Blender prints the log on the console only: it is captured while compiling).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

GLSL = Path(__file__).resolve().parent / "glsl"


class ShaderError(RuntimeError):
    """A shader did not compile: the message names the cause."""


def source(*names: str) -> str:
    """The ``glsl/`` files ``names`` (without ``.glsl``), joined in order."""
    return "\n".join((GLSL / f"{name}.glsl").read_text() for name in names)


@dataclass
class Program:
    """What makes one shader: its stages' sources, interface and resources.

    kind:      "compute" or "draw" (vertex + fragment)
    sources:   ``glsl/`` file names joined before ``main`` (in order)
    main:      the stage's ``main`` (compute), or (vertex main, fragment main)
    defines:   name -> value text
    structs:   ``uniforms.Struct`` types declared (in order)
    prelude:   generated GLSL declared after them (constant tables)
    blocks:    (struct name, block member name, e.g. "lights[64]") uniform buffers
    samplers:  (type, name), e.g. ("FLOAT_2D", "shadow_mips")
    images:    (format, type, name) written by a compute shader
    constants: (type, name) push constants
    inputs:    vertex attributes (type, name); varyings: (type, name, "smooth" or "flat")
    outputs:   fragment outputs (type, name), in slot order
    group:     a compute shader's local group size (x, y)
    depth_write: the fragment stage writes gl_FragDepth: "ANY", "LESS" or "GREATER"; None not
    """

    kind: str
    sources: tuple[str, ...]
    main: str | tuple[str, str]
    defines: dict = field(default_factory=dict)
    structs: tuple = ()
    prelude: str = ""
    blocks: tuple = ()
    samplers: tuple = ()
    images: tuple = ()
    constants: tuple = ()
    inputs: tuple = ()
    varyings: tuple = ()
    outputs: tuple = ()
    group: tuple[int, int] = (8, 8)
    depth_write: str | None = None

    def create_info(self):
        import gpu

        info = gpu.types.GPUShaderCreateInfo()
        for name, value in self.defines.items():
            info.define(name, str(value))
        info.typedef_source("".join(s.glsl() for s in self.structs) + self.prelude)
        for slot, (struct, member) in enumerate(self.blocks):
            info.uniform_buf(slot, struct, member)
        for slot, (kind, name) in enumerate(self.samplers):
            info.sampler(slot, kind, name)
        for kind, name in self.constants:
            info.push_constant(kind, name)
        body = source(*self.sources)
        if self.kind == "compute":
            for slot, (fmt, kind, name) in enumerate(self.images):
                info.image(slot, fmt, kind, name, qualifiers={"WRITE"})
            info.local_group_size(*self.group)
            info.compute_source(body + "\n" + self.main)
            return info
        for slot, (kind, name) in enumerate(self.inputs):
            info.vertex_in(slot, kind, name)
        if self.varyings:
            iface = gpu.types.GPUStageInterfaceInfo(f"bo2_iface_{abs(hash(self.main)) % 10**8}")
            for kind, name, interpolation in self.varyings:
                getattr(iface, interpolation)(kind, name)
            info.vertex_out(iface)
        for slot, (kind, name) in enumerate(self.outputs):
            info.fragment_out(slot, kind, name)
        if self.depth_write is not None:
            info.depth_write(self.depth_write)
        vertex, fragment = self.main
        info.vertex_source(vertex)
        info.fragment_source(body + "\n" + fragment)
        return info


_compiled: dict[int, object] = {}
KEEP = 96  # compiled shaders kept (a session editing materials makes new ones)


def compiled(program: Program, key) -> object:
    """The ``gpu`` shader of ``program``, compiled on first use and kept under ``key`` (a
    hashable naming the program and what its defines depend on)."""
    shader = _compiled.get(key)
    if shader is not None:
        _compiled[key] = _compiled.pop(key)  # the most recently used last: kept longest
    else:
        shader = _compile(program)
        while len(_compiled) >= KEEP:
            del _compiled[next(iter(_compiled))]
        _compiled[key] = shader
    return shader


def _compile(program: Program):
    import gpu

    info = program.create_info()
    log: list[str] = []
    with _output_captured(log):
        try:
            return gpu.shader.create_from_info(info)
        except Exception as exc:  # noqa: BLE001 - the cause is in the captured log
            error = exc
    lines = [line.strip(" |") for line in "".join(log).splitlines()]
    causes = [line for line in lines if re.search(r"\berror\b\s*[:(]", line, re.I)]
    cause = causes[0] if causes else str(error)
    raise ShaderError(f"The GPU shader did not compile: {cause}")


@contextlib.contextmanager
def _output_captured(log: list[str]):
    """Standard output and error (at the C level, where Blender prints a shader's log: one or
    the other by version) into ``log`` while open; echoed to stderr afterwards."""
    with tempfile.TemporaryFile() as fh:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
        os.dup2(fh.fileno(), 1)
        os.dup2(fh.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            fh.seek(0)
            text = fh.read()
            if text:
                os.write(2, text)
            log.append(text.decode(errors="replace"))
