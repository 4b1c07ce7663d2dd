"""OpenBLAS's kernels pinned to one CPU type, so that results do not depend on the machine's vector width.

OpenBLAS (numpy's and scipy's own copies, built with DYNAMIC_ARCH) picks its kernels when
it is loaded, by the CPU: on a machine with AVX-512 the SkylakeX kernels, on one with AVX2
the Haswell ones. They add the terms of a dot product or a norm in other orders, so the last
bits differ, and an iterative fit that reads them (scipy's lsmr inside the refinement's
least squares, `plantlod.simplify.refine`) stops elsewhere: abop_1_24f's level 1 came out with
drag coefficients 1.2e-4 (relative to the largest) from the golden file on an AVX-512 machine,
and the same bytes as it with OPENBLAS_CORETYPE=Haswell. `pin_openblas_kernels` sets that
variable (unless the user has set it) where the CPU runs the Haswell kernels (x86-64 with AVX2
and FMA), before numpy is first imported: `plantlod/__init__.py` calls it, and every module
of plantlod imports that first. A program that imports numpy before plantlod keeps the
kernels OpenBLAS chose (the variable is read only when the library is loaded). Thread counts
are the other half of the same rule (`plantlod.sim.blas_threads`).
"""

from __future__ import annotations

import os
import sys

CORE_TYPE = "Haswell"                       # AVX2 + FMA kernels: every x86-64 CPU since 2013
NEEDED_FLAGS = ("avx2", "fma")              # what they need, as /proc/cpuinfo names it


def cpu_flags(path: str = "/proc/cpuinfo") -> set[str]:
    """The first 'flags' line of ``path`` as a set (empty where there is no such file)."""
    try:
        with open(path, encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.partition(":")[2].split())
    except OSError:
        pass
    return set()


def this_machine() -> str:
    """The CPU architecture as uname names it ('x86_64', 'aarch64'); `os.uname` where there is
    one, so that ``import plantlod`` does not import the platform module (2-3 ms) for it."""
    uname = getattr(os, "uname", None)
    if uname is not None:
        return uname().machine
    import platform                             # (Windows: no os.uname)

    return platform.machine()


def runs_core_type(machine: str | None = None, flags: set[str] | None = None) -> bool:
    """Whether a CPU runs CORE_TYPE's kernels: x86-64 with NEEDED_FLAGS. ``machine``,
    ``flags``: this machine's (`this_machine`, `cpu_flags`) unless given."""
    if (machine or this_machine()).lower() not in ("x86_64", "amd64"):
        return False
    return set(NEEDED_FLAGS) <= (cpu_flags() if flags is None else flags)


def pin_openblas_kernels(environ=os.environ, machine: str | None = None,
                         flags: set[str] | None = None, numpy_loaded: bool | None = None
                         ) -> str | None:
    """Set OPENBLAS_CORETYPE to CORE_TYPE where it applies; the core type in force (None:
    OpenBLAS chooses). Does nothing where the user set the variable, where numpy is loaded
    already (too late to matter), or on a CPU that cannot run those kernels. ``machine``,
    ``flags``: as `runs_core_type`; ``numpy_loaded``: numpy in sys.modules unless given."""
    if "OPENBLAS_CORETYPE" in environ:
        return environ["OPENBLAS_CORETYPE"]
    if ("numpy" in sys.modules) if numpy_loaded is None else numpy_loaded:
        return None
    if not runs_core_type(machine, flags):
        return None
    environ["OPENBLAS_CORETYPE"] = CORE_TYPE
    return CORE_TYPE
