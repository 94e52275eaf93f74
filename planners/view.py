"""The viewer's episode sources of this package's trials (``dopt.view``; registered as
``dopt.view.sources`` entry points in pyproject.toml, since dopt imports no planner).

- ``PICK``: a pick-and-place trial file (``experiments/cloth_fold.py``, ``rope.py``:
  ``OUT/trials/*.json``, ``planners.pick_place.run_trial``): the problem rebuilt from its
  settings and seed, the recorded actions re-simulated from its start (exact: the replay ends
  where the trial says it ended, ``Episode.replay_error``), the goal of each stage as a ghost,
  the stage's key particles on the object and on the goal, the picked particle and the place
  target of the action in progress; the distance to the goal over time and CEM's best cost per
  iteration.
- ``MPC``: an MPC trial file (``experiments/mpc.py``, ``planners.svr_mpc.run_trial``): the task
  rebuilt (``split_params(params)[0].build_task(seed)``), each object shaded by the share of
  its DoFs in the active set C of the optimisation under way (the SVR paper's Fig. 1), the goal
  region, the goal object's centre and its target marked and tagged (``mpc_goal_markers``);
  the goal distance and |C| over time. The recorded controls (optional fields
  ``start_state`` and ``controls`` of the result: ``run_trial(..., keep_controls=True)``,
  ``experiments/mpc.py --keep-controls``) are re-simulated exactly; a trial without them shows
  its start and its recorded final state only, and its summary says how to get them
  (``NO_CONTROLS``).

Shapes: S executed steps, F frames, N particles, K key particles, ns state row.
"""

from __future__ import annotations

import logging
from pathlib import Path

import mujoco
import numpy as np

from dopt.view.episode import (
    Curve,
    Episode,
    Ghost,
    Markers,
    Region,
    frame_rows,
    read_record,
    replay_controls,
)

log = logging.getLogger(__name__)
#: what an MPC trial without controls shows, and how to get them
NO_CONTROLS = ("no controls recorded: start and recorded end only; for a replay, rerun this "
               "trial with experiments/mpc.py --keep-controls")


def _record(path, kind: str) -> dict:
    record = read_record(Path(path))
    if record is None or not isinstance(record.get("result"), dict) \
            or not isinstance(record.get("params"), dict):
        raise ValueError(f"{path} is not a {kind} trial file (JSON with params and result)")
    return record


# ------------------------------------------------------------------------- pick and place
def pick_controls(scene, actions: list) -> tuple[np.ndarray, np.ndarray]:
    """The control rows (S, nc) of a trial's recorded actions, stage after stage, and per
    step (S, 4) its stage, action within the stage, particle and the action's global index."""
    rows, info, g = [], [], 0
    for k, stage in enumerate(actions):
        particles = np.asarray(stage["particles"], dtype=int)
        if not particles.size:
            continue
        plan = scene.picker.schedule(particles[None],
                                     np.asarray(stage["displacements"])[None])
        for a, (i, K) in enumerate(zip(particles, plan.steps[0], strict=True)):
            info += [(k, a, int(i), g)] * int(K)
            g += 1
        rows.append(plan.controls[0])
    nc = scene.picker.ncontrol
    return (np.concatenate(rows) if rows else np.empty((0, nc)),
            np.array(info, dtype=int).reshape(-1, 4))


def load_pick(path, max_frames: int = 300) -> Episode:
    """A pick-and-place trial file replayed as an ``Episode`` (module docstring)."""
    from dopt.tasks.pick.picker import CONTROL_SPEC
    from dopt.tasks.pick.scene import mean_distance
    from planners.pick_place import PickPlaceSettings, make_problem

    record = _record(path, "pick-and-place")
    params, res = record["params"], record["result"]
    settings = PickPlaceSettings.from_dict(params["settings"])
    problem = make_problem(settings, int(params["seed"]))
    scene = problem.scene
    U, info = pick_controls(scene, res["actions"])
    spec = scene.scene.layout.spec
    states = replay_controls(scene.model, problem.start_state, U, spec, CONTROL_SPEC)
    error = float(np.max(np.abs(states[-1] - np.asarray(res["final_state"], dtype=float))))
    rows = frame_rows(len(states), max_frames)
    pos_all = scene.positions(states)                                  # (S + 1, N, 3)
    pos = pos_all[rows]
    # the step under way at each frame (row r follows step r - 1); row 0: the first step
    step_info = info[np.clip(rows - 1, 0, max(len(info) - 1, 0))] if len(info) else \
        np.zeros((len(rows), 4), dtype=int)
    stage_of = step_info[:, 0] if len(info) else np.zeros(len(rows), dtype=int)
    markers = _pick_markers(problem, res["actions"], info, pos_all, pos, rows, stage_of)
    goal = problem.final_goal
    dist = mean_distance(pos, goal) * 1e3
    curves = [Curve("distance to the goal", states[rows, 0], dist, "mm")]
    history = np.asarray(res.get("cost_history", []), dtype=float) * 1e3
    if len(history) > 1:
        # the plan being executed is the last iteration's: the cursor stays there
        curves.append(Curve("CEM best cost", np.arange(1, len(history) + 1), history, "mm",
                            "CEM iteration", np.full(len(rows), float(len(history)))))
    ghost = Ghost(np.stack([s.goal for s in problem.stages]), stage_of.copy(),
                  np.asarray(scene.elements))
    captions = [_pick_caption(problem, res["actions"], step_info[f], d, len(info) > 0)
                for f, d in enumerate(dist)]
    s = settings
    summary = (f"**{res.get('method', params.get('method'))}** seed {params['seed']} · "
               f"{s.task} {s.goal} (n = {s.n}, {s.physics})  \n"
               f"final cost {res.get('final_cost', float('nan')) * 1e3:.1f} mm"
               + (f" · **unstable**: {res.get('unstable_reason')}" if res.get("unstable")
                  else "")
               + f"  \nreplay of {len(U)} steps ends {error:.1e} from the recorded final state")
    return Episode(Path(path).stem, scene.model, states[rows], states[rows, 0], captions,
                   summary, spec=spec, curves=curves, markers=markers, ghost=ghost,
                   replay_error=error)


def _pick_markers(problem, actions, info, pos_all, pos, rows, stage_of) -> list[Markers]:
    """Key particles on the object and on the goal (the frame's stage), the picked particle
    and the place target of the action under way."""
    stages = problem.stages
    K = max(len(s.keys) for s in stages)
    on_object = np.full((len(rows), K, 3), np.nan)
    on_goal = np.full((len(rows), K, 3), np.nan)
    for f, k in enumerate(stage_of):
        keys = np.asarray(stages[k].keys, dtype=int)
        on_object[f, :len(keys)] = pos[f, keys]
        on_goal[f, :len(keys)] = stages[k].goal[keys]
    picked = np.full((len(rows), 1, 3), np.nan)
    target = np.full((len(rows), 1, 3), np.nan)
    if len(info):
        starts = np.flatnonzero(np.r_[True, np.diff(info[:, 3]) != 0])  # first step of each
        disp = np.concatenate([np.asarray(a["displacements"], dtype=float).reshape(-1, 3)
                               for a in actions])
        for f, r in enumerate(rows):
            step = min(max(r - 1, 0), len(info) - 1)
            _, _, i, g = info[step]
            if i < 0 or r == 0:
                continue
            picked[f, 0] = pos[f, i]
            target[f, 0] = pos_all[starts[g], i] + disp[g]
    return [Markers("key particles", on_object, (255, 215, 0)),
            Markers("key particles on the goal", on_goal, (40, 110, 230), 0.008),
            Markers("picked particle", picked, (20, 200, 20), 0.018),
            Markers("place target", target, (230, 0, 230), 0.018)]


def _pick_caption(problem, actions, step_info, distance: float, any_action: bool) -> str:
    k, a, i, _ = (int(v) for v in step_info)
    stage = problem.stages[k]
    text = f"stage {k + 1}/{len(problem.stages)} {stage.name}"
    if any_action:
        d = np.asarray(actions[k]["displacements"], dtype=float).reshape(-1, 3)[a]
        n = len(actions[k]["particles"])
        what = "none (hold nothing)" if i < 0 else f"pick particle {i}"
        text += (f" · action {a + 1}/{n}: {what}, move ({d[0]:+.3f}, {d[1]:+.3f}, "
                 f"{d[2]:+.3f}) m")
    return text + f" · distance to goal {distance:.1f} mm"


class PickSource:
    """Episode source of pick-and-place trial files."""

    name = "pick"

    def claims(self, path: Path, record: dict | None) -> bool:
        result = (record or {}).get("result")
        params = (record or {}).get("params")
        return (isinstance(result, dict) and isinstance(params, dict)
                and "actions" in result and "settings" in params)

    def load(self, path: Path, max_frames: int = 300) -> Episode:
        return load_pick(path, max_frames)


# ------------------------------------------------------------------------------------ MPC
def object_shade(model: mujoco.MjModel, dofs: np.ndarray, robot_dofs: np.ndarray
                 ) -> np.ndarray:
    """(nbody,) per body the share of its DoFs in the set ``dofs`` (NaN: a body without DoFs,
    or one of the robot's)."""
    in_set = np.zeros(model.nv, dtype=bool)
    in_set[np.asarray(dofs, dtype=int)] = True
    robot = np.zeros(model.nv, dtype=bool)
    robot[np.asarray(robot_dofs, dtype=int)] = True
    out = np.full(model.nbody, np.nan)
    for b in range(1, model.nbody):
        a, n = int(model.body_dofadr[b]), int(model.body_dofnum[b])
        if n and not robot[a:a + n].any():
            out[b] = in_set[a:a + n].mean()
    return out


def load_mpc(path, max_frames: int = 300) -> Episode:
    """An MPC trial file as an ``Episode`` (module docstring)."""
    from dopt.tasks.push import warm_start
    from planners.svr_mpc.episode import CONTROLS_FIELDS, dofs_of_mask
    from planners.svr_mpc.settings import split_params

    record = _record(path, "MPC")
    settings, seed, _ = split_params(record["params"])
    seed = int(seed)
    res = record["result"]
    task = settings.build_task(seed)
    model = task.model
    final = np.asarray(res["final_state"], dtype=float)
    if set(CONTROLS_FIELDS) <= set(res):
        states = replay_controls(model, res["start_state"], res["controls"])
        error = float(np.max(np.abs(states[-1] - final)))
        steps = np.arange(len(states))
    else:
        log.warning("%s: %s", path, NO_CONTROLS)
        start = (warm_start.setup(task).final_state if settings.start.warm_start
                 else task.initial_state)
        states, error, steps = np.stack([start, final]), None, np.array([0, int(res["steps"])])
    rows = frame_rows(len(states), max_frames)
    steps = steps[rows]
    opt_step = np.asarray(res["opt_step"], dtype=int)
    which = np.searchsorted(opt_step, steps, side="right") - 1       # optimisation under way
    shades = {i: object_shade(model, dofs_of_mask(res["active_sets"][i]), task.robot_dofs)
              for i in set(which.tolist()) if i >= 0}
    shade = np.stack([shades[i] if i >= 0 else np.full(model.nbody, np.nan) for i in which])
    goal_body = model.body(task.goal_object).id if task.soft_body is None else None
    captions = [_mpc_caption(res, int(s), int(i), model, goal_body) for s, i in
                zip(steps, which, strict=True)]
    stride = int(res.get("goal_distance_stride", 10))
    gd = np.asarray(res.get("goal_distance", []), dtype=float)
    gd_steps = np.minimum(np.arange(len(gd)) * stride, int(res["steps"]))
    curves = [Curve("goal distance", gd_steps * task.dt, gd * 1e3, "mm"),
              Curve("|C|", opt_step * task.dt, np.asarray(res["n_dofs"], dtype=float), "DoFs")]
    site = model.site("goal")
    region = Region(np.asarray(task.goal_position, dtype=float), float(site.size[0]),
                    2 * float(site.size[1]))
    markers = mpc_goal_markers(model, states[rows], task)
    replay = (NO_CONTROLS if error is None else
              f"replay of {len(states) - 1} steps ends {error:.1e} from the recorded final state")
    summary = (f"**{settings.selection.method}** seed {seed} · {settings.task} "
               f"({settings.scene.problem}) · "
               f"MPC cost {res.get('mpc_cost', float('nan')):.4g} · success "
               f"{res.get('success')}  \n{replay}  \nshade: share of each object's DoFs in C "
               f"(grey none, red all)")
    return Episode(Path(path).stem, model, states[rows], steps * task.dt, captions, summary,
                   curves=curves, regions=[region], shade=shade, replay_error=error,
                   markers=markers)


#: colours of the MPC goal object's marker and of its target
GOAL_OBJECT_COLOUR, TARGET_COLOUR = (255, 140, 0), (0, 110, 0)


def mpc_goal_markers(model: mujoco.MjModel, states: np.ndarray, task) -> list[Markers]:
    """The goal object's centre at each of the frames states (F, ns) (the mean position of
    ``task.goal_bodies``: its body, or a soft body's vertex bodies) and its target
    (``task.goal_position``), tagged in the scene."""
    bodies = np.asarray(task.goal_bodies, dtype=int)
    data = mujoco.MjData(model)
    centre = np.empty((len(states), 1, 3))
    for f, row in enumerate(states):
        mujoco.mj_setState(model, data, row, mujoco.mjtState.mjSTATE_INTEGRATION)
        mujoco.mj_kinematics(model, data)
        centre[f, 0] = data.xpos[bodies].mean(axis=0)
    target = np.broadcast_to(np.asarray(task.goal_position, dtype=float), (len(states), 1, 3))
    return [Markers("goal object (its centre)", centre, GOAL_OBJECT_COLOUR, 0.02,
                    "goal object"),
            Markers("goal target (the goal region's centre)", target.copy(), TARGET_COLOUR,
                    0.02, "target")]


def _mpc_caption(res: dict, step: int, i: int, model, goal_body: int | None) -> str:
    text = f"step {step}"
    if i < 0:
        return text + " · before the first optimisation"
    text += f" · optimisation {i + 1}/{len(res['opt_step'])} · |C| = {res['n_dofs'][i]}"
    if goal_body is not None:
        from planners.svr_mpc.episode import dofs_of_mask
        a, n = int(model.body_dofadr[goal_body]), int(model.body_dofnum[goal_body])
        dofs = dofs_of_mask(res["active_sets"][i])
        text += f" · goal object's DoFs in C: {int(((dofs >= a) & (dofs < a + n)).sum())}/{n}"
    return text


class MPCSource:
    """Episode source of MPC trial files."""

    name = "mpc"

    def claims(self, path: Path, record: dict | None) -> bool:
        result = (record or {}).get("result")
        params = (record or {}).get("params")
        return (isinstance(result, dict) and isinstance(params, dict)
                and "active_sets" in result and "task" in params)

    def load(self, path: Path, max_frames: int = 300) -> Episode:
        return load_mpc(path, max_frames)


PICK = PickSource()
MPC = MPCSource()
