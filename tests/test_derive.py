"""The derivation engine (model.md section 1): counts, hand-derived strings, errors, text.

Systems are written in a compact text form and built with `make_system`, a
small helper independent of `lsys/parse.py` (expressions in Python syntax via
`ast`), so these tests check the engine alone. Expected values come from
production-matrix powers, hand derivations, ABOP and L-Py, and SHA-256 digests
computed with the `sha256sum` command.
"""

from __future__ import annotations

import ast

import numpy as np
import pytest

from plantlod.formats import derived_string
from plantlod.formats.derived_string import format_derived
from plantlod.lsys.derive import derive, interpret
from plantlod.lsys.errors import InputError
from plantlod.lsys.expr import Binary, Call, Name, Num, Pos, Unary, format_number
from plantlod.lsys.stochastic import address_fraction
from plantlod.lsys.system import LSystem, Module, Pattern, Production

# --- a small builder for test systems ------------------------------------------------

_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Mod: "%", ast.Pow: "^"}
_CMPOPS = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}


def expr(text: str):
    """An expression tree from Python syntax: ``x*2``, ``y <= 3``, ``x > 1 and y < 2``."""

    def conv(node):
        if isinstance(node, ast.Constant):
            return Num(float(node.value))
        if isinstance(node, ast.Name):
            return Name(node.id)
        if isinstance(node, ast.BinOp):
            return Binary(_BINOPS[type(node.op)], conv(node.left), conv(node.right))
        if isinstance(node, ast.UnaryOp):
            op = {ast.USub: "-", ast.UAdd: "+", ast.Not: "!"}[type(node.op)]
            return Unary(op, conv(node.operand))
        if isinstance(node, ast.Compare):
            assert len(node.ops) == 1
            return Binary(_CMPOPS[type(node.ops[0])], conv(node.left), conv(node.comparators[0]))
        if isinstance(node, ast.BoolOp):
            op = "&&" if isinstance(node.op, ast.And) else "||"
            out = conv(node.values[0])
            for v in node.values[1:]:
                out = Binary(op, out, conv(v))
            return out
        if isinstance(node, ast.Call):
            return Call(node.func.id, tuple(conv(a) for a in node.args))
        raise ValueError(f"unsupported expression {ast.dump(node)}")

    return conv(ast.parse(text.strip(), mode="eval").body)


def _split_modules(text: str) -> list[tuple[str, list[str]]]:
    """``"A(x,y*2)[+F]"`` -> [("A", ["x", "y*2"]), ("[", []), ...]; spaces ignored."""
    out, i = [], 0
    while i < len(text):
        ch = text[i]
        i += 1
        if ch.isspace():
            continue
        args: list[str] = []
        if i < len(text) and text[i] == "(":
            depth, j, start = 0, i, i + 1
            while True:
                if text[j] == "(":
                    depth += 1
                elif text[j] == ")":
                    depth -= 1
                    if depth == 0:
                        break
                elif text[j] == "," and depth == 1:
                    args.append(text[start:j])
                    start = j + 1
                j += 1
            args.append(text[start:j])
            i = j + 1
        out.append((ch, args))
    return out


def modules(text: str) -> tuple[Module, ...]:
    return tuple(Module(ch, tuple(expr(a) for a in args)) for ch, args in _split_modules(text))


def patterns(text: str) -> tuple[Pattern, ...]:
    return tuple(Pattern(ch, tuple(a.strip() for a in args)) for ch, args in _split_modules(text))


def production(text: str) -> Production:
    """``"[L <] P [> R] [: cond] -> [(prob)] successor"``; conditions in Python syntax."""
    head, succ = text.split("->", 1)
    condition = None
    if ":" in head:
        head, cond = head.split(":", 1)
        condition = None if cond.strip() == "*" else expr(cond)
    left = right = ""
    if "<" in head:
        left, head = head.split("<", 1)
    if ">" in head:
        head, right = head.split(">", 1)
    succ = succ.strip()
    probability = None
    if succ.startswith("("):
        close = succ.index(")")
        probability, succ = expr(succ[1:close]), succ[close + 1:]
    (pred,) = patterns(head)
    return Production(pred, modules(succ), patterns(left), patterns(right), condition, probability)


def make_system(axiom: str, productions=(), interpretation=(), n: int = 1,
                defines=(), ignore: str = "", seed: int = 0) -> LSystem:
    return LSystem(
        derivation_length=n, branching_angle=25.0, rotation_angle=25.0,
        force_absorbed=0.01, force_propagated=0.5, axiom=modules(axiom),
        productions=tuple(production(p) for p in productions),
        interpretation=tuple(production(p) for p in interpretation),
        defines=tuple(defines), ignore=tuple(ignore), seed=seed)


def text_of(d) -> str:
    """The derived string by a slow literal formatting, independent of format_derived."""
    out = []
    for i in range(len(d)):
        ch = d.alphabet[d.codes[i]]
        p = d.params[d.param_start[i]:d.param_start[i + 1]]
        out.append(ch + (f"({','.join(format_number(v) for v in p)})" if len(p) else ""))
    return "".join(out)


def addresses(d) -> list[str]:
    return d.address_strings(np.arange(len(d)))


# --- OL-systems: counts from the production matrix -----------------------------------

ABOP_1_24 = {
    "a": ("F", {"F": "F[+F]F[-F]F"}),
    "b": ("F", {"F": "F[+F]F[-F][F]"}),
    "c": ("F", {"F": "FF-[-F+F+F]+[+F-F-F]"}),
    "d": ("X", {"X": "F[+X]F[-X]+X", "F": "FF"}),
    "e": ("X", {"X": "F[+X][-X]FX", "F": "FF"}),
    "f": ("X", {"X": "F-[[X]+X]+F[+FX]-X", "F": "FF"}),
}


def matrix_counts(axiom: str, rules: dict[str, str], n: int) -> dict[str, int]:
    """Symbol counts after n steps: count vector times the n-th power of the production matrix."""
    symbols = sorted(set(axiom) | set("".join(rules.values())) | set(rules))
    index = {s: i for i, s in enumerate(symbols)}
    m = np.zeros((len(symbols), len(symbols)), dtype=object)      # Python ints: no overflow
    for s in symbols:
        for t in rules.get(s, s):
            m[index[s], index[t]] += 1
    v = np.zeros(len(symbols), dtype=object)
    for s in axiom:
        v[index[s]] += 1
    for _ in range(n):
        v = v.dot(m)
    return {s: int(v[index[s]]) for s in symbols}


def derived_counts(d) -> dict[str, int]:
    counts = np.bincount(d.codes, minlength=len(d.alphabet))
    return {ch: int(c) for ch, c in zip(d.alphabet, counts) if c}


@pytest.mark.parametrize("fig", sorted(ABOP_1_24))
@pytest.mark.parametrize("fast", [True, False])
def test_abop_1_24_symbol_counts_match_matrix_powers(fig, fast):
    axiom, rules = ABOP_1_24[fig]
    system = make_system(axiom, [f"{k} -> {v}" for k, v in rules.items()])
    for n in (0, 1, 2, 4):
        d = derive(system, n, fast=fast)
        expected = {s: c for s, c in matrix_counts(axiom, rules, n).items() if c}
        assert derived_counts(d) == expected, (fig, n)
        assert d.steps() == n and len(d.history) == n


def test_abop_1_24a_size_at_n5_fast_path():
    axiom, rules = ABOP_1_24["a"]
    d = derive(make_system(axiom, [f"F -> {rules['F']}"]), 5)
    assert len(d) == sum(matrix_counts(axiom, rules, 5).values())


def test_lpy_published_count_311_modules_after_3_steps():
    d = derive(make_system("F", ["F -> F[+F]F[-F]F"], n=3))
    assert len(d) == 311


def test_first_production_wins_and_unmatched_are_copied():
    d = derive(make_system("ABC", ["A -> X", "A -> Y", "B -> "]), 1)
    assert text_of(d) == "XC"
    parent, local = d.history[0]
    assert parent.tolist() == [0, 2] and local.tolist() == [0, 0]


def test_fast_and_general_engines_agree_on_history():
    system = make_system("X", ["X -> F-[[X]+X]+F[+FX]-X", "F -> FF"])
    a, b = derive(system, 4), derive(system, 4, fast=False)
    assert text_of(a) == text_of(b)
    for (pa, la), (pb, lb) in zip(a.history, b.history):
        assert np.array_equal(pa, pb) and np.array_equal(la, lb)


def test_array_shapes_and_dtypes():
    d = derive(make_system("A(1)B", ["A(x) -> A(x+1)[F]"]), 2)
    n = len(d)
    assert d.codes.dtype == np.int32 and d.codes.shape == (n,)
    assert d.param_start.dtype == np.int64 and d.param_start.shape == (n + 1,)
    assert d.params.dtype == np.float64 and d.params.shape == (d.param_start[-1],)
    assert all(p.dtype == np.int64 and l.dtype == np.int64 for p, l in d.history)
    assert d.module_params(0).tolist() == [3.0]
    assert d.code_of("A") is not None and d.code_of("Q") is None
    assert d.origin is None


# --- parametric productions with conditions ------------------------------------------

ABOP_1_7 = [
    "A(x,y) : y <= 3 -> A(x*2, x+y)",
    "A(x,y) : y > 3 -> B(x)A(x/y, 0)",
    "B(x) : x < 1 -> C",
    "B(x) : x >= 1 -> B(x-1)",
]


@pytest.mark.parametrize("fast", [True, False])
def test_abop_fig_1_7_parametric_derivation_by_hand(fast):
    # ABOP p. 43, Figure 1.7: the strings of the first derivation steps.
    expected = [
        "B(2)A(4,4)",
        "B(1)B(4)A(1,0)",
        "B(0)B(3)A(2,1)",
        "CB(2)A(4,3)",
        "CB(1)A(8,7)",
        f"CB(0)B(8)A({format_number(8 / 7)},0)",
    ]
    system = make_system("B(2)A(4,4)", ABOP_1_7)
    for n, text in enumerate(expected):
        assert text_of(derive(system, n, fast=fast)) == text


def test_defines_and_successor_arguments_use_predecessor_parameters():
    system = make_system("A(1,10)", ["A(l,w) -> F(l)[+(a)A(l*r,w-1)]A(l*r*r,w-2)"],
                         defines=[("r", 0.5), ("a", 30.0)])
    assert text_of(derive(system, 1)) == "F(1)[+(30)A(0.5,9)]A(0.25,8)"


def test_parameter_count_must_match_the_predecessor():
    system = make_system("A(1)A(1,2)A", ["A(x) -> X", "A -> Y"])
    assert text_of(derive(system, 1)) == "XA(1,2)Y"


def test_condition_nonzero_is_true():
    system = make_system("A(0)A(2)A(-1)", ["A(x) : x -> B"])
    assert text_of(derive(system, 1)) == "A(0)BB"


def test_division_by_zero_is_an_input_error_at_the_operator():
    pos = Pos("t.lsys", 3, 12)
    succ = (Module("A", (Binary("/", Num(1.0), Name("x"), pos=pos),)),)
    system = LSystem(1, 25.0, 25.0, 0.1, 0.5, axiom=modules("A(2)A(0)"),
                     productions=(Production(Pattern("A", ("x",)), succ),))
    with pytest.raises(InputError) as err:
        derive(system)
    assert (err.value.file, err.value.line, err.value.col) == ("t.lsys", 3, 12)
    assert "division by zero" in err.value.message


def test_conditions_are_not_evaluated_for_modules_an_earlier_rule_took():
    # 1/x would divide by zero for A(0), but the first production takes A(0).
    system = make_system("A(0)A(4)", ["A(x) : x == 0 -> Z", "A(x) : 1/x > 0.2 -> B(1/x)"])
    assert text_of(derive(system, 1)) == "ZB(0.25)"


# --- context-sensitive productions ---------------------------------------------------

def test_acropetal_signal_with_brackets_by_hand():
    # left context: a ']' skips back over its branch, a '[' is passed over.
    system = make_system("b[a]a[a]a", ["b < a -> b", "b -> a"])
    assert [text_of(derive(system, n)) for n in (1, 2, 3)] == \
        ["a[b]b[a]a", "a[a]a[b]b", "a[a]a[a]a"]


def test_basipetal_signal_with_brackets_by_hand():
    # right context: a '[' skips over its whole branch, a ']' ends the search.
    system = make_system("a[a]a[a]b", ["a > b -> b", "b -> a"])
    assert [text_of(derive(system, n)) for n in (1, 2)] == ["a[a]b[a]a", "b[a]a[a]a"]


def test_ignore_list_skips_symbols_in_context():
    rules = ["b < a -> b", "b -> a"]
    with_ignore = make_system("b+a-a", rules, ignore="+-")
    assert [text_of(derive(with_ignore, n)) for n in (1, 2)] == ["a+b-a", "a+a-b"]
    without = make_system("b+a-a", rules)
    assert text_of(derive(without, 1)) == "a+a-a"


def test_abop_fig_1_31_style_two_sided_context_with_ignore():
    # ABOP Figure 1.31's pattern "0 < 0 > 1 -> 1[+F1F1]" with "#ignore: +-F":
    # F and the turns between the digits do not break the context.
    system = make_system("F1F0F0F1", ["0 < 0 > 1 -> 1[+F1F1]", "1 < 0 > 0 -> X"], ignore="+-F")
    # module 0@3 has left 1, right 0 -> X; module 0@5 has left 0, right 1 -> branch.
    assert text_of(derive(system, 1)) == "F1FXF1[+F1F1]F1"


def test_multi_module_and_parametric_contexts_by_hand():
    system = make_system(
        "A(1)B(2)[F]C(5)A(4)B(2)C(3)",
        ["A(x) B(y) < C(z) : x + y < z -> C(x+y+z)", "B(y) > C(z) -> B(y*z)"])
    assert text_of(derive(system, 1)) == "A(1)B(10)[F]C(8)A(4)B(6)C(3)"


def test_context_of_first_module_in_a_branch_is_before_the_branch():
    system = make_system("A[B]C[[D]E]", ["A < B -> X", "A < C -> Y", "C < E -> Z",
                                         "C < D -> W", "B > C -> V"])
    # B's right neighbour is ']' (end of search): no V.
    assert text_of(derive(system, 1)) == "A[X]Y[[W]Z]"


def test_context_pattern_may_not_be_a_bracket():
    system = LSystem(1, 25.0, 25.0, 0.1, 0.5, axiom=modules("A[B]"),
                     productions=(Production(Pattern("A"), modules("B"), right=(Pattern("["),)),))
    with pytest.raises(InputError, match="context pattern"):
        derive(system)


# --- stochastic productions ----------------------------------------------------------

# First 16 hex digits of SHA-256, from:  printf '%s' "7:0" | sha256sum
SHA256_PREFIX = {
    "7:0": "f5ff61d7b533cd73",     # u = 0.961
    "7:1": "d7a0cee7b61eb0e3",     # u = 0.842
    "7:2": "8d8ea3758174b90c",     # u = 0.553
    "7:0.0": "06789eb1955c7feb",   # u = 0.025
    "7:0.1": "b11d402d6b5d98fb",   # u = 0.692
}


def test_address_fraction_matches_sha256sum():
    for key, hexdigits in SHA256_PREFIX.items():
        seed, address = key.split(":")
        assert address_fraction(int(seed), address) == int(hexdigits, 16) / 2 ** 64


def test_stochastic_choice_by_hand():
    # cumulative 0.6, 0.85, 1.0: u 0.961 -> D, 0.842 -> C, 0.553 -> B.
    system = make_system("AAA", ["A -> (0.6) B", "A -> (0.25) C", "A -> (0.15) D"], seed=7)
    assert text_of(derive(system, 1)) == "DCB"
    # the address at step 2 is the module's address in step 1's string
    system = make_system("X", ["X -> AA", "A -> (0.5) B", "A -> (0.5) C"], seed=7)
    assert text_of(derive(system, 2)) == "BC"


def test_stochastic_choice_is_repeatable_and_depends_on_the_seed():
    rules = ["A -> (0.5) A[+A]", "A -> (0.5) AA"]
    a = [text_of(derive(make_system("A", rules, seed=3), 5)) for _ in range(2)]
    assert a[0] == a[1]
    others = {text_of(derive(make_system("A", rules, seed=s), 5)) for s in range(4, 10)}
    assert len(others - {a[0]}) >= 1


def test_stochastic_frequencies_follow_probabilities():
    m = 20000
    system = make_system("A" * m, ["A -> (0.2) B", "A -> (0.3) C", "A -> (0.5) D"], seed=11)
    counts = derived_counts(derive(system, 1))
    for ch, p in (("B", 0.2), ("C", 0.3), ("D", 0.5)):
        sigma = (p * (1 - p) / m) ** 0.5
        assert abs(counts[ch] / m - p) < 5 * sigma


def test_stochastic_group_shares_condition_and_position_in_file_order():
    system = make_system("A(1)A(5)", ["A(x) : x > 2 -> (0.5) B", "A(x) : x > 2 -> (0.5) B",
                                      "A(x) -> C"], seed=0)
    assert text_of(derive(system, 1)) == "CB"


def test_first_k_steps_identical_for_every_derivation_length():
    rules = ["A -> (0.3) F[+A]A", "A -> (0.3) F[-A]", "A -> (0.4) FA", "F -> (0.5) FF", "F -> (0.5) F"]
    system = make_system("A", rules, seed=5)
    longest = derive(system, 6)
    for k in range(7):
        d = derive(system, k)
        for (p1, l1), (p2, l2) in zip(d.history, longest.history[:k]):
            assert np.array_equal(p1, p2) and np.array_equal(l1, l2)


def _slow_stochastic_derive(system, k, monkeypatch):
    """`derive` with every stochastic step's addresses read from the whole history (no
    addresses carried from the step before: the literal definition)."""
    from plantlod.lsys import rewrite_param

    with monkeypatch.context() as m:
        m.setattr(rewrite_param.GeneralRewriter, "_addresses",
                  lambda self, ds, cand, chosen: ds.address_strings(cand))
        return derive(system, k)


@pytest.mark.parametrize("axiom, rules, k", [
    ("A", ["A -> (0.5) FA", "A -> (0.5) A"], 120),                 # a chain
    ("A", ["A -> (0.3) F[+A]A", "A -> (0.3) F[-A]", "A -> (0.4) FA",
           "F -> (0.5) FF", "F -> (0.5) F"], 7),                    # branching, F stochastic too
    ("X", ["X -> AXA", "A -> (0.5) B", "A -> (0.5) AC", "C -> (0.5) A", "C -> (0.5) X"], 9),
])
def test_stochastic_steps_carrying_addresses_choose_as_the_history_says(axiom, rules, k, monkeypatch):
    """A stochastic module's address is carried from its parent's of the step before where
    the parent was chosen for too (`GeneralRewriter._addresses`); the choices are those of
    addresses read from the whole history, step by step."""
    system = make_system(axiom, rules, seed=13)
    fast, slow = derive(system, k), _slow_stochastic_derive(system, k, monkeypatch)
    assert text_of(fast) == text_of(slow) and len(fast) > 20
    for (p1, l1), (p2, l2) in zip(fast.history, slow.history):
        assert np.array_equal(p1, p2) and np.array_equal(l1, l2)


def test_a_deep_chain_has_its_addresses_in_closed_form():
    """A -> FA for k steps: the F made at step i + 1 has the address 0 .1 (i times) .0, then
    .0 for each of the k - i - 1 steps it is copied. At k = 300 the addresses are joined from
    their numbers (building them prefix by prefix would write about k/3 times as much)."""
    k = 300
    d = derive(make_system("A", ["A -> FA"]), k)
    want = ["0" + ".1" * i + ".0" + ".0" * (k - i - 1) for i in range(k)] + ["0" + ".1" * k]
    assert addresses(d) == want
    bushy = derive(make_system("F", ["F -> F[+F]F[-F]F"]), 4)       # prefixes shared: built
    idx = np.arange(len(bushy))
    assert bushy.address_strings(idx) == bushy._joined_addresses(idx)


# --- the max_modules guard -----------------------------------------------------------

def test_max_modules_guard_message():
    system = make_system("F", ["F -> FFFFF"])
    with pytest.raises(InputError) as err:
        derive(system, 5, max_modules=100)
    assert err.value.message == ("step 3 would produce 125 modules, more than the 100 modules "
                                 "allowed; expected a smaller derivation length (the file's "
                                 "derivation_length, or -n / --steps where given; or derive "
                                 "--max-modules, the API's max_modules)")
    assert len(derive(system, 2, max_modules=25)) == 25


@pytest.mark.parametrize("fast", [True, False])
def test_max_modules_guard_checks_before_building(fast):
    system = make_system("F", ["F -> " + "F" * 125])
    with pytest.raises(InputError, match=r"^step 4 would produce 244,140,625 modules, "
                                         r"more than the 5,000,000 modules allowed; expected a smaller "
                                         r"derivation length \("):
        derive(system, 6, fast=fast)


def test_negative_steps_rejected():
    with pytest.raises(InputError, match="steps"):
        derive(make_system("F"), -1)


def test_unbalanced_successor_rejected():
    with pytest.raises(InputError, match="'\\['"):
        derive(make_system("F", ["F -> F[+F"]))


# --- interpretation -----------------------------------------------------------------

def test_interpretation_keeps_addresses_and_is_not_reapplied():
    system = make_system("AB", ["A -> AF"], interpretation=["A -> F[+L]F", "F -> A"])
    d = derive(system, 2)
    assert text_of(d) == "AFFB" and addresses(d) == ["0.0.0", "0.0.1", "0.1.0", "1.0.0"]
    out = interpret(system, d)
    # F -> A and A -> F[+L]F apply once each, never to their own output
    assert text_of(out) == "F[+L]FAAB"
    assert out.origin.tolist() == [0, 0, 0, 0, 0, 0, 1, 2, 3]
    assert addresses(out) == ["0.0.0"] * 6 + ["0.0.1", "0.1.0", "1.0.0"]
    assert out.steps() == 2


def test_interpretation_with_parameters():
    system = make_system("A(2,3)", ["A(l,w) -> F(l)A(l/2,w)"],
                         interpretation=["A(l,w) -> L(w*l)"])
    out = interpret(system, derive(system, 2))
    assert text_of(out) == "F(2)F(1)L(1.5)"
    assert addresses(out) == ["0.0.0", "0.1.0", "0.1.1"]


def test_no_interpretation_rules_gives_identity_origin():
    system = make_system("FA", ["A -> F[A]"])
    d = derive(system, 2)
    out = interpret(system, d)
    assert text_of(out) == text_of(d)
    assert out.origin.tolist() == list(range(len(d)))
    assert addresses(out) == addresses(d)


# --- the derived string as text ------------------------------------------------------

def test_format_derived_by_hand():
    system = make_system("A(1,0.5)[+(25)F(-2)]B", ["B -> B(0.1)"])
    d = derive(system, 1)
    assert "".join(format_derived(d)) == "A(1,0.5)[+(25)F(-2)]B(0.1)\n"
    d = derive(make_system("F", ["F -> F[+F]F"]), 1)
    assert "".join(format_derived(d)) == "F[+F]F\n"
    assert "".join(format_derived(derive(make_system("F", ["F -> "]), 1))) == "\n"


def test_format_derived_across_chunks_matches_literal_formatting(monkeypatch):
    monkeypatch.setattr(derived_string, "DERIVED_TEXT_CHUNK_MODULES", 7)
    system = make_system("A(1)", ["A(x) -> F(x)[+(x*3)A(x/3)][B]A(x+1)", "B -> éF"])
    d = derive(system, 4)
    assert "".join(format_derived(d)) == text_of(d) + "\n"
