"""From an L-system to its branch tree: derive, interpret, run the turtle.

The one function every command calls, so that `derive`, `simulate`, `simplify`
and `compare` build trees the same way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .constants import DEFAULT_MAX_MODULES
from .derive import DerivedString, derive, interpret
from .system import LSystem
from .tree import Tree
from .turtle import build_tree


@dataclass
class Built:
    """The stages of building one tree.

    derived     : the string after `steps` derivation steps
    interpreted : the string the turtle read (interpretation rules applied)
    tree        : the branch tree
    steps       : derivation steps taken
    warnings    : messages for people (e.g. leaves dropped for want of a branch)
    """

    derived: DerivedString
    interpreted: DerivedString
    tree: Tree
    steps: int
    warnings: list[str] = field(default_factory=list)


def build(system: LSystem, steps: int | None = None,
          max_modules: int = DEFAULT_MAX_MODULES) -> Built:
    """Derive ``steps`` steps (default: the file's derivation length) and build the tree."""
    n = system.derivation_length if steps is None else steps
    derived = derive(system, n, max_modules=max_modules)
    interpreted = interpret(system, derived, max_modules=max_modules)
    tree, warnings = build_tree_with_warnings(system, interpreted)
    return Built(derived, interpreted, tree, n, warnings)


def build_tree_with_warnings(system: LSystem, interpreted: DerivedString) -> tuple[Tree, list[str]]:
    """Run the turtle, collecting its warnings as strings instead of printing them."""
    import warnings as _warnings

    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        tree = build_tree(system, interpreted)
    return tree, [str(w.message) for w in caught]
