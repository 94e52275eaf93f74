"""The files Table 1 (``table1``, experiments/mpc.py) writes besides its summary:
OUT/table1.md and table1.csv (``write_table``), the first seed's |C| and goal-distance curves
per row (``write_plots``: mpc_dofs.png, mpc_goal_distance.png) and each row's final scene
(final_<row>.png, ``write_final``)."""

from __future__ import annotations

import csv
import logging
from pathlib import Path

import numpy as np

from dopt import atomic
from planners.svr_mpc import OUTLIER_DISTANCE, row_label, split_params

log = logging.getLogger(__name__)

def write_table(out: Path, task: str, methods: dict, feedback: dict | None = None) -> None:
    rows = [("row", "MPC cost (normalised) mean", "CI90 +-", "median (all)",
             "median ratio", "opt. time (ms)", "DoFs", "lag (steps)", "success",
             "goal dist. (m, median)", "outliers", "trials")]

    def num(x, digits=2):
        """A number to the table, or n/a when there is none (no baseline for the pairing)."""
        return "n/a" if x is None or x != x else f"{x:.{digits}f}"

    for name, m in methods.items():
        rows.append((name, num(m["mpc_cost_normalised_mean"]),
                     num(m["mpc_cost_normalised_ci90"]),
                     num(m["mpc_cost_normalised_median"]), num(m["mpc_cost_median_ratio"]),
                     f"{m['opt_ms_mean']:.0f}", f"{m['n_dofs_mean']:.1f}",
                     f"{m['lag_steps_mean']:.0f}", f"{m['success_rate']:.2f}",
                     f"{m['goal_distance_end_median']:.3f}", str(m["outliers"]),
                     str(m["n_trials"])))
    with atomic.writing(out / "table1.csv") as tmp, open(tmp, "w", newline="") as f:
        csv.writer(f).writerows(rows)
    lines = [f"Task: {task}. Normalised by baseline on the same instance; mean and 90% CI "
             f"exclude outliers (goal object > {OUTLIER_DISTANCE} m from the goal) and unstable "
             "trials.", "",
             "| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    lines += ["| " + " | ".join(r) + " |" for r in rows[1:]]
    if feedback:
        lines += ["", "Feedback vs open loop, paired by seed (MPC cost ratio, geometric mean and "
                  "90% CI; pairs where feedback cost less; successes open loop -> feedback):",
                  "", "| method | cost ratio | CI90 | feedback better | successes |",
                  "|---|---|---|---|---|"]
        lines += [f"| {name} | {f['ratio_geomean']:.2f} | {f['ratio_ci90'][0]:.2f}-"
                  f"{f['ratio_ci90'][1]:.2f} | {f['better']}/{f['pairs']} | "
                  f"{f['success_open_loop']} -> {f['success_feedback']} |"
                  for name, f in feedback.items()]
    atomic.write_text(out / "table1.md", "\n".join(lines) + "\n")


# ---------------------------------------------------------------------------------- plots

def first_seed(records: list[dict], rows) -> dict:
    """{row label: result of its lowest seed} for each row (``row_label``) in ``rows``."""
    out = {}
    for r in sorted(records, key=lambda r: r["params"]["seed"]):
        label = row_label(r["params"])
        if label in rows and label not in out:
            out[label] = {**r["result"], "seed": r["params"]["seed"], "params": r["params"]}
    return {k: out[k] for k in rows if k in out}


def write_plots(out: Path, task: str, records: list[dict], rows, render: bool = True) -> None:
    """mpc_dofs.png, mpc_goal_distance.png and (``render``) final_<row>.png of the first seed
    of each row. Trial files written before a result held the goal distance per step or the
    final state are left out of those pictures; a failed render is logged, not raised."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dopt.tasks.push.costs import PushWeights

    first = first_seed(records, rows)
    if not first:
        return
    # colours and, as rows often overlap (every method starts alike), dashes and widths
    style = {row: dict(color=plt.get_cmap("tab10")(i % 10), lw=2.6 - 0.4 * (i % 4),
                       ls=("-", "--", "-.", ":")[i % 4]) for i, row in enumerate(first)}
    fig, ax = plt.subplots(figsize=(7, 4))
    for row, r in first.items():
        if not r["n_dofs"]:
            continue
        # each |C| holds from its optimisation's start to the next one's (the last: to the end)
        x = list(r["opt_step"]) + [max(r["steps"], r["opt_step"][-1] if r["opt_step"] else 0)]
        y = list(r["n_dofs"]) + list(r["n_dofs"][-1:])
        ax.step(x, y, where="post", **style[row],
                label=f"{row} (mean {r['dofs_mean']:.1f}, {len(r['n_dofs'])} optimisations)")
    _save(fig, ax, out / "mpc_dofs.png", "agent step at which the optimisation started",
          "active DoFs |C|", f"{task}: DoFs optimised over the episode (first seed of each "
          "method)")

    fig, ax = plt.subplots(figsize=(7, 4))
    for row, r in first.items():
        d = r.get("goal_distance") or []
        if d:
            stride = r.get("goal_distance_stride", 1)
            x = [min(i * stride, r["steps"]) for i in range(len(d))]
            ax.plot(x, d, **style[row],
                    label=f"{row}: {'success' if r['success'] else 'no success'}, "
                          f"end {d[-1]:.3f} m")
    ax.axhline(PushWeights().success_radius, color="k", ls="--", lw=1,
               label="success radius")
    _save(fig, ax, out / "mpc_goal_distance.png", "executed agent step",
          "goal object's distance to the goal (m)",
          f"{task}: goal distance over the episode (first seed of each method)")

    if not render:
        return
    try:
        for row, r in first.items():
            if r.get("final_state"):
                write_final(out / f"final_{row.replace(' +', '_')}.png", task, row, r)
    except Exception as e:                # the numbers are written; a missing GL only loses images
        log.warning("rendering failed (%s: %s); set MUJOCO_GL=egl", type(e).__name__, e)


def final_panels(params: dict, final_state, size=(640, 480)):
    """(close-up from above, oblique) images (2, H, W, 3) of a push task's final state: the
    close-up frames the objects, the goal and the pusher, leaves the arm out and marks where
    each object (a soft body: its mean vertex) started (white rings; the goal object's black)
    with a line to where it ended, and the goal (x); the oblique view shows the whole scene."""
    import mujoco

    from dopt import render
    from dopt.scene import Scene
    settings, seed, _ = split_params(params)
    tm = settings.build_task(seed)
    m = tm.model
    spec = Scene(m).layout.spec
    fovy, (w, h) = m.vis.global_.fovy, size
    data = mujoco.MjData(m)

    def body_xpos(state):
        mujoco.mj_setState(m, data, np.asarray(state, dtype=float), spec)
        mujoco.mj_forward(m, data)
        return data.xpos.copy(), data.site(tm.ee_site).xpos.copy()

    # the objects: the goal object, a soft body that is not it, the distractors; each a list
    # of bodies (a soft body's vertices) whose mean is marked
    objects = [tm.goal_bodies]
    if tm.soft_body and tm.soft_body != tm.goal_object:
        f = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, tm.soft_body)
        objects.append([int(b) for b in m.flex_vertbodyid[
            m.flex_vertadr[f]:m.flex_vertadr[f] + m.flex_vertnum[f]]])
    objects += [[m.body(name).id] for name in tm.distractors]
    (x0, _), (x1, ee) = body_xpos(tm.initial_state), body_xpos(final_state)
    start = np.array([x0[b].mean(axis=0) for b in objects])
    end = np.array([x1[b].mean(axis=0) for b in objects])
    goal = np.asarray(tm.goal_position, dtype=float)
    # frame every object whole: each body +- its geoms' bounding radius along every axis
    bodies = np.concatenate(objects)
    radius = np.array([m.geom_rbound[m.geom_bodyid == b].max(initial=0.0) for b in bodies])
    box = (np.concatenate([x0[bodies], x1[bodies]])[:, None, :]
           + np.tile(radius, 2)[:, None, None] * np.concatenate([np.eye(3), -np.eye(3)]))
    # and the goal region (its marker, about a cylinder's size)
    region = goal + np.array([[x, y, z] for x in (-.06, .06) for y in (-.06, .06)
                              for z in (0.0, 0.12)])
    close = render.fit_camera(np.concatenate([box.reshape(-1, 3), region, [ee]]), *render.TOP,
                              fovy=fovy, aspect=w / h, fill=0.85, min_extent=0.3)
    arm = np.flatnonzero(np.isin(m.geom_bodyid, [m.body(b).id for b in tm.robot_bodies[:-1]]))
    top = render.render(m, final_state, spec, close, w, h, hide_geoms=arm)
    a, b = render.project(start, close, w, h, fovy), render.project(end, close, w, h, fovy)
    top = render.draw_segments(top, a, b, (20, 20, 20), 2.0)
    top = render.draw_markers(top, a[1:], (255, 255, 255), 7, "ring")
    top = render.draw_markers(top, a[:1], (20, 20, 20), 9, "ring", outline=(255, 255, 255))
    top = render.draw_markers(top, render.project(goal[None], close, w, h, fovy), (20, 20, 20),
                              7, "cross", outline=(255, 255, 255))
    whole = render.fit_camera(np.concatenate([x1[1:], [goal]]), *render.OBLIQUE, fovy=fovy,
                              aspect=w / h)
    return np.stack([top, render.render(m, final_state, spec, whole, w, h)])


#: a goal object tilted this far (degrees) from upright is said to be tipped over
TIPPED_DEG = 30.0


def goal_tilt(params: dict, final_state) -> float | None:
    """The angle (degrees) between a rigid goal object's z axis in ``final_state`` and the
    world's (a success counts the distance in the table's plane only, so a picture says
    whether the object stands); None for a soft goal object."""
    import mujoco

    from dopt.scene import Scene
    settings, seed, _ = split_params(params)
    tm = settings.build_task(seed)
    if tm.soft_body is not None and tm.soft_body == tm.goal_object:
        return None
    m = tm.model
    data = mujoco.MjData(m)
    mujoco.mj_setState(m, data, np.asarray(final_state, dtype=float), Scene(m).layout.spec)
    mujoco.mj_kinematics(m, data)
    zz = float(data.body(tm.goal_object).xmat[8])
    return float(np.degrees(np.arccos(np.clip(zz, -1.0, 1.0))))


def write_final(path: Path, task: str, row: str, r: dict) -> None:
    """final_<row>.png: ``final_panels`` side by side, titled with the method, seed, MPC cost,
    success, the final goal distance and whether the goal object stands (``goal_tilt``)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = final_panels(r["params"], r["final_state"])
    n, h, w = panels.shape[:3]
    top, gap, bottom = 56, 6, 30
    W, H = n * w + (n - 1) * gap, top + h + bottom
    fig = plt.figure(figsize=(W / 100, H / 100), dpi=100)
    for i, title in enumerate(("objects from above (arm hidden)", "whole scene")):
        ax = fig.add_axes((i * (w + gap) / W, bottom / H, w / W, h / H))
        ax.imshow(panels[i], interpolation="none")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title, fontsize=11, pad=3)
    tilt = goal_tilt(r["params"], r["final_state"])
    upright = "" if tilt is None else (
        f", goal object {'upright' if tilt < TIPPED_DEG else 'TIPPED OVER'} "
        f"(tilt {tilt:.0f} deg)")
    fig.suptitle(f"{task}: {row}, seed {r['seed']}, MPC cost {r['mpc_cost']:.3g}, "
                 f"{'success' if r['success'] else 'no success'}, goal distance "
                 f"{r['goal_distance_start']:.3f} -> {r['goal_distance_end']:.3f} m "
                 f"({r['steps']} steps){upright}", y=1 - 6 / H, fontsize=11,
                 fontweight="bold")
    fig.text(0.01, 6 / H, "ring: start of each object (black: the goal object, green), line: "
             "to its end; x and pale green disc: the goal region", ha="left", fontsize=10)
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def _save(fig, ax, path: Path, xlabel: str, ylabel: str, title: str) -> None:
    """Label, grid and legend one plot, write it to ``path`` and close it."""
    import matplotlib.pyplot as plt

    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=9)
    fig.tight_layout()
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
