"""Comparing a simplified tree with its original (model.md 5 and 6): groups, measures, reports.

Between `sim` and `simplify`: the fit (`plantlod.simplify`) measures its levels with
these, and `plantlod compare` reports them.

    groups   which original branches a simplified branch stands for, main paths,
             combined angles, carrying angles into a group root's frame W_0
    measures amplitude, period, motion, tip errors of model.md 6 (`compare_groups`)
    runs     two simulated (or read) runs of two trees compared (`compare_runs`)
    report   compare's table and JSON; plot: its PNG (matplotlib)

`plantlod.compare` is both this package and the public function
``plantlod.compare(original, *simplified, **options)`` (plantlod.api.compare):
calling the package calls the function, as with `plantlod.simplify`. Its options: wind,
dt, steps, duration, window, bounds, damping, wind_speed, wind_direction, damping_ratio
(``inspect.signature(plantlod.compare)`` and ``help(plantlod.api.compare)`` show them).
"""

import sys as _sys
import types as _types


class _CallablePackage(_types.ModuleType):
    def __call__(self, original, *simplified, **options):
        """Compare simplified trees with the original in one wind (plantlod.api.compare)."""
        from plantlod.api import compare   # the API's function; a call, not a dependency

        return compare(original, *simplified, **options)

    __call__.__qualname__ = "compare"       # (Python's TypeError for a wrong call names it)

    @property
    def __signature__(self):
        """The API function's signature, for `inspect.signature` and a notebook's help."""
        import inspect

        from plantlod.api import compare

        return inspect.signature(compare)


_sys.modules[__name__].__class__ = _CallablePackage
