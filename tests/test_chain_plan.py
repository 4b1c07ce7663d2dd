"""`--form auto` keeps a chain getting coarser (issue 21 item 4): level n + 1 never has more
branches than level n, whichever form each level takes, and a grammar level keeps at most
60 % of the branches of every finer level, as an explicit one does (model.md 5; session 30:
family stalk-162's grammar level 1 had 79 of 80) (simplify/pipeline.chain_plan)."""

from __future__ import annotations

import math

import pytest

from plantlod.lsys.parse import parse_lsys
from plantlod.simplify.pipeline import Options, chain_plan, simplify

# one branch per derivation step: the grammar form's level k has N - k branches, while
# the explicit groupings keep floor(0.6 x) of the level before (model.md 5)
LINEAR = """\
name: lin
derivation_length: 10
branching_angle: 30
force_absorbed: 0.01
force_propagated: 0.7
branch F: length=0.5 radius=0.02 bend_strength=30 rotation_strength=30
leaf L: area=0.004
axiom: A
productions:
  A -> F[+L]A
"""


def _explicit_counts(b: int) -> list[int]:
    out = [b]
    while out[-1] > 1:
        out.append(max(1, math.floor(0.6 * out[-1])))
    return out


def test_the_budget_is_the_fewest_branches_of_any_finer_level():
    system = parse_lsys(LINEAR, "lin.lsys")
    explicit = _explicit_counts(10)                     # 10, 6, 3, 1
    for level in range(1, 8):
        grammar = [10 - k for k in range(1, level)]
        budget = min([10] + grammar + explicit[1:level])
        plan = chain_plan(system, level)
        assert plan.budget == budget
        assert plan.grammar_fits == (10 - level <= math.floor(0.6 * budget))
        assert not plan.grammar_fits                        # one branch fewer a level
        if level < len(explicit):
            assert explicit[plan.explicit_grouping] <= budget
        else:
            assert plan.explicit_grouping is None           # past the last: an error there


@pytest.mark.slow
def test_auto_chain_never_gains_branches():
    system = parse_lsys(LINEAR, "lin.lsys")
    counts = [10]
    for level in range(1, 4):          # level 3 is a single branch: the chain's end
        result = simplify(system, Options(level=level, duration=4.0))
        counts.append(result.tree.n_branches)
    assert all(b <= a for a, b in zip(counts, counts[1:])), counts


# one branch whose steps grow only leaves: every grammar level has that one branch
LEAVES_ONLY = """\
name: lob
derivation_length: 3
branching_angle: 30
force_absorbed: 0.005
force_propagated: 0.7
branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20
leaf L: area=0.01
axiom: F A
productions:
  A -> [+L][-L][&L][^L]A
"""


def test_a_grammar_level_no_coarser_than_the_tree_is_no_level():
    """`--form auto` gave "level 1" of 1 -> 1 branch (the grammar form at N - 1 steps, every
    leaf kept as an equivalent one) while --levels said the tree has no levels (a helper's
    runs of odd trees, session 38): a grammar level must have fewer branches than the finer
    level too, so auto takes the explicit form, which has none."""
    from plantlod.lsys.errors import InputError

    system = parse_lsys(LEAVES_ONLY, "lob.lsys")
    assert chain_plan(system, 1).grammar_fits is False
    with pytest.raises(InputError, match="level 1 is past the last: this tree has no levels"):
        simplify(system, Options(level=1))
    # a grammar level asked for by name is still the thesis' N - n steps
    assert simplify(system, Options(level=1, form="grammar")).tree.n_branches == 1
