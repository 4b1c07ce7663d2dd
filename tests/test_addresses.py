"""Addresses (model.md section 1) and a slow literal reference derivation.

The reference below rewrites plain Python lists of (character, parameters,
address) one module at a time, searching contexts by walking the list as
docs/lsys-format.md describes, evaluating expressions one value at a time and
hashing with hashlib itself. Hypothesis compares it with both engines (the
numpy table lookup and the general vectorised one) on random small systems.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from plantlod.lsys import context
from plantlod.lsys.derive import derive, interpret
from plantlod.lsys.expr import evaluate
from plantlod.lsys.system import LSystem

from test_derive import addresses, make_system, text_of

# --- hand-computed addresses ---------------------------------------------------------


def test_addresses_by_hand():
    system = make_system("AB", ["A -> A[+B]A", "B -> BA"])
    d1 = derive(system, 1)
    assert text_of(d1) == "A[+B]ABA"
    assert addresses(d1) == ["0.0", "0.1", "0.2", "0.3", "0.4", "0.5", "1.0", "1.1"]
    d2 = derive(system, 2)
    assert text_of(d2) == "A[+B]A[+BA]A[+B]ABAA[+B]A"
    assert addresses(d2) == (
        ["0.0.0", "0.0.1", "0.0.2", "0.0.3", "0.0.4", "0.0.5",   # A -> A[+B]A
         "0.1.0", "0.2.0",                                        # [ + copied
         "0.3.0", "0.3.1",                                        # B -> BA
         "0.4.0",                                                 # ] copied
         "0.5.0", "0.5.1", "0.5.2", "0.5.3", "0.5.4", "0.5.5",   # A -> A[+B]A
         "1.0.0", "1.0.1",                                        # B -> BA
         "1.1.0", "1.1.1", "1.1.2", "1.1.3", "1.1.4", "1.1.5"])  # A -> A[+B]A


def test_address_of_axiom_and_array_form():
    d = derive(make_system("F[A]", ["A -> AA"]), 0)
    assert addresses(d) == ["0", "1", "2", "3"]
    d = derive(make_system("F[A]", ["A -> AA"]), 3)
    arr = d.address_array(np.array([4, 0]))
    assert arr.shape == (2, 4) and arr.dtype == np.int64
    assert arr.tolist() == [[2, 0, 1, 0], [0, 0, 0, 0]]


def test_addresses_stable_across_derivation_lengths():
    # every step-5 module descends from the step-3 module whose address is its prefix
    rules = ["A -> (0.5) F[+A][-A]", "A -> (0.5) FA", "F -> (0.3) FF", "F -> (0.7) F"]
    system = make_system("A", rules, seed=9)
    d3, d5 = derive(system, 3), derive(system, 5)
    ancestor = np.arange(len(d5))
    for parent, _local in reversed(d5.history[3:]):
        ancestor = parent[ancestor]
    a3 = d3.address_array(np.arange(len(d3)))
    a5 = d5.address_array(np.arange(len(d5)))
    assert np.array_equal(a5[:, :4], a3[ancestor])
    assert {tuple(r) for r in a5[:, :4].tolist()} <= {tuple(r) for r in a3.tolist()}
    for (p3, l3), (p5, l5) in zip(d3.history, d5.history[:3]):
        assert np.array_equal(p3, p5) and np.array_equal(l3, l5)


# --- the literal reference ----------------------------------------------------------

def ref_left(s, i, ignore):
    """Index of the left context module of s[i], or None (docs/lsys-format.md)."""
    j = i - 1
    while j >= 0:
        ch = s[j][0]
        if ch == "]":
            depth = 1
            while depth:
                j -= 1
                depth += {"]": 1, "[": -1}.get(s[j][0], 0)
            j -= 1                 # continue before the matching '['
        elif ch == "[" or ch in ignore:
            j -= 1
        else:
            return j
    return None


def ref_right(s, i, ignore):
    """Index of the right context module of s[i], or None."""
    j = i + 1
    while j < len(s):
        ch = s[j][0]
        if ch == "[":
            depth = 1
            while depth:
                j += 1
                depth += {"[": 1, "]": -1}.get(s[j][0], 0)
            j += 1                 # continue after the matching ']'
        elif ch == "]":
            return None
        elif ch in ignore:
            j += 1
        else:
            return j
    return None


def ref_groups(productions):
    """Rule groups in file order: stochastic alternatives join the first of their kind."""
    groups, where = [], {}
    for p in productions:
        key = (p.pred, p.left, p.right, p.condition)
        if p.probability is not None and key in where:
            groups[where[key]].append(p)
        else:
            if p.probability is not None:
                where[key] = len(groups)
            groups.append([p])
    return groups


def ref_match(s, i, group, system):
    """The environment if the group's predecessor, contexts and condition match s[i]."""
    first = group[0]
    ch, params, _addr = s[i]
    if ch != first.pred.name or len(params) != len(first.pred.params):
        return None
    env = system.constants()
    bindings = [(first.pred.params, params)]
    for pats, step in ((first.left[::-1], ref_left), (first.right, ref_right)):
        j = i
        for pat in pats:
            j = step(s, j, system.ignore)
            if j is None or s[j][0] != pat.name or len(s[j][1]) != len(pat.params):
                return None
            bindings.append((pat.params, s[j][1]))
    for names, values in bindings:
        env.update(zip(names, values))
    if first.condition is not None and evaluate(first.condition, env) == 0:
        return None
    return env


def ref_pick(group, env, seed, address):
    if group[0].probability is None:
        return group[0]
    text = f"{seed}:{'.'.join(map(str, address))}"
    u = int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "big") / 2 ** 64
    probs = [evaluate(p.probability, env) for p in group]
    total = sum(probs)
    acc = 0.0
    for p, prob in zip(group, probs):
        acc += prob
        if acc > u * total:
            return p
    return group[-1]


def ref_step(s, productions, system, new_level: bool):
    """One parallel rewriting step. new_level: addresses grow by the local index."""
    groups = ref_groups(productions)
    out = []
    for i, (ch, params, addr) in enumerate(s):
        for group in groups:
            env = ref_match(s, i, group, system)
            if env is not None:
                prod = ref_pick(group, env, system.seed, addr)
                for j, m in enumerate(prod.successor):
                    vals = tuple(float(evaluate(a, env)) for a in m.args)
                    out.append((m.name, vals, addr + (j,) if new_level else addr))
                break
        else:
            out.append((ch, params, addr + (0,) if new_level else addr))
    return out


def ref_derive(system: LSystem, steps: int, limit: int = 3000):
    env = system.constants()
    s = [(m.name, tuple(float(evaluate(a, env)) for a in m.args), (i,))
         for i, m in enumerate(system.axiom)]
    for _ in range(steps):
        s = ref_step(s, system.productions, system, True)
        if len(s) > limit:
            return None
    return s


def as_triples(d):
    addr = d.address_array(np.arange(len(d))).tolist()
    return [(d.alphabet[d.codes[i]], tuple(d.module_params(i).tolist()), tuple(addr[i]))
            for i in range(len(d))]


# --- random small systems ------------------------------------------------------------

# parametric characters and their parameter names; F, +, - and brackets carry none
PARAMS = {"A": ("x",), "B": ("x", "y")}
ARG_EXPRS = ["x", "x+1", "x*0.5", "2", "x-k", "y*2", "x+y", "u", "v+1"]
CONDITIONS = [None, "x < 2", "x >= 1", "x + y > 3", "k > 2", "u < x", "0"]


def _usable(text, names):
    return all(name in names for name in ("x", "y", "u", "v") if name in text)


@st.composite
def successors(draw, names, parametric):
    out = []
    for _ in range(draw(st.integers(0, 5))):
        kind = draw(st.sampled_from("ABF+-[" if parametric else "ABCF+-["))
        if kind == "[":
            inner = draw(successors(names, parametric))
            out.append("[" + inner + "]")
        elif parametric and kind in PARAMS:
            args = [draw(st.sampled_from([e for e in ARG_EXPRS if _usable(e, names)] or ["2"]))
                    for _ in PARAMS[kind]]
            out.append(f"{kind}({','.join(args)})")
        else:
            out.append(kind)
    return "".join(out)


@st.composite
def context_pattern(draw, parametric, name_index):
    ch = draw(st.sampled_from("ABF+" if parametric else "ABCF+"))
    if parametric and ch in PARAMS:
        names = ("u", "v")[:len(PARAMS[ch])] if name_index == 0 else ("w", "z")[:len(PARAMS[ch])]
        return f"{ch}({','.join(names)})", set(names)
    return ch, set()


@st.composite
def lsystems(draw, parametric=False, contexts=False, stochastic=False, conditions=False):
    preds = "ABF" if parametric else "ABCF"
    rules = []
    for _ in range(draw(st.integers(1, 4))):
        ch = draw(st.sampled_from(preds))
        names = {"k"} | (set(PARAMS[ch]) if parametric and ch in PARAMS else set())
        pred = f"{ch}({','.join(PARAMS[ch])})" if parametric and ch in PARAMS else ch
        left = right = ""
        if contexts and draw(st.booleans()):
            text, bound = draw(context_pattern(parametric, 0))
            names |= bound
            left = text + " < "
        if contexts and draw(st.booleans()):
            text, bound = draw(context_pattern(parametric, 1))
            names |= bound
            right = " > " + text
        cond = ""
        if conditions:
            c = draw(st.sampled_from([c for c in CONDITIONS if c is None or _usable(c, names)]))
            cond = "" if c is None else f" : {c}"
        head = f"{left}{pred}{right}{cond} -> "
        if stochastic and draw(st.booleans()):
            probs = draw(st.sampled_from([(0.5, 0.5), (0.25, 0.75), (0.5, 0.3, 0.2), (0.1, 0.9)]))
            for p in probs:
                rules.append(head + f"({p}) " + draw(successors(names, parametric)))
        else:
            rules.append(head + draw(successors(names, parametric)))
    axiom = draw(st.sampled_from(["A(1)B(0,2)", "B(3,1)[A(0)]FA(2)", "A(0.5)"] if parametric
                                 else ["A", "AB", "B[A]CF", "F+A-B"]))
    ignore = draw(st.sampled_from(["", "+-", "F+-"])) if contexts else ""
    return make_system(axiom, rules, defines=[("k", 3.0)], ignore=ignore,
                       seed=draw(st.integers(0, 5)))


def check_against_reference(system, steps):
    expected = ref_derive(system, steps)
    assume(expected is not None)
    assert as_triples(derive(system, steps)) == expected
    assert as_triples(derive(system, steps, fast=False)) == expected


SETTINGS = settings(max_examples=120, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])


@SETTINGS
@given(lsystems(), st.integers(0, 4))
def test_ol_systems_match_reference(system, steps):
    check_against_reference(system, steps)


@SETTINGS
@given(lsystems(parametric=True, conditions=True), st.integers(0, 4))
def test_parametric_systems_match_reference(system, steps):
    check_against_reference(system, steps)


@SETTINGS
@given(lsystems(contexts=True, stochastic=True), st.integers(0, 4))
def test_context_and_stochastic_systems_match_reference(system, steps):
    check_against_reference(system, steps)


@SETTINGS
@given(lsystems(parametric=True, contexts=True, stochastic=True, conditions=True),
       st.integers(0, 4))
def test_everything_together_matches_reference(system, steps):
    check_against_reference(system, steps)


@SETTINGS
@given(lsystems(parametric=True, contexts=True, stochastic=True, conditions=True),
       lsystems(parametric=True, contexts=True, stochastic=True, conditions=True),
       st.integers(0, 3))
def test_interpretation_matches_reference(system, interpreter, steps):
    system = dataclasses.replace(system, interpretation=interpreter.productions)
    expected = ref_derive(system, steps)
    assume(expected is not None)
    expected = ref_step(expected, system.interpretation, system, False)
    for fast in (True, False):
        out = interpret(system, derive(system, steps, fast=fast), fast=fast)
        assert as_triples(out) == expected


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from("ab+[]"), max_size=30), st.sampled_from(["", "+", "+b"]))
def test_context_neighbours_match_literal_search(chars, ignore):
    # make the brackets balance: drop unmatched ']' and close open '['
    s, depth = [], 0
    for ch in chars:
        if ch == "]" and depth == 0:
            continue
        depth += {"[": 1, "]": -1}.get(ch, 0)
        s.append(ch)
    s += ["]"] * depth
    alphabet = ["a", "b", "+", "[", "]"]
    codes = np.array([alphabet.index(c) for c in s], dtype=np.int32)
    ignored = np.array([c in ignore for c in alphabet])
    left, right = context.neighbours(codes, 3, 4, ignored)
    triples = [(c, (), ()) for c in s]
    for i in range(len(s)):
        exp_left, exp_right = ref_left(triples, i, ignore), ref_right(triples, i, ignore)
        assert left[i] == (-1 if exp_left is None else exp_left)
        assert right[i] == (-1 if exp_right is None else exp_right)
