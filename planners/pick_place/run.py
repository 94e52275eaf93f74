"""The run loop: plan and execute every stage of a problem (``run_problem``), one trial in one
call (``solve``), and the same for ``dopt.lab.sweep`` (``run_trial``); a trial saves its progress
to a checkpoint and resumes from it to the result it gives unstopped.

Blow-up captures (``blowup_out``, opt-in): every stage's executed plan that the stability
verdict flags (``PickPlaceTask``'s, never a CEM sample) is written to
``blowup_out/blowups/<label>-<stage>`` (``capture_label``; ``dopt.blowup``, which
``dopt-view`` opens at the flagged step) and listed in the result.

Shapes: ns state row.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from dopt.blowup import retire_captures
from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks import PickPlaceTask
from planners.pick_place.planners import PickPlanner, StagePlan, make_planner
from planners.pick_place.problem import Problem, make_problem
from planners.pick_place.settings import PickPlaceSettings
from planners.pick_place.trial_names import trial_key

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PickPlaceResult:
    """One trial: ``metrics`` of the final state (``Problem.metrics``), the best cost after
    every iteration of every stage (``cost_history``, with ``stage_of_iteration``), each
    stage's cost, candidates and actions, seconds per CEM iteration (None when scripted), the
    final state (ns,), the wall time (s), the rollouts simulated and how many the stability
    verdict flagged, and whether an executed plan was unstable (``unstable_reason`` names the
    stage, step and bound): such a trial's metrics are not those of a physical result.
    ``segments``: the runs the trial took (more than 1 when it was resumed from a checkpoint;
    ``wall_s`` is then their sum, and the same result as in one run). ``blowups``: the blow-up
    capture folders of its flagged executed plans, relative to ``run_problem``'s
    ``blowup_out`` (none without it)."""

    method: str
    seed: int
    metrics: dict
    cost_history: list
    stage_of_iteration: list
    stage_costs: list
    n_candidates: list
    s_per_iteration: float | None
    actions: list
    final_state: np.ndarray
    wall_s: float
    n_rollouts: int = 0
    n_unstable_rollouts: int = 0
    unstable: bool = False
    unstable_reason: str = ""
    n_infeasible_rollouts: int = 0
    segments: int = 1
    blowups: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-able form: the metrics at the top level, the final state as a list."""
        d = asdict(self)
        metrics = d.pop("metrics")
        d["final_state"] = self.final_state.tolist()
        return {"method": d.pop("method"), "seed": d.pop("seed"), **metrics, **d}


@dataclass
class TrialProgress:
    """What a trial has done, kept in its checkpoint (``dopt.lab.sweep.Checkpoint``, or anything
    with ``load() -> dict | None`` and ``save(dict)``; None: not checkpointed): the trial it
    is of (method, seed, ``settings.identity()``), the stages planned, the planner's progress
    in the next (``partial``), the runs so far and their wall time."""

    checkpoint: object | None
    trial: dict
    start: float = field(default_factory=time.perf_counter)
    done: list[StagePlan] = field(default_factory=list)
    earlier_s: float = 0.0
    segments: int = 1
    partial: dict | None = None

    @classmethod
    def open(cls, checkpoint, problem: Problem, planner, method: str,
             seed: int) -> TrialProgress:
        """The trial's progress: a fresh one, or the one ``checkpoint`` holds (ValueError if
        it holds another trial's), with the planner's generators set to it."""
        # what the progress must be of (threads do not change results)
        trial = {"method": method, "seed": int(seed), "settings": problem.settings.identity()}
        progress = cls(checkpoint, trial)
        saved = checkpoint.load() if checkpoint is not None else None
        if saved is None:
            return progress
        if saved.get("trial") != trial:
            raise ValueError(f"the checkpoint holds the progress of another trial: "
                             f"{_trial_difference(saved.get('trial'), trial)}")
        progress.done = [StagePlan.from_dict(d) for d in saved["stages"]]
        progress.earlier_s = float(saved["wall_s"])
        progress.segments = int(saved["segments"]) + 1
        progress.partial = saved["stage"]
        planner.set_rng_state(saved["planner"])
        log.info("%s seed %d resumes after %d of %d stages%s", method, seed,
                 len(progress.done), len(problem.stages),
                 " and part of the next" if progress.partial else "")
        return progress

    def wall_s(self) -> float:
        """Seconds of every run of the trial so far."""
        return self.earlier_s + time.perf_counter() - self.start

    def save(self, stage_progress: dict | None, rng: dict) -> None:
        """Checkpoint the stages done, the planner's progress in the next stage and its
        generators' state ``rng`` at that stage's start."""
        self.checkpoint.save({"trial": self.trial, "stages": [p.to_dict() for p in self.done],
                              "planner": rng, "stage": stage_progress,
                              "segments": self.segments, "wall_s": self.wall_s()})

    def plan_kwargs(self, planner) -> dict:
        """The resume arguments of ``planner.plan`` for the next stage (none without a
        checkpoint)."""
        if self.checkpoint is None:
            return {}
        rng = planner.rng_state()                   # the stage's start: a resume redraws
        return {"resume": self.partial,
                "on_progress": lambda progress, rng=rng: self.save(progress, rng)}


def capture_label(prefix: str, stage: str) -> str:
    """The label of the blow-up capture of a trial's stage: "<prefix>-<stage name>" (its
    folder under OUT/blowups, ``dopt.blowup.capture_dir``)."""
    return f"{prefix}-{stage}"


@dataclass(frozen=True)
class _Captures:
    """Where ``run_problem`` writes the blow-up captures of a trial (``out``; None: nowhere)
    and the label prefix of its stages' captures (``capture_label``)."""

    out: str | os.PathLike | None
    prefix: str

    def __post_init__(self):
        if self.out is not None and not isinstance(self.out, (str, os.PathLike)):
            raise TypeError(f"blowup_out must be a folder path or None, got "
                            f"{type(self.out).__name__}")
        if not isinstance(self.prefix, str):
            raise TypeError(f"blowup_label must be a string or None, got {self.prefix!r}")

    def retire(self, stages) -> None:
        """Move the captures of ``stages`` (an earlier run's) to ``blowups/outdated/``."""
        if self.out is not None:
            retire_captures(self.out, [capture_label(self.prefix, s.name) for s in stages])

    def task_kwargs(self, stage) -> dict:
        """The blow-up arguments of the stage's ``PickPlaceTask``."""
        if self.out is None:
            return {}
        return {"blowup_out": self.out, "blowup_label": capture_label(self.prefix, stage.name)}

    def record(self, plan: StagePlan, task: PickPlaceTask) -> StagePlan:
        """``plan`` with the captures its task wrote (relative to ``out``)."""
        if self.out is None or not task.blowups:
            return plan
        return replace(plan, blowups=[os.path.relpath(b, self.out) for b in task.blowups])


def run_problem(problem: Problem, planner: PickPlanner, *, method: str = "", seed: int = 0,
                service: RolloutService | None = None,
                on_iteration: Callable[[int, float], None] | None = None,
                checkpoint=None, blowup_out: str | os.PathLike | None = None,
                blowup_label: str | None = None) -> PickPlaceResult:
    """Plan and execute every stage of ``problem`` in turn with ``planner``.

    ``service`` defaults to a new one with the settings' threads (closed at the end);
    ``method`` and ``seed`` only label the result. ``checkpoint`` (``dopt.lab.sweep.Checkpoint``,
    or anything with ``load() -> dict | None`` and ``save(dict)``): the trial's progress is
    saved after every stage and, with a resumable planner (``PickPlanner``), after every step
    of its planning; a progress found there is resumed, and the result is the one the trial
    gives without a stop (only ``wall_s``, summed over the runs, and ``segments`` differ).
    ``blowup_out``: a run folder that receives a blow-up capture of each stage's executed plan
    that the verdict flags, as ``blowups/<blowup_label>-<stage>`` (default label
    ``<method>-seed<seed>``; the module docstring), listed in ``PickPlaceResult.blowups``;
    those of the stages still to run from an earlier run move to ``blowups/outdated/`` first.
    None (default): no capture.
    """
    checkpoint = _check_run(problem, planner, on_iteration, checkpoint)
    captures = _Captures(blowup_out, f"{method}-seed{seed}" if blowup_label is None
                        else blowup_label)
    progress = TrialProgress.open(checkpoint, problem, planner, method, seed)
    captures.retire(problem.stages[len(progress.done):])
    with _services(problem, service) as (svc, plan_svc):
        state = progress.done[-1].final_state if progress.done else problem.start_state
        for stage in problem.stages[len(progress.done):]:
            task = PickPlaceTask(problem.scene, stage.goal, state, svc,
                                 problem.planning_scene, plan_svc,
                                 rest=problem.settings.rest(), **captures.task_kwargs(stage))
            plan = planner.plan(task, stage.keys, on_iteration, **progress.plan_kwargs(planner))
            plan = captures.record(plan, task)
            progress.partial = None
            state = plan.final_state
            progress.done.append(plan)
            if plan.unstable:
                log.warning("%s seed %d stage %s: the executed plan went unstable (%s)", method,
                            seed, stage.name, plan.unstable_reason)
            log.info("%s seed %d stage %s: cost %.1f mm", method, seed, stage.name,
                     plan.cost * 1e3)
            if checkpoint is not None:
                progress.save(None, planner.rng_state())
    return _result(problem, progress, state, method, seed)


def _check_run(problem, planner, on_iteration, checkpoint):
    """TypeError on a bad argument of ``run_problem``; the checkpoint to use (None where the
    planner cannot resume)."""
    if not isinstance(problem, Problem):
        raise TypeError(f"problem must be a Problem (make_problem), got {type(problem).__name__}")
    if not callable(getattr(planner, "plan", None)):
        raise TypeError(f"planner must be a PickPlanner (with plan), got {type(planner).__name__}")
    if on_iteration is not None and not callable(on_iteration):
        raise TypeError(f"on_iteration must be callable or None, got {on_iteration!r}")
    if checkpoint is not None and not (callable(getattr(checkpoint, "load", None))
                                       and callable(getattr(checkpoint, "save", None))):
        raise TypeError(f"checkpoint must have load() and save(progress), got "
                        f"{type(checkpoint).__name__}")
    if checkpoint is not None and not callable(getattr(planner, "rng_state", None)):
        log.info("%s: the planner has no rng_state, so the trial is not checkpointed",
                 type(planner).__name__)
        return None
    return checkpoint


@contextmanager
def _services(problem: Problem, service: RolloutService | None
              ) -> Iterator[tuple[RolloutService, RolloutService | None]]:
    """The rollout services of the scene (``service``, or a new one closed at the end) and of
    the planning scene (None without one)."""
    own = service is None
    svc = service or RolloutService(problem.scene.scene,
                                    RolloutConfig(threads=problem.settings.threads))
    plan_svc = (RolloutService(problem.planning_scene.scene,
                               RolloutConfig(threads=problem.settings.threads))
                if problem.planning_scene is not None else None)
    try:
        yield svc, plan_svc
    finally:
        if own and hasattr(svc, "close"):
            svc.close()
        if plan_svc is not None:
            plan_svc.close()


def _result(problem: Problem, progress: TrialProgress, state: np.ndarray, method: str,
            seed: int) -> PickPlaceResult:
    """The trial's result from its stage plans and final state (ns,)."""
    done = progress.done
    history = [c for p in done for c in p.cost_history]
    stage_of = [k for k, p in enumerate(done) for _ in p.cost_history]
    seconds = [t for p in done for t in p.seconds_per_iteration]
    reasons = [f"stage {stage.name}: {p.unstable_reason}"
               for stage, p in zip(problem.stages, done, strict=True) if p.unstable]
    # full precision: a cloth amplifies a micrometre of rounding into centimetres, and the
    # recorded actions must replay to the recorded final state
    actions = [{"stage": stage.name, "particles": p.particles.tolist(),
                "displacements": np.asarray(p.displacements, float).tolist()}
               for stage, p in zip(problem.stages, done, strict=True)]
    return PickPlaceResult(method, int(seed), problem.metrics(state), history, stage_of,
                           [p.cost for p in done], [p.n_candidates for p in done],
                           float(np.mean(seconds)) if seconds else None,
                           actions, np.asarray(state), progress.wall_s(),
                           sum(p.n_rollouts for p in done),
                           sum(p.n_unstable_rollouts for p in done), bool(reasons),
                           "; ".join(reasons), sum(p.n_infeasible_rollouts for p in done),
                           progress.segments, [b for p in done for b in p.blowups])


def checkpoint_problem(progress: dict) -> str | None:
    """Why the saved ``progress`` of a trial (holding ``PROGRESS_FIELDS``) cannot be resumed,
    or None: ``planners.trial_progress.progress_problem``, then each finished stage read as a
    ``StagePlan`` and the unfinished stage's CEM progress as a ``CEMProgress`` (finite
    probabilities >= 0 that sum to 1, histories as long as its iterations, ...). The
    experiments' ``dopt.lab.sweep.Schema.check_progress``: a checkpoint that fails is moved
    aside and its trial starts afresh, where it once failed the trial on every rerun."""
    from planners.cem import CEMProgress
    from planners.trial_progress import progress_problem

    if (problem := progress_problem(progress)) is not None:
        return problem
    try:
        for d in progress["stages"]:
            StagePlan.from_dict(d)
        stage = progress["stage"]
        if stage is not None:
            CEMProgress.from_dict(stage["cem"])
    except (KeyError, TypeError, ValueError) as e:
        return f"its progress cannot be resumed ({type(e).__name__}: {e})"
    return None


def _trial_difference(saved, trial: dict) -> str:
    """How a checkpoint's trial identity ``saved`` differs from ``trial``'s."""
    if not isinstance(saved, dict):
        return "it names no trial"
    parts = [f"{k} {saved.get(k)!r}, not {trial[k]!r}" for k in ("method", "seed")
             if saved.get(k) != trial[k]]
    theirs = saved.get("settings") if isinstance(saved.get("settings"), dict) else {}
    other = sorted(k for k in set(theirs) | set(trial["settings"])
                   if theirs.get(k) != trial["settings"].get(k))
    if other:
        parts.append("other settings: " + ", ".join(other))
    return "; ".join(parts)


def solve(settings: PickPlaceSettings, method: str = "simple", seed: int = 0,
          on_iteration: Callable[[int, float], None] | None = None,
          checkpoint=None, blowup_out: str | os.PathLike | None = None,
          blowup_label: str | None = None) -> PickPlaceResult:
    """One trial in one call: build the problem, plan every stage with ``method``, execute,
    measure. The same settings, method and seed give the same result, also when the trial
    is stopped and resumed from its ``checkpoint`` (``run_problem``, as are ``blowup_out``
    and ``blowup_label``).

    Raises:
        TypeError / ValueError: settings that are not PickPlaceSettings, an unknown method, a
            seed that is not an int >= 0, an on_iteration that is not callable.
    """
    if on_iteration is not None and not callable(on_iteration):
        raise TypeError(f"on_iteration must be callable or None, got {on_iteration!r}")
    planner = make_planner(method, settings, seed)      # checks all three before any scene
    _Captures(blowup_out, "" if blowup_label is None else blowup_label)     # and these two
    problem = make_problem(settings, seed)
    return run_problem(problem, planner, method=method, seed=seed, on_iteration=on_iteration,
                       checkpoint=checkpoint, blowup_out=blowup_out, blowup_label=blowup_label)


def run_trial(params: dict, on_iteration: Callable[[int, float], None] | None = None,
              checkpoint=None, blowup_out: str | os.PathLike | None = None) -> dict:
    """``solve`` for ``dopt.lab.sweep``: params {"settings": PickPlaceSettings.to_dict(),
    "method", "seed"} -> ``PickPlaceResult.to_dict()``; the sweep's ``checkpoint`` lets a
    stopped trial resume. ``blowup_out``: the sweep's folder, which receives the blow-up
    captures of the trial's executed plans as ``blowups/<trial key>-<stage>`` (``trial_key``,
    ``capture_label``), listed in the result's "blowups" relative to it."""
    settings = PickPlaceSettings.from_dict(params["settings"])
    method, seed = params["method"], int(params["seed"])
    label = None if blowup_out is None else trial_key(method, seed, settings)
    return solve(settings, method, seed, on_iteration, checkpoint, blowup_out,
                 label).to_dict()

