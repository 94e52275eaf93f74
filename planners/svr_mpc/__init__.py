"""iLQR-SVR inside asynchronous MPC on the pushing tasks: the state-vector-reduction paper's
pipeline as one library call.

``build_controller`` wires a task instance (``dopt.tasks.PUSH_TASKS``) to its cost, a rollout
service, iLQR and a DoF selector; ``run_svr_mpc`` runs one MPC episode (Alg. 1) with it and
returns an ``SVRMPCResult``::

    from planners.svr_mpc import SVRMPCSettings, run_svr_mpc
    result = run_svr_mpc(SVRMPCSettings(task="clutter"), seed=0)   # iLQR-SVR, svr-sum
    result.mpc_cost, result.success, result.dofs_mean

The optimiser is a seam: ``run_svr_mpc(settings, seed, optimiser=...)`` takes a name of
``OPTIMISERS`` (``register_optimiser`` adds one) or a factory ``OptimiserContext -> optimiser``
(any object with ``optimise(state, plan)``), and a trial's params carry the name, so the
sweeps, summaries and command lines (``DOPT_OPTIMISERS``: the modules that register theirs) run
a new optimiser as they run iLQR-SVR (docs/GUIDE.md, "A new MPC optimiser").

``summarize`` turns many finished trials of one task into the rows of Table 1 (costs normalised
by baseline on the same task instance), ``paired`` compares each row with baseline seed by
seed. ``SVRMPCSettings.paper(task, row)`` is the paper's protocol for one of its nine Table 1
rows (``TABLE1_ROWS``): the paper's cost (Eq. 2, no end-effector term), the authors' initial
plan (``dopt.tasks.push.warm_start``), their 5 % control noise, and the virtual clock.

Shapes: T horizon, nu controls, ns state row, c = |C| active DoFs.

    settings.py  SVRMPCSettings (nested: from_params / params, the flat form a trial's
                 params keep), Derivatives (planners.ilqr's typed derivative options;
                 spell_derivatives, their one spelling), TABLE1_ROWS, rows
                 by name (parse_row -> Row), task_defaults, trial params and row labels
    settings_groups.py  the settings' groups: DofSelection, PushScene, PushStart, Timing,
                 Execution
    trial_names.py  a trial's name (trial_key, dopt.lab.identity's rule), the names of the
                 trials written before it (legacy_trial_key) and the sweeps' identity check
    presets.py   the protocols (ours, paper, authors) and TABLE1_ROWS, each number with its
                 source (the paper's section, the authors' file)
    optimisers.py  OPTIMISERS by name, register_optimiser, OptimiserContext, svr_optimiser
    episode.py   build_controller, wire_controller, run_svr_mpc -> SVRMPCResult, run_trial
                 and CapturingTrial (for dopt.lab.sweep; keep_controls: for an exact replay)
    summary.py   summarize, paired, versus (SVR rows against rand and baseline, Holm),
                 feedback_effect, derivatives_effect; table1_fields, fig4_fields: all of a
                 Table 1 / Fig. 4 summary at once
    authors_data.py  the authors' Table 1 statistic on their per-episode files and on ours
    authors_clock.py  the model clock fitted to the authors' optimisation times (clock
                 ``authors``)
    replays.py   KeptControls: which trials keep their executed controls (dopt-view's
                 exact replay), the first seed's or every one's
    choice.py    what each row's C held (the goal object's share) beside its lag and held
                 steps, from stored active sets (choice_fields)
    experiments/  the paper's experiments (Table 1, Fig. 4, ...) behind experiments/*.py
"""

from planners.svr_mpc.episode import (
    CONTROLS_FIELDS,
    GOAL_DISTANCE_STRIDE,
    CapturingTrial,
    SVRController,
    SVRMPCResult,
    build_controller,
    dofs_mask,
    dofs_of_mask,
    run_svr_mpc,
    run_trial,
    solve,
    wire_controller,
)
from planners.svr_mpc.optimisers import (
    DEFAULT_OPTIMISER,
    OPTIMISERS,
    OptimiserContext,
    optimiser_factory,
    optimiser_names,
    register_optimiser,
    svr_optimiser,
)
from planners.svr_mpc.replays import KeptControls
from planners.svr_mpc.settings import (
    CLOCK_MODEL_MS,
    FINITE_DIFFERENCES,
    PAPER_COSTS,
    PRESETS,
    TABLE1_ROWS,
    Derivatives,
    Row,
    SVRMPCSettings,
    derivatives_tag,
    parse_row,
    parse_variants,
    row_label,
    row_name,
    spell_derivatives,
    split_params,
    task_defaults,
    trial_params,
)
from planners.svr_mpc.settings_groups import (
    SVR_CLOCKS,
    DofSelection,
    Execution,
    PushScene,
    PushStart,
    Timing,
)
from planners.svr_mpc.summary import (
    OUTLIER_DISTANCE,
    derivatives_effect,
    feedback_effect,
    fig4_fields,
    paired,
    paired_ratio,
    summarize,
    table1_fields,
    versus,
)
from planners.svr_mpc.trial_names import legacy_trial_key, trial_key

__all__ = ["CLOCK_MODEL_MS", "CONTROLS_FIELDS", "DEFAULT_OPTIMISER", "FINITE_DIFFERENCES",
           "GOAL_DISTANCE_STRIDE", "OPTIMISERS", "OUTLIER_DISTANCE", "PAPER_COSTS", "PRESETS",
           "SVR_CLOCKS", "TABLE1_ROWS", "CapturingTrial", "Derivatives", "DofSelection",
           "Execution", "KeptControls", "OptimiserContext", "PushScene", "PushStart", "Row",
           "SVRController", "SVRMPCResult", "SVRMPCSettings", "build_controller",
           "derivatives_effect", "derivatives_tag", "dofs_mask", "dofs_of_mask", "feedback_effect",
           "fig4_fields", "legacy_trial_key", "optimiser_factory", "optimiser_names", "paired",
           "paired_ratio",
           "parse_row", "parse_variants", "register_optimiser", "row_label", "row_name",
           "run_svr_mpc", "run_trial", "solve", "spell_derivatives", "split_params", "summarize",
           "svr_optimiser", "table1_fields", "task_defaults", "Timing", "trial_key", "trial_params",
           "versus", "wire_controller"]
