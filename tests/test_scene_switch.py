"""State carried across a level switch (model.md 7, scene/switch.py): fine to coarse is the
group's combined angles (on a straight stalk: plain sums, computed here by hand); coarse to
fine shares them by static deflection and gives the level's state back exactly."""

from __future__ import annotations

import numpy as np
import pytest

from golden_util import ROOT
from plantlod.scene.levels import level_chain
from plantlod.scene.switch import Transfer
from plantlod.simplify.static import static_angles, static_parts
from test_motion_fit import ROLLED_STALK


@pytest.fixture(scope="module")
def chains(tmp_path_factory):
    cache = tmp_path_factory.mktemp("cache")
    out = {}
    for name in ("stalk8.lsys", "eval/twin_draw.lsys"):
        chain, _ = level_chain(ROOT / "examples" / name, 5.0, 0.01, 2.0, cache)
        out[name] = (chain, Transfer(chain.trees, chain.groups))
    # a trunk rolled 45° between segments, a leaf on each: its levels carry swing rolls
    # (docs/model.md; which level does is the grouping's choice: rolled 66°, since the mode
    # misfit weighs level 2's merges, none of its levels does)
    rolled = cache / "rolled.lsys"
    rolled.write_text(ROLLED_STALK.replace("T /", "T [&(20) L] /")
                      .replace("rotation_angle: 66", "rotation_angle: 45"))
    chain, _ = level_chain(rolled, 5.0, 0.01, 20.0, cache)      # periods need the time
    assert any(t.swing_roll is not None for t in chain.trees[1:])
    out["rolled"] = (chain, Transfer(chain.trees, chain.groups))
    return out


def test_fine_to_coarse_on_a_stalk_is_the_sum_over_each_group(chains):
    chain, transfer = chains["stalk8.lsys"]
    rng = np.random.default_rng(3)
    full = rng.normal(scale=0.01, size=(4, chain.trees[0].n_branches))
    for level in range(1, len(chain.trees)):
        got = transfer.carry(0, level, full, np.array([5.0, 0.0, 0.0]))
        by_hand = np.zeros((4, chain.trees[level].n_branches))
        for row in range(4):
            np.add.at(by_hand[row], chain.groups[level], full[row])
        np.testing.assert_allclose(got, by_hand, atol=1e-15)


@pytest.mark.parametrize("name", ["stalk8.lsys", "eval/twin_draw.lsys", "rolled"])
def test_a_level_state_through_the_full_tree_and_back_is_unchanged(chains, name):
    chain, transfer = chains[name]
    rng = np.random.default_rng(7)
    for level in range(1, len(chain.trees)):
        state = rng.normal(scale=0.02, size=(4, chain.trees[level].n_branches))
        for wind in ([6.0, 1.0, 0.0], [0.0, 0.0, 0.0]):
            full = transfer.carry(level, 0, state, np.array(wind))
            np.testing.assert_allclose(transfer.carry(0, level, full, np.array(wind)), state,
                                       rtol=1e-9, atol=1e-13)
        if level + 1 < len(chain.trees):                  # between two levels, via the full tree
            coarser = transfer.carry(level, level + 1, state, np.array([6.0, 1.0, 0.0]))
            assert coarser.shape == (4, chain.trees[level + 1].n_branches)


def test_coarse_to_fine_shares_by_static_deflection(chains):
    chain, transfer = chains["stalk8.lsys"]
    wind = np.array([7.0, 0.0, 0.0])
    original = chain.trees[0]
    parts = static_parts(original, (wind / 7.0)[None])
    sb, _ = static_angles(original, 7.0 * parts.leaf + 49.0 * parts.drag)
    level = 1
    state = np.zeros((4, chain.trees[level].n_branches))
    state[0] = 0.03 * (1 + np.arange(state.shape[1]))          # group bend angles
    full = transfer.carry(level, 0, state, wind)
    for g in range(state.shape[1]):
        members = np.flatnonzero(chain.groups[level] == g)
        assert full[0, members].sum() == pytest.approx(state[0, g], rel=1e-12)
        np.testing.assert_allclose(full[0, members] / full[0, members].sum(),
                                   sb[0, members] / sb[0, members].sum(), rtol=1e-12)
    # calm air: the members share equally
    calm = transfer.carry(level, 0, state, np.zeros(3))
    for g in range(state.shape[1]):
        members = np.flatnonzero(chain.groups[level] == g)
        np.testing.assert_allclose(calm[0, members], state[0, g] / len(members), rtol=1e-12)


def test_members_turned_half_round_share_a_calm_state_without_cancelling():
    """A group of two segments, the second turned half round (ψ = π after a `-` turn): in W_0
    its angles count with the opposite sign (model.md 5), so equal calm shares would cancel
    and the state would come back as 0. Shares carried into W_0 give it back."""
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys
    from plantlod.simplify.explicit import explicit_system_text, level_header
    from plantlod.simplify.grouping import Grouping

    text = ("name: rolled pair\nderivation_length: 0\nbranching_angle: 30\nrotation_angle: 90\n"
            "force_absorbed: 0.002\nforce_propagated: 0.7\ndrag_coefficient: 0.0015\n"
            "branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=30\n"
            "leaf L: area=0.01\naxiom: F -(5) F L\n")
    system = parse_lsys(text, "pair.lsys")
    original = build(system).tree
    grouping = Grouping(np.zeros(2, dtype=np.int64), np.zeros(1, dtype=np.int64))
    _, level = explicit_system_text(original, grouping, name="t", header=level_header(system),
                                    level=1, dt=0.01, motion=False, refine=False)
    transfer = Transfer([original, level], [np.arange(2), np.zeros(2, dtype=np.int64)])
    state = np.array([[0.01], [-0.02], [0.03], [0.005]])
    full = transfer.carry(1, 0, state, np.zeros(3))
    assert full[0, 0] == pytest.approx(-full[0, 1])              # equal in W_0: opposite own angles
    np.testing.assert_allclose(transfer.carry(0, 1, full, np.zeros(3)), state, rtol=1e-12)


@pytest.mark.parametrize("name", ["eval/twin_draw.lsys", "rolled"])
def test_between_two_levels_the_coarser_chords_point_at_the_finer_levels_tips(chains, name):
    """Level a -> level b (0 < a < b): every chord of b, posed with the carried angles,
    points from its base at the tip of the level-a branch that stands for its group tip
    (`Transfer.tips_matched`), and keeps pointing there as both move on by their rates
    (to second order in the step): checked with the pose alone. Through the full tree, a
    sympodial tree's level 2 at 15 m/s put its tips 12 cm from level 1's, and a twin_draw
    switch at 20 m/s carried rates of 5e11 rad/s (session 30)."""
    from plantlod.sim.kinematics import pose

    chain, transfer = chains[name]
    rng = np.random.default_rng(11)
    wind = np.array([6.0, 1.0, 0.0])

    def misalignment(a, b, fine, coarse):
        fine_tip = {int(p[-1]): j for j, p in enumerate(transfer.paths(a))}
        target = pose(chain.trees[a], fine[0], fine[1]).tip[
            [fine_tip[int(p[-1])] for p in transfer.paths(b)]]
        posed = pose(chain.trees[b], coarse[0], coarse[1])
        want, chord = target - posed.base, posed.tip - posed.base
        cos = np.einsum("gi,gi->g", want, chord) / (np.linalg.norm(want, axis=1)
                                                    * np.linalg.norm(chord, axis=1))
        return float(np.max(np.arccos(np.clip(cos, -1.0, 1.0))))

    for a in range(1, len(chain.trees) - 1):
        b = a + 1
        state = rng.normal(scale=0.1, size=(4, chain.trees[a].n_branches))
        got = transfer.carry(a, b, state, wind)
        assert misalignment(a, b, state[[0, 2]], got[[0, 2]]) < 1e-7
        moved = [misalignment(a, b, state[[0, 2]] + step * state[[1, 3]],
                              got[[0, 2]] + step * got[[1, 3]]) for step in (1e-2, 5e-3)]
        assert moved[0] < 1e-3 and moved[1] < 0.35 * moved[0] + 1e-7   # second order
