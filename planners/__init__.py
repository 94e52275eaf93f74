"""Optimisers over a RolloutService and a cost: CEM over pick actions, reduced iLQR, SVR, and
the two papers' pipelines over them.

The algorithm modules know no paper; the pipelines hold each paper's settings, problems, run
loop and summaries. Modules:

    cem.py            torch-batched CEM over pick-and-place action sequences
    gaussian_cem.py   the plain diagonal-Gaussian CEM of the key-particle authors' code
    scripted.py       the key-particle paper's scripted policy
    ilqr.py           iLQR with state-vector reduction (reduced backward, full forward pass);
                      keypoints.py: derivatives at key timesteps only
    svr.py            DoF importance from the gains K, the DoF selectors, SVROptimiser
    pick_place/       the key-particle pipeline: the tasks and goals registered once, the
                      presets of both protocols, settings, problems, planners by name,
                      run_problem / solve / run_trial, summarize, the sizes a setting
                      implies (budget.py)
    svr_mpc/          the state-vector-reduction pipeline: settings and presets, run_svr_mpc,
                      summaries, the authors' statistic
    trial_progress.py the CEM iterations a saved trial holds, the fields of a trial's result and
                      progress (standard library only)
    view.py           dopt-view's sources of pick-and-place and MPC trial files
    _checks.py        input checks the planners share (particle indices, a picker bound)
    bench/            python -m planners.bench: CEM, iLQR, the model clock, physics sweeps
"""

import dopt  # noqa: F401  first, so that it pins OpenBLAS's kernels before numpy loads (dopt/blas.py)
