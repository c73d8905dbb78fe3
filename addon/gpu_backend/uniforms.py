"""Uniform blocks declared once: a ``Struct`` gives its GLSL declaration and packs records
into the std140 bytes a ``gpu.types.GPUUniformBuf`` takes (OpenGL 4.6 core profile, section
7.6.2.2, "Standard Uniform Block Layout")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# type -> (components, base alignment in bytes, numpy kind)
_TYPES = {"float": (1, 4, np.float32), "int": (1, 4, np.int32), "vec2": (2, 8, np.float32),
          "vec3": (3, 16, np.float32), "vec4": (4, 16, np.float32),
          "ivec4": (4, 16, np.int32), "mat4": (16, 16, np.float32)}


@dataclass(frozen=True)
class Struct:
    """A GLSL struct of ``fields``: (name, type, count), count 0 for a single value; types of
    ``_TYPES``. Arrays take a 16-byte stride per element (std140)."""

    name: str
    fields: tuple[tuple[str, str, int], ...]

    def layout(self) -> tuple[dict[str, int], int]:
        """({field: byte offset}, the struct's size rounded to 16 bytes)."""
        offsets, at = {}, 0
        for name, kind, count in self.fields:
            comps, align, _ = _TYPES[kind]
            align = 16 if count else align
            at = -(-at // align) * align
            offsets[name] = at
            if kind == "mat4" and count:
                raise ValueError(f"{self.name}.{name}: arrays of mat4 are not supported")
            at += 16 * count if count else 4 * comps
        return offsets, -(-at // 16) * 16

    def glsl(self) -> str:
        """``struct Name { ... };`` for a shader's ``typedef_source``."""
        lines = [f"  {kind} {name}{f'[{count}]' if count else ''};"
                 for name, kind, count in self.fields]
        return f"struct {self.name} {{\n" + "\n".join(lines) + "\n};\n"

    def pack(self, records: list[dict], count: int | None = None) -> bytes:
        """std140 bytes of an array of ``count`` structs (``len(records)`` by default, at
        least one: a block may not be empty); a record maps field names to values (scalars or
        arrays, flattened: an array's elements filled in order, or from rows (K, C) one row per
        element; a vector's or an array's last components may be left out), a missing field
        or component is 0."""
        offsets, size = self.layout()
        count = max(1, len(records) if count is None else count)
        if len(records) > count:
            raise ValueError(f"{len(records)} {self.name} records for a block of {count}")
        raw = np.zeros(count * size, np.uint8)
        for k, record in enumerate(records):
            for name, kind, n in self.fields:
                if name not in record:
                    continue
                comps, _, dtype = _TYPES[kind]
                value = np.asarray(record[name], dtype)
                if kind == "mat4":  # GLSL matrices are stored column by column
                    value = np.swapaxes(value.reshape(-1, 4, 4), 1, 2)
                elif n and value.ndim == 2 and value.shape[1] < comps:  # rows: one per element
                    value = np.pad(value, ((0, 0), (0, comps - value.shape[1])))
                value = value.reshape(-1)
                at = k * size + offsets[name]
                if n:  # each element in its own 16-byte slot
                    if len(value) > n * comps:
                        raise ValueError(f"{self.name}.{name}: {len(value)} values for "
                                         f"{n} x {kind}")
                    padded = np.zeros((n, 4), dtype)
                    flat = np.zeros(n * comps, dtype)
                    flat[:len(value)] = value
                    padded[:, :comps] = flat.reshape(n, comps)
                    raw[at:at + 16 * n] = padded.view(np.uint8).reshape(-1)
                else:
                    if len(value) > comps or (len(value) < comps and kind == "mat4"):
                        raise ValueError(f"{self.name}.{name}: {len(value)} values for {kind}")
                    raw[at:at + 4 * len(value)] = value.view(np.uint8)  # the rest stays 0
        return raw.tobytes()
