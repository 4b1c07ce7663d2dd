"""plantlod/blas_kernels.py: OpenBLAS's kernels pinned before numpy loads, where the CPU runs them."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from plantlod.blas_kernels import CORE_TYPE, cpu_flags, pin_openblas_kernels, runs_core_type

AVX2 = {"sse2", "avx", "avx2", "fma"}


def test_pins_on_an_avx2_x86_machine_before_numpy():
    env = {}
    assert pin_openblas_kernels(env, "x86_64", AVX2, numpy_loaded=False) == CORE_TYPE
    assert env == {"OPENBLAS_CORETYPE": CORE_TYPE}


@pytest.mark.parametrize("machine, flags, loaded", [
    ("x86_64", AVX2, True),                   # numpy loaded: too late, leave it
    ("aarch64", AVX2, False),                 # not x86: those kernels do not exist
    ("x86_64", {"sse2", "avx"}, False),       # no AVX2 / FMA: they would not run
    ("x86_64", {"avx2"}, False),
])
def test_leaves_it_where_it_cannot_apply(machine, flags, loaded):
    env = {}
    assert pin_openblas_kernels(env, machine, flags, numpy_loaded=loaded) is None
    assert env == {}


def test_the_users_choice_wins():
    env = {"OPENBLAS_CORETYPE": "SkylakeX"}
    assert pin_openblas_kernels(env, "x86_64", AVX2, numpy_loaded=False) == "SkylakeX"
    assert env == {"OPENBLAS_CORETYPE": "SkylakeX"}


def test_cpu_flags_reads_the_first_flags_line(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nflags\t\t: fpu avx2 fma\n\nprocessor\t: 1\nflags\t: fpu\n")
    assert cpu_flags(str(info)) == {"fpu", "avx2", "fma"}
    assert cpu_flags(str(tmp_path / "missing")) == set()


@pytest.mark.skipif(not runs_core_type(), reason="not an x86-64 CPU with AVX2 and FMA")
def test_this_test_process_and_a_fresh_one_are_pinned():
    # the test session itself (conftest imports plantlod before numpy; zarr's pytest plugin,
    # which would load numpy first, is switched off in pyproject.toml) ...
    assert os.environ.get("OPENBLAS_CORETYPE") == CORE_TYPE
    # ... and a program that imports plantlod, then numpy
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    code = ("import plantlod, numpy, os; from threadpoolctl import threadpool_info; "
            "print(os.environ['OPENBLAS_CORETYPE'], "
            "sorted({i.get('architecture') for i in threadpool_info() if i['internal_api'] == 'openblas'}))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.split(maxsplit=1)
    assert out[0] == CORE_TYPE
    assert out[1].strip() == f"['{CORE_TYPE}']"     # what OpenBLAS itself says it runs
