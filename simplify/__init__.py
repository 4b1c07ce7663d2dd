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
        """The level-``level`` L-system standing for ``system`` (plantlod.api.simplify: an
        `LSystem`, a path, or the text of an L-system, as `plantlod.read_lsystem` reads it)."""
        from plantlod.api import simplify   # the API's function; a call, not a dependency

        return simplify(system, level, **options)


_sys.modules[__name__].__class__ = _CallablePackage
