"""dopt pins OpenBLAS's kernels (dopt/blas.py): imported before numpy on a CPU with AVX2 and
FMA, every BLAS call of the process runs the Haswell kernels whatever the CPU would pick; a
user's OPENBLAS_CORETYPE wins; imported after numpy it changes nothing and reports the kernels
OpenBLAS chose. Each case runs in a fresh interpreter (this one loaded numpy long ago)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REPORT = ("import os, json; from dopt import blas; "
          "print(json.dumps([os.environ.get('OPENBLAS_CORETYPE'), blas.kernels()]))")


def _flags() -> set:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            return {w for line in f if line.startswith("flags") for w in line.split(":")[1].split()}
    except OSError:
        return set()


AVX2 = {"avx2", "fma"} <= _flags()
needs_avx2 = pytest.mark.skipif(not AVX2, reason="the pin applies only where the CPU runs AVX2")


def _run(first: str, env_value: str | None = None) -> list:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if env_value is not None:
        env["OPENBLAS_CORETYPE"] = env_value
    out = subprocess.run([sys.executable, "-c", f"import {first}; {REPORT}"], cwd=ROOT, env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@needs_avx2
@pytest.mark.parametrize("first", ["dopt", "planners", "deformables"])
def test_importing_a_package_first_pins_the_haswell_kernels(first):
    env_value, running = _run(first)
    if running is None:
        pytest.skip("numpy's BLAS here is not an OpenBLAS that names its kernels")
    assert [env_value, running] == ["Haswell", "Haswell"]


@needs_avx2
def test_the_users_own_choice_wins():
    # Sandybridge: AVX kernels, which every CPU with AVX2 runs, unlike dopt's own choice
    assert _run("dopt", "Sandybridge") == ["Sandybridge", "Sandybridge"]


def test_numpy_loaded_first_keeps_what_openblas_chose():
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    code = ("import numpy, os, json; from dopt import blas; "
            "print(json.dumps([os.environ.get('OPENBLAS_CORETYPE'), blas.pin()]))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                         text=True, check=True)
    # dopt set nothing on import, and a later pin() declines: it would come too late
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [None, None]


@pytest.mark.skipif(not Path("/proc/cpuinfo").exists(), reason="Linux's /proc/cpuinfo only")
def test_cpuinfo_reads_the_first_processors_fields():
    from dopt import blas

    assert blas.cpuinfo("processor") == "0"                 # the first processor's index
    assert set(blas.cpuinfo("flags").split()) == _flags()   # this file's own reader
    assert blas.cpuinfo("no such field") == ""
    assert blas.cpuinfo("flag") == ""                       # a whole field name, not a prefix
