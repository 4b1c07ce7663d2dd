"""Levels of detail: groups, error measures, simplified parameters (docs/simplify.md).

`plantlod.simplify` is both this package and the public function
``plantlod.simplify(system, level=1, **options)`` (plantlod.api.simplify): calling
the package calls the function, so the name means one thing whichever way a
user reaches it.
"""

import sys as _sys
import types as _types


class _CallablePackage(_types.ModuleType):
    def __call__(self, system, level=1, **options):
        """The level-``level`` L-system standing for ``system`` (plantlod.api.simplify)."""
        import os

        from .pipeline import simplified_system

        if isinstance(system, (str, os.PathLike)):        # a path, as plantlod.api.simplify
            from plantlod.formats.lsys_file import read_lsys

            system = read_lsys(os.fspath(system))
        return simplified_system(system, level, **options)


_sys.modules[__name__].__class__ = _CallablePackage
