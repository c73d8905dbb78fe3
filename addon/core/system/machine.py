"""The machine the kernels run on: its memory and the process's limit on it, in words."""

from __future__ import annotations

__all__ = ["limit_note", "physical", "size"]


def physical() -> int | None:
    """Bytes of memory this machine has, or None where the system does not say (Windows)."""
    import os

    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return None


def size(count: int) -> str:
    """Bytes as 'N MiB' under a GiB, else 'N.N GiB'."""
    return f"{count / 2**20:.0f} MiB" if count < 2**30 else f"{count / 2**30:.1f} GiB"


def limit_note() -> str:
    """' under a limit of N MiB of address space (ulimit -v)' when the process has one."""
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, OSError, ValueError):
        return ""
    if soft == resource.RLIM_INFINITY:
        return ""
    return f" under a limit of {size(soft)} of address space (ulimit -v)"
