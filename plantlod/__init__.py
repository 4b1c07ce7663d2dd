"""plantlod: wind-blown L-system trees with levels of detail.

    import plantlod
    system = plantlod.read_lsystem("examples/stalk8.lsys")
    angles = plantlod.simulate(plantlod.derive(system), wind=(2, 0, 0), dt=0.01, steps=400)
    level = plantlod.simplify(system, level=1)

The public API (docs/api.md) is loaded on first use (PEP 562), so ``import
plantlod`` costs almost nothing. The subpackages each own one responsibility and
import one way, bottom to top (tests/test_package_graph.py keeps it so):

    lsys (language) -> sim (dynamics) -> compare (error measures) -> simplify (levels of detail)
        -> scene (many trees, camera-chosen levels) / export (glTF, USD, OBJ, pages)
        -> plantlod (this API) -> cli (commands)

`formats` reads and writes bytes and imports nothing above `lsys`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from plantlod.blas_kernels import pin_openblas_kernels

pin_openblas_kernels()          # before numpy loads OpenBLAS: the same bits on any x86-64 CPU

__all__ = ["Angles", "InputError", "LSystem", "PlantlodError", "PlantlodWarning", "RunFailure", "Tree",
           "__version__", "compare", "derive", "export_animation", "read_angles", "read_lsystem",
           "read_tree", "simplify", "simulate", "write_angles", "write_lsystem", "write_tree",
           "write_view"]

_FROM = {
    **{name: "plantlod.api" for name in ("Angles", "derive", "export_animation",
                                         "read_angles", "write_view",
                                         "read_lsystem", "read_tree", "simulate",
                                         "write_angles", "write_lsystem", "write_tree")},
    "InputError": "plantlod.lsys.errors", "PlantlodError": "plantlod.lsys.errors",
    "PlantlodWarning": "plantlod.lsys.errors",
    "RunFailure": "plantlod.lsys.errors", "LSystem": "plantlod.lsys.system",
    "Tree": "plantlod.lsys.tree",
}

if TYPE_CHECKING:  # pragma: no cover - for type checkers and editors only
    from plantlod.api import (Angles, compare, derive, export_animation, read_angles,
                              read_lsystem, read_tree, simplify, simulate, write_angles,
                              write_lsystem, write_tree, write_view)
    from plantlod.lsys.errors import InputError, PlantlodError, PlantlodWarning, RunFailure
    from plantlod.lsys.system import LSystem
    from plantlod.lsys.tree import Tree


def __getattr__(name: str) -> Any:
    import importlib

    if name == "__version__":       # read from the installed metadata on first use (25 ms)
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("plantlod")
        except PackageNotFoundError:  # a source tree that was never installed
            value = "0+unknown"
        globals()["__version__"] = value
        return value
    if name == "compare":
        # likewise plantlod.compare: the subpackage, callable as plantlod.api.compare
        return importlib.import_module("plantlod.compare")
    if name == "simplify":
        # the subpackage plantlod.simplify is callable as plantlod.api.simplify, so that
        # the name stays one object once any of its modules has been imported
        return importlib.import_module("plantlod.simplify")
    module = _FROM.get(name)
    if module is None:
        raise AttributeError(f"module 'plantlod' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
