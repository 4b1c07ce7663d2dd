"""Levels of detail: groups, error measures, simplified parameters (docs/simplify.md).

`plantlod.simplify` is both this package and the public function
``plantlod.simplify(system, level=1, **options)`` (plantlod.api.simplify): calling
the package calls the function, so the name means one thing whichever way a
user reaches it. Its options: method, calibrate, wind_range, dt, duration, every,
max_evaluations, form, damping_ratio (`plantlod.simplify.pipeline.Options`;
``inspect.signature(plantlod.simplify)`` and ``help(plantlod.api.simplify)`` show them).
"""

import sys as _sys
import types as _types


class _CallablePackage(_types.ModuleType):
    def __call__(self, *args, **options):
        """The level-``level`` L-system standing for ``system`` (plantlod.api.simplify: an
        `LSystem`, a path, or the text of an L-system, as `plantlod.read_lsystem` reads it).
        The arguments pass on as given, so that Python's TypeError for a wrong call counts
        them as the caller wrote them (``self`` made it one more)."""
        from plantlod.api import simplify   # the API's function; a call, not a dependency

        return simplify(*args, **options)

    @property
    def __signature__(self):
        """The API function's signature, for `inspect.signature` and a notebook's help."""
        import inspect

        from plantlod.api import simplify

        return inspect.signature(simplify)


_sys.modules[__name__].__class__ = _CallablePackage
