"""The authors' regime gives the same trial on any machine and day: a committed trial of the
clutter pilot (recorded on the project's 2-core machine), rerun here on the authors' clock,
gives its recorded MPC cost to the last bit, whatever this machine's speed or load (a busy
thread runs beside it) and whichever kernels its OpenBLAS would pick: dopt pins the AVX2 ones
(dopt/blas.py; under the AVX-512 kernels the trial ends at another cost). Skips without the
authors' scenes (../shared/external)."""

import json
import threading
from pathlib import Path

import pytest

from dopt import blas
from planners.svr_mpc import run_trial

from ...external import LAYOUTS

ROOT = Path(__file__).resolve().parents[3]
TRIAL = (ROOT / "docs" / "results" / "runs" / "table1-clutter-authors-executor" / "trials"
         / "clutter-rand-rho1-theta5-slow1-Y0-seed3-costauthors-clutter-ws-clockauthors-"
           "execauthors-authors.json")


@pytest.mark.skipif(not LAYOUTS.is_dir(), reason=f"the authors' scenes are not at {LAYOUTS}")
def test_a_committed_pilot_trial_reruns_to_its_recorded_cost_under_load():
    stored = json.loads(TRIAL.read_text())
    assert stored["params"]["clock"] == "authors" and stored["params"]["executor"] == "authors"
    if blas.kernels() not in (None, "Haswell", "Zen"):
        pytest.skip(f"OpenBLAS runs its {blas.kernels()} kernels here (a CPU without AVX2, or "
                    "numpy loaded before dopt): the trial was recorded under the AVX2 ones")
    params = {**stored["params"], "layouts": str(LAYOUTS)}
    stop = threading.Event()

    def busy():                                    # load that a CPU clock would feel
        x = 0
        while not stop.is_set():
            x += 1

    load = threading.Thread(target=busy, daemon=True)
    load.start()
    try:
        result = run_trial(params)
    finally:
        stop.set()
        load.join()
    assert result["mpc_cost"] == stored["result"]["mpc_cost"]
    assert result["n_dofs"] == stored["result"]["n_dofs"]
    assert result["held_steps"] == stored["result"]["held_steps"]
