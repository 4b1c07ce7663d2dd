"""Golden files of `plantlod derive` and `plantlod simulate` on the bundled examples.

The golden files (tests/golden/) pin the exact bytes of the commands' output, so
any change to derivation, turtle, tree-file or CSV formatting shows up as a
diff to review (`make golden` rewrites them). Pinned bytes alone would only
reprint the code's own output, so the pinned files are also checked here
against independent computations:

- stalk8's tree file against the structure worked out by hand from its
  L-system (8 branches 0.0.0.0 .. 0.1.1.1 chained, one leaf on top);
- stalk8's angle CSV against the closed form of the first steps (model.md
  section 4 on a vertical stalk: the force recursion F_i = d + k_fp F_(i+1),
  F_top = d + k_fp A v, and the linear recurrence of the scheme), and against
  the slow literal reference model (tests/reference_model.py) at every row;
- the derived strings against hand rewriting of the productions;
- every example's tree header against the counts published in
  examples/README.md.
"""

from __future__ import annotations

import io
import json
import math
import re

import pytest

from golden_util import ROOT, assert_golden, golden_path, run_cli

EXAMPLES = sorted(p.stem for p in (ROOT / "examples").glob("*.lsys"))

# The stalk8 simulation pinned below (docs: `make golden` regenerates it).
STALK8_SIM_ARGS = ("simulate", "examples/stalk8.lsys", "--dt", "0.01", "--steps", "300",
                   "--wind-speed", "10", "--every", "10")

# stalk8.lsys, read by eye: header and declarations.
STALK = dict(k_fa=0.005, k_fp=0.7, c_d=0.0015, length=1.0, radius=0.02, k_bs=20.0,
             k_rs=20.0, area=0.01)

# %.10g keeps 10 significant digits: a value read back is within 5e-10 relative.
CSV_REL = 1e-9


# --- the golden files themselves ------------------------------------------------------

@pytest.mark.parametrize("example", EXAMPLES)
def test_derive_golden(example):
    result = run_cli("derive", f"examples/{example}.lsys")
    assert_golden(f"derive_{example}.jsonl", result.stdout)


@pytest.mark.parametrize("name, args", [
    ("derive_string_stalk8.txt", ("examples/stalk8.lsys",)),
    ("derive_string_abop_2_6_n2.txt", ("examples/abop_2_6.lsys", "-n", "2")),
])
def test_derive_string_golden(name, args):
    result = run_cli("derive", *args, "--format", "string")
    assert_golden(name, result.stdout)


def test_simulate_stalk8_golden():
    result = run_cli(*STALK8_SIM_ARGS)
    assert_golden("simulate_stalk8.csv", result.stdout)


# --- the pinned files against independent computations ---------------------------------

def _pinned(name: str) -> str:
    path = golden_path(name)
    if not path.exists():
        pytest.fail(f"golden file tests/golden/{name} is missing; run `make golden`")
    return path.read_text(encoding="utf-8")


def test_golden_stalk8_tree_by_hand():
    """F -> F F three times from `F L`: 8 straight 1 m branches in one chain, leaf on top."""
    records = [json.loads(line) for line in _pinned("derive_stalk8.jsonl").splitlines()]
    header, branches, leaves = records[0], records[1:9], records[9:]
    assert header == {"format": "plantlod-tree", "version": 1, "source": "examples/stalk8.lsys",
                      "branches": 8, "leaves": 1, "leaf_force_scale": 1.0, "depth": 8}
    # address of the j-th F (j = 0..7): axiom index 0, then the binary digits of j
    expected_addresses = [f"0.{j >> 2 & 1}.{j >> 1 & 1}.{j & 1}" for j in range(8)]
    assert expected_addresses[0] == "0.0.0.0" and expected_addresses[-1] == "0.1.1.1"
    assert [b["address"] for b in branches] == expected_addresses
    assert [b["parent"] for b in branches] == [-1, 0, 1, 2, 3, 4, 5, 6]
    assert [b["index"] for b in branches] == list(range(8))
    for b in branches:
        assert b["type"] == "branch" and b["symbol"] == "F"
        assert (b["length"], b["radius"]) == (STALK["length"], STALK["radius"])
        assert (b["bend_strength"], b["rotation_strength"]) == (STALK["k_bs"], STALK["k_rs"])
        assert (b["force_absorbed"], b["force_propagated"], b["drag_coefficient"]) == (
            STALK["k_fa"], STALK["k_fp"], STALK["c_d"])
        assert (b["phi"], b["alpha"], b["psi"], b["offset"]) == (0.0, 0.0, 0.0, [0.0, 0.0, 0.0])
    # the axiom's L (index 1) is copied unchanged three times: index 0 each step
    assert leaves == [{"type": "leaf", "index": 0, "address": "1.0.0.0", "branch": 7,
                       "area": STALK["area"], "normal": [1.0, 0.0, 0.0]}]


def _stalk_forces(v: float) -> list[float]:
    """Force on each of the 8 vertical branches (base first) in a horizontal wind v (model.md 4).

    The leaf (normal +x, along the wind) pushes with A v; each branch's drag is
    C_d v^2 2 pi r L (the wind is perpendicular to it); F_top = d + k_fp A v,
    F_i = d + k_fp F_(i+1).
    """
    drag = STALK["c_d"] * v * v * 2.0 * math.pi * STALK["radius"] * STALK["length"]
    forces = [drag + STALK["k_fp"] * STALK["area"] * v]
    for _ in range(7):
        forces.append(drag + STALK["k_fp"] * forces[-1])
    return forces[::-1]


def _read_csv(text: str) -> tuple[list[str], list[list[float]]]:
    lines = text.splitlines()
    return lines[0].split(","), [[float(x) for x in line.split(",")] for line in lines[1:]]


def test_stalk8_first_step_by_hand():
    """After step 1, v_b = k_FA F_i and theta_b = dt k_FA F_i; no rotation (model.md 4)."""
    dt, v = 0.01, 10.0
    header, rows = _read_csv(run_cli("simulate", "examples/stalk8.lsys", "--dt", str(dt),
                                     "--steps", "1", "--wind-speed", str(v)).stdout)
    assert rows[0] == [0.0] * 17
    t, *angles = rows[1]
    assert t == dt
    forces = _stalk_forces(v)
    # the top branch by the numbers of stalk8.lsys's comment at 10 m/s
    assert forces[-1] == pytest.approx(0.0015 * 100 * 2 * math.pi * 0.02 + 0.7 * 0.01 * 10)
    for i, force in enumerate(forces):
        assert angles[2 * i] == pytest.approx(dt * STALK["k_fa"] * force, rel=CSV_REL)
        assert angles[2 * i + 1] == 0.0


def test_golden_stalk8_csv_first_rows_by_hand():
    """Rows t = 0.1, 0.2 of the pinned CSV against the scheme's linear recurrence.

    While the angles are small the stalk stays vertical to first order: every
    force keeps its value at rest, so each branch follows the linear recurrence
        v_k = v_(k-1) + k_FA F_i - theta_(k-1) k_bs / 1000,  theta_k = theta_(k-1) + v_k dt.
    The forces' true values differ from those at rest by cosines of the tilts,
    a relative change below (total tilt)^2 / 2, the total tilt being the sum of
    the 8 angles: that bounds the tolerance (about 2e-6 at t = 0.1, 1.3e-5 at 0.2).
    """
    header, rows = _read_csv(_pinned("simulate_stalk8.csv"))
    assert header == ["t"] + [f"{kind}:0.{j >> 2 & 1}.{j >> 1 & 1}.{j & 1}"
                              for j in range(8) for kind in ("b", "r")]
    assert len(rows) == 300 // 10 + 1
    assert [r[0] for r in rows] == pytest.approx([k * 0.1 for k in range(31)], rel=1e-12)
    dt, forces = 0.01, _stalk_forces(10.0)
    theta, vel = [0.0] * 8, [0.0] * 8
    for step in range(1, 21):
        for i, force in enumerate(forces):
            vel[i] += STALK["k_fa"] * force - theta[i] * STALK["k_bs"] / 1000.0
            theta[i] += vel[i] * dt
        if step % 10 == 0:
            row = rows[step // 10]
            tolerance = sum(theta) ** 2 / 2 + CSV_REL
            assert tolerance < 2e-5
            assert row[1::2] == pytest.approx(theta, rel=tolerance)
            assert row[2::2] == [0.0] * 8


def test_golden_stalk8_csv_against_reference_model():
    """Every pinned row against the slow literal model (tests/reference_model.py)."""
    from reference_model import reference_simulate

    from plantlod.formats.treefile import read_tree

    tree = read_tree(io.StringIO(_pinned("derive_stalk8.jsonl")), "derive_stalk8.jsonl")
    bend, rot = reference_simulate(tree, 0.01, 300, lambda t: [10.0, 0.0, 0.0])
    _header, rows = _read_csv(_pinned("simulate_stalk8.csv"))
    for row, k in zip(rows, range(0, 301, 10)):
        expected = [x for pair in zip(bend[k], rot[k]) for x in pair]
        assert row[1:] == pytest.approx(expected, rel=CSV_REL, abs=1e-300)


def _rewrite(axiom: str, successor: str, steps: int) -> str:
    """Non-parametric rewriting of F by hand: every F replaced at once, others copied."""
    text = axiom
    for _ in range(steps):
        text = "".join(successor if ch == "F" else ch for ch in text)
    return text


def test_golden_stalk8_string_by_hand():
    assert _pinned("derive_string_stalk8.txt") == _rewrite("FL", "FF", 3) + "\n"
    assert _rewrite("FL", "FF", 3) == "FFFFFFFFL"


def _num(x: float) -> str:
    """A number as the derived-string notation writes it: shortest text, no '.0'."""
    return str(int(x)) if x == int(x) else repr(x)


def test_golden_abop_2_6_string_by_hand():
    """Two steps of ABOP 2.6a's productions, written out by hand with the file's constants."""
    r1, r2, a0, a2, d, wr = 0.9, 0.6, 45.0, 45.0, 137.5, 0.707
    n = _num

    def p_a(l, w):
        return f"!({n(w)})F({n(l)})[&({n(a0)})B({n(l * r2)},{n(w * wr)})]/({n(d)})A({n(l * r1)},{n(w * wr)})"

    def p_b(l, w):
        return f"!({n(w)})F({n(l)})[-({n(a2)})$C({n(l * r2)},{n(w * wr)})]C({n(l * r1)},{n(w * wr)})"

    l0, w0 = 1 * 0.6, 10 * 0.004          # axiom A(1*len_unit, 10*radius_unit)
    l1, w1 = l0 * r1, w0 * wr              # step 1 makes B(l0 r2, w1) and A(l1, w1)
    step2 = (f"!({n(w0)})F({n(l0)})[&({n(a0)})" + p_b(l0 * r2, w1) + f"]/({n(d)})" + p_a(l1, w1))
    assert _pinned("derive_string_abop_2_6_n2.txt") == step2 + "\n"


def _readme_counts() -> dict[str, tuple[int, int, int]]:
    """(modules, branches, leaves) per example from the table in examples/README.md."""
    counts = {}
    for line in (ROOT / "examples" / "README.md").read_text(encoding="utf-8").splitlines():
        m = re.match(r"\|\s*`(\w+)\.lsys`\s*\|[^|]*\|\s*\d+\s*\|\s*(\d+)\s*\|\s*(\d+)\s*\|\s*(\d+)\s*\|",
                     line)
        if m:
            counts[m.group(1)] = (int(m.group(2)), int(m.group(3)), int(m.group(4)))
    return counts


def test_golden_tree_headers_match_published_counts():
    counts = _readme_counts()
    assert sorted(counts) == EXAMPLES
    for example, (_modules, branches, leaves) in counts.items():
        first = _pinned(f"derive_{example}.jsonl").split("\n", 1)[0]
        header = json.loads(first)
        assert (header["branches"], header["leaves"]) == (branches, leaves), example
        assert header["source"] == f"examples/{example}.lsys"


def test_derive_summary_modules_match_published_counts():
    """The stderr summary's module count is the README's 'modules' (string length after n)."""
    counts = _readme_counts()
    for example in ("stalk8", "abop_1_24a", "abop_2_6"):
        stderr = run_cli("derive", f"examples/{example}.lsys").stderr
        modules = int(re.search(r"([\d,]+) modules", stderr).group(1).replace(",", ""))
        assert modules == counts[example][0]
