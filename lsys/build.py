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
    if system.groups and n != system.derivation_length:
        from .errors import InputError

        # (its groups: name the branches of its own derivation; another count said "the
        # groups: section names no group for the branch at 1.0.0.0", blaming the file)
        raise InputError(f"a derivation length of {n} (-n, --simplified-n) does not apply to "
                         f"an explicit-form level: its groups: section names the branches its "
                         f"own derivation length ({system.derivation_length}) draws; expected "
                         f"no -n for it", system.source or None)
    derived = derive(system, n, max_modules=max_modules)
    interpreted = interpret(system, derived, max_modules=max_modules)
    tree, warnings = build_tree_with_warnings(system, interpreted)
    if system.groups:
        tree, unmatched = _with_group_roots(system, tree)
        warnings.extend(unmatched)
    if tree.n_branches == 0:
        warnings.append(no_branches_message(system))
    elif system.leaves and tree.n_leaves == 0 and not warnings and not system.groups:
        # (an explicit level, whose groups: section names it, declares its leaf symbol
        # whether or not its original has leaves)
        names = ", ".join(leaf.name for leaf in system.leaves)
        warnings.append(f"the tree has no leaves: no leaf symbol ({names}) is in the derived "
                        "string, so only drag moves its branches (a misspelled symbol?)")
    return Built(derived, interpreted, tree, n, warnings)


def no_branches_message(system: LSystem) -> str:
    """Why a tree has no branch (nothing for the wind to move), and what to write."""
    if not system.branches:
        return ("no branch symbol declared, so the tree has no branches and nothing moves; "
                "declare one: 'branch F: length=1 radius=0.02 bend_strength=20 "
                "rotation_strength=20'")
    names = ", ".join(b.name for b in system.branches)
    return (f"the tree has no branches: no branch symbol ({names}) is in the derived string, "
            "so nothing moves")


def _with_group_roots(system: LSystem, tree: Tree) -> tuple[Tree, list[str]]:
    """``tree`` with `Tree.group_root` from the file's groups: section (every branch named),
    and a warning for each line naming an address that draws no branch (as an override
    that matches nothing gets; such a line was taken without a word, session 30)."""
    from dataclasses import replace

    from .errors import InputError

    roots = {".".join(map(str, a)): root for a, root in system.groups}
    lines = {".".join(map(str, a)): n for (a, _root), n in zip(system.groups, system.group_lines)}
    missing = [a for a in tree.address if a not in roots]
    if missing:
        raise InputError(f"the groups: section names no group for the branch at {missing[0]}"
                         f" ({len(missing)} branches without one); expected a line per branch",
                         system.source or None)
    drawn = set(tree.address)
    unmatched = [a for a in roots if a not in drawn]
    said = [f"groups: line for address {a} names no branch the file draws"
            for a in unmatched[:3]]
    if len(unmatched) > 3:
        said.append(f"{len(unmatched) - 3:,} more groups: lines name no branch the file draws")
    return replace(tree, group_root=[roots[a] for a in tree.address],
                   group_line=[lines.get(a, 0) for a in tree.address]), said


def build_tree_with_warnings(system: LSystem, interpreted: DerivedString) -> tuple[Tree, list[str]]:
    """Run the turtle, collecting its warnings as strings instead of printing them."""
    import warnings as _warnings

    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        tree = build_tree(system, interpreted)
    return tree, [str(w.message) for w in caught]
