"""iLQR-SVR inside asynchronous MPC on the pushing tasks: the state-vector-reduction paper's
pipeline as one library call.

``build_controller`` wires a task instance (``dopt.tasks.PUSH_TASKS``) to its cost, a rollout
service, iLQR and a DoF selector; ``run_svr_mpc`` runs one MPC episode (Alg. 1) with it and
returns an ``SVRMPCResult``::

    from planners.svr_mpc import SVRMPCSettings, run_svr_mpc
    result = run_svr_mpc(SVRMPCSettings(task="clutter", method="svr-sum"), seed=0)
    result.mpc_cost, result.success, result.dofs_mean

``summarize`` turns many finished trials of one task into the rows of Table 1 (costs normalised
by baseline on the same task instance), ``paired`` compares each row with baseline seed by
seed. ``SVRMPCSettings.paper(task, row)`` is the paper's protocol for one of its nine Table 1
rows (``TABLE1_ROWS``): the paper's cost (Eq. 2, no end-effector term), the authors' initial
plan (``dopt.tasks.push.warm_start``), their 5 % control noise, and the virtual clock.

Shapes: T horizon, nu controls, ns state row, c = |C| active DoFs.

    settings.py  SVRMPCSettings, TABLE1_ROWS, row names and derivative variants, trial keys
    episode.py   build_controller, run_svr_mpc -> SVRMPCResult, run_trial and CapturingTrial
                 (for dopt.sweep)
    summary.py   summarize, paired, feedback_effect, derivatives_effect
    authors_data.py  the authors' Table 1 statistic on their per-episode files and on ours
"""

from planners.svr_mpc.episode import (
    GOAL_DISTANCE_STRIDE,
    CapturingTrial,
    SVRController,
    SVRMPCResult,
    build_controller,
    dofs_mask,
    dofs_of_mask,
    run_svr_mpc,
    run_trial,
)
from planners.svr_mpc.settings import (
    CLOCK_MODEL_MS,
    PAPER_COSTS,
    TABLE1_ROWS,
    SVRMPCSettings,
    derivatives_tag,
    parse_row,
    row_label,
    row_name,
    trial_key,
    variant_settings,
)
from planners.svr_mpc.summary import (
    OUTLIER_DISTANCE,
    derivatives_effect,
    feedback_effect,
    paired,
    paired_ratio,
    summarize,
)

__all__ = ["CLOCK_MODEL_MS", "GOAL_DISTANCE_STRIDE", "OUTLIER_DISTANCE", "PAPER_COSTS",
           "TABLE1_ROWS", "CapturingTrial", "SVRController", "SVRMPCResult", "SVRMPCSettings",
           "build_controller", "derivatives_effect", "derivatives_tag", "dofs_mask",
           "dofs_of_mask", "feedback_effect", "paired", "paired_ratio", "parse_row",
           "row_label", "row_name", "run_svr_mpc", "run_trial", "summarize", "trial_key",
           "variant_settings"]
