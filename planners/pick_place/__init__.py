"""Pick-and-place on rope and cloth: the key-particle paper's pipeline as one library call.

A *problem* is a scene (rope or cloth with the picker), a start state and one or more *stages*:
the goal shape and, for the multi-step folds, its intermediate goals in turn (Sec. III-D), each
with the key particles of its goal (``deformables``). A *planner* plans one stage from the
current state; the plan is executed and the next stage starts from where it left the object.

Planners (the paper's Sec. IV-C.2), one interface (``PickPlanner``), built by name with
``make_planner``:

    simple    CEM over the key particles of each stage's goal (CEM(Simple))
    original  CEM over all particles (CEM(Original))
    random    CEM over a random subset as large as the key set (CEM(Random))
    scripted  pick each key particle, move it above its goal, release

One call runs a whole trial::

    from planners.pick_place import PickPlaceSettings, solve
    result = solve(PickPlaceSettings.preset("cloth", "diagonal"), method="simple", seed=0)
    result.metrics["final_cost"]          # mean particle distance to the goal (m)

Modules, one job each (every name is re-exported here):

    tasks.py     the tasks and goals, registered once: PICK_TASKS (PickTaskSpec: scene,
                 sizes, goals), PickGoal (stages, start, metrics, prepared start),
                 PICK_METRICS,
                 register_goal (a new goal and its budget in one call), GOALS;
                 GOAL_NAMES (goal_name), the one table of every name a goal goes by
    presets.py   the presets of both protocols with the source of every number: PRESETS
                 (ours), PAPER_PRESETS (the paper's), QUICK_CHANGES, PROTOCOL_SEEDS
    settings.py  PickPlaceSettings: presets, scene and picker configs, a trial's identity
    trial_names.py  a trial's name (trial_key, dopt.lab.identity's rule), the names of the
                 trials written before it (legacy_trial_key) and the sweeps' identity check
    problem.py   Problem and make_problem (a goal's start, or its prepared start)
    budget.py    the sizes a setting implies, checked before anything is allocated
                 (check_budget, budget_problem, BudgetError)
    planners.py  StagePlan, PickPlanner, CEMPlanner, ScriptedPlanner, make_planner, METHODS,
                 register_planner
    drag.py      the authors' drag encoding as planners (original-, simple-, random-drag;
                 drag_settings.py: DragSettings; encoding.py: its sweep against N)
    run.py       run_problem (with checkpoints and blow-up captures: capture_label), solve,
                 run_trial, PickPlaceResult
    summary.py   summarize, last_improvement
    calibration.py  seconds_per_action: what one simulated action costs on this machine now
                 (a command line's estimate of a run's time)
    scaling.py   the gain against the particle count: scaling_trials (Fig. 7's trials at
                 several cloth sizes: a finer sheet, or a bigger one at fixed spacing),
                 scaling_summary (intervals, the trend test on log N, in m and normalised
                 by the flat sheet's cost, ``fold_costs``)
    random_reach.py  why CEM(Random) lands where it does: each trial's candidates re-drawn
                 from its seed and what they can reach (``random_reach``, ``reach_summary``;
                 ``settings_groups`` splits a folder that ran two settings)

Shapes: N particles, K key particles, H actions per plan, ns state row.
"""

from planners.pick_place import drag as _drag  # noqa: F401  (registers the drag planners)
from planners.pick_place.calibration import seconds_per_action
from planners.pick_place.planners import (
    CEM_CANDIDATES,
    LABELS,
    METHODS,
    CEMPlanner,
    PickPlanner,
    ScriptedPlanner,
    StagePlan,
    make_planner,
    register_planner,
)
from planners.pick_place.presets import (
    PAPER_CHANGES,
    PAPER_PRESETS,
    PRESETS,
    PROTOCOL_SEEDS,
    PROTOCOLS,
    QUICK_CHANGES,
    Preset,
    paper_preset,
    quick_preset,
)
from planners.pick_place.problem import Problem, make_problem
from planners.pick_place.run import (
    PickPlaceResult,
    TrialProgress,
    capture_label,
    run_problem,
    run_trial,
    solve,
)
from planners.pick_place.settings import (
    FOLD_STARTS,
    UNSET_SCENE_FIELDS,
    UNSET_SETTINGS,
    PickPlaceSettings,
)
from planners.pick_place.summary import last_improvement, summarize
from planners.pick_place.tasks import (
    CRUMPLE_TURN,
    GOAL_NAMES,
    GOALS,
    PICK_METRICS,
    PICK_TASKS,
    PREPARED_LIFT,
    PREPARED_SETTLE,
    GoalName,
    PickGoal,
    PickTaskSpec,
    Stage,
    cloth_prepared,
    cloth_sequence,
    goal_name,
    metric_names,
    pick_task,
    register_goal,
    register_task,
    rope_stage,
)
from planners.pick_place.trial_names import legacy_trial_key, trial_key

__all__ = [
    "CEM_CANDIDATES", "CRUMPLE_TURN", "FOLD_STARTS", "GOAL_NAMES", "GOALS", "LABELS", "METHODS",
    "PAPER_CHANGES", "PAPER_PRESETS", "PICK_METRICS", "PICK_TASKS", "PREPARED_LIFT",
    "PREPARED_SETTLE", "PRESETS", "PROTOCOLS", "PROTOCOL_SEEDS", "QUICK_CHANGES",
    "UNSET_SCENE_FIELDS", "UNSET_SETTINGS", "CEMPlanner", "GoalName", "PickGoal",
    "PickPlaceResult", "PickPlaceSettings", "PickPlanner", "PickTaskSpec", "Preset", "Problem",
    "ScriptedPlanner", "Stage", "StagePlan", "TrialProgress", "capture_label", "cloth_prepared",
    "cloth_sequence", "goal_name", "last_improvement", "make_planner", "make_problem",
    "metric_names", "paper_preset", "pick_task", "quick_preset", "register_goal",
    "register_planner", "register_task", "rope_stage", "run_problem", "run_trial",
    "legacy_trial_key", "seconds_per_action", "solve", "summarize", "trial_key",
]
