"""The pictures of a Fig. 7 run (``fig7``): curves.csv and cost_curves.png (best cost per CEM
iteration, mean and 95 % band over the seeds), and for the first seed of each method
goal_vs_<method>.png (goal | result from above and obliquely, key and picked particles marked)
and plan_<method>.gif (the executed plan replayed). The MuJoCo-only image making is
``dopt.render``; this module composes, labels and writes the pictures.
"""

from __future__ import annotations

import csv
import logging
from pathlib import Path

import numpy as np

from dopt import atomic
from dopt.lab.stats import mean_ci
from planners.pick_place import LABELS, make_problem

log = logging.getLogger(__name__)
COLOURS = {"simple": "tab:blue", "original": "tab:red", "random": "tab:green",
           "scripted": "tab:gray"}


def write_curves(path: Path, results: list) -> None:
    """CSV: method, seed, iteration, stage, best_cost_m (scripted: one row per stage)."""
    with atomic.writing(path) as tmp, open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["method", "seed", "iteration", "stage", "best_cost_m"])
        for r in sorted(results, key=lambda r: (r["method"], r["seed"])):
            rows = zip(r["cost_history"], r["stage_of_iteration"], strict=True)
            for i, (c, s) in enumerate(rows):
                w.writerow([r["method"], r["seed"], i + 1, s, f"{c:.6g}"])


def plot_curves(path: Path, results: list, methods, title: str) -> None:
    """Fig. 7-style plot: best cost per CEM iteration, mean and 95 % CI band over the seeds;
    the scripted policy as a dashed line at its mean final cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    n_iter = 1
    for m in methods:
        runs = sorted((r for r in results if r["method"] == m), key=lambda r: r["seed"])
        if not runs or m == "scripted":
            continue
        curves = np.array([r["cost_history"] for r in runs]) * 1e3          # (seeds, I)
        x = np.arange(1, curves.shape[1] + 1)
        n_iter = max(n_iter, len(x))
        stats_ = [mean_ci(c) for c in curves.T]
        mean = np.array([s[0] for s in stats_])
        ci = np.nan_to_num(np.array([s[1] for s in stats_]))
        ax.plot(x, mean, color=COLOURS[m], label=LABELS[m])
        ax.fill_between(x, mean - ci, mean + ci, color=COLOURS[m], alpha=0.2)
        stages = np.asarray(runs[0]["stage_of_iteration"])
        for b in np.flatnonzero(np.diff(stages)) + 1.5:
            ax.axvline(b, color="k", lw=0.5, ls=":")
    scripted_runs = [r for r in results if r["method"] == "scripted"]
    if "scripted" in methods and scripted_runs:
        ax.axhline(np.mean([r["final_cost"] for r in scripted_runs]) * 1e3,
                   color=COLOURS["scripted"], ls="--", label=LABELS["scripted"] + " (final)")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.set_xlabel("CEM iteration")
    ax.set_ylabel("best cost: mean particle distance to goal (mm)")
    ax.set_title(title)
    ax.set_xlim(1, max(n_iter, 2))
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:          # nothing to label when every trial failed
        ax.legend()
    fig.tight_layout()
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


#: pixels of one view of the goal-vs-result figure, and of one frame of the plan GIF
VIEW_SIZE = (640, 480)
GIF_SIZE = (320, 240)
#: most rendered frames of a plan GIF (its last frame is then held for GIF_HOLD frames)
GIF_FRAMES = 120
GIF_HOLD = 20
GIF_MS_PER_FRAME = 70
#: marker colours (RGB): key particles of the last stage, picked particles, the goal
KEY_COLOUR, PICKED_COLOUR, ERROR_COLOUR = (255, 210, 0), (0, 235, 255), (20, 20, 20)
OUTLINE_COLOUR = (230, 0, 230)
#: the floor's opacity in the views from above
FLOOR_ALPHA_FROM_ABOVE = 0.6


def render_report(out: Path, problem, results: list, methods, problem_seed: int = 0) -> None:
    """goal_vs_<method>.png (goal | result, from above and obliquely, key and picked particles
    marked) and plan_<method>.gif (the executed plan replayed) of the first seed of each
    method. ``problem`` is the problem of seed ``problem_seed`` (another seed's is rebuilt:
    the crumpled rope's start depends on it). A rendering failure (no OpenGL) is logged, not
    raised: the numbers are already written."""
    try:
        for m in methods:
            runs = sorted((r for r in results if r["method"] == m), key=lambda r: r["seed"])
            if not runs:
                continue
            r = runs[0]
            p = problem if r["seed"] == problem_seed else make_problem(problem.settings,
                                                                        r["seed"])
            write_comparison(out / f"goal_vs_{m}.png", p, r)
            write_plan_gif(out / f"plan_{m}.gif", p, r)
    except Exception as e:
        log.warning("rendering failed (%s: %s); set MUJOCO_GL=egl", type(e).__name__, e)


def _title(problem, r: dict) -> str:
    return (f"{problem.settings.task} {problem.settings.goal}: {LABELS[r['method']]}, seed "
            f"{r['seed']}, final cost {r['final_cost'] * 1e3:.1f} mm")


def _picked(r: dict) -> np.ndarray:
    """(M,) the particles the executed plan picked (None actions left out)."""
    return np.array(sorted({int(i) for a in r["actions"] for i in a["particles"] if i >= 0}),
                    dtype=int)


def _hidden(scene) -> list[int]:
    """The picker's geom: from above it would cover the middle of the object."""
    import mujoco
    g = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_GEOM, "picker")
    return [g] if g >= 0 else []


def comparison_panels(problem, r: dict, size=VIEW_SIZE) -> np.ndarray:
    """(2 views (top, oblique), 2 (goal, result), H, W, 3) images of one trial, each view's
    camera fitted to the goal and the result together (from above the floor is see-through:
    rope or cloth pushed under it shows faded); key particles of the last stage as gold
    dots, picked particles as cyan rings, and on the result the goal's outline (magenta) and a
    black line from each key particle to its goal (a black x)."""
    import mujoco

    from dopt import render

    scene = problem.scene
    m, spec = scene.model, scene.scene.layout.spec
    fovy, (w, h) = m.vis.global_.fovy, size
    goal = problem.final_goal
    final_state = np.asarray(r["final_state"], dtype=float)
    result = scene.positions(final_state)
    keys, picked = problem.stages[-1].keys, _picked(r)
    goal_state = scene.with_positions(scene.initial_state, goal)
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    radius = max(4.0, w / 110)
    panels = np.empty((2, 2, h, w, 3), dtype=np.uint8)
    for v, view in enumerate((render.TOP, render.OBLIQUE)):
        cam = render.fit_camera(np.concatenate([goal, result]), *view, fovy=fovy, aspect=w / h)
        # from above the floor is see-through, showing what a plan pushed under it
        alpha = {floor: FLOOR_ALPHA_FROM_ABOVE} if v == 0 and floor >= 0 else None
        images = render.render_states(m, np.stack([goal_state, final_state]), spec, cam, w, h,
                                      hide_geoms=_hidden(scene), geom_alpha=alpha,
                                      shadow_size=2048)                   # (2, H, W, 3)
        goal_mask = render.object_mask(render.render(
            m, goal_state, spec, cam, w, h, hide_geoms=_hidden(scene), segmentation=True))
        for c, pos in enumerate((goal, result)):
            img = images[c]
            px = render.project(pos, cam, w, h, fovy)
            if c == 1:
                img = img.copy()
                img[render.mask_outline(goal_mask, max(2, w // 320))] = OUTLINE_COLOUR
                target = render.project(goal[keys], cam, w, h, fovy)
                img = render.draw_segments(img, px[keys], target, ERROR_COLOUR, 2.0)
                img = render.draw_markers(img, target, ERROR_COLOUR, radius, "cross",
                                          outline=(255, 255, 255))
            img = render.draw_markers(img, px[picked], PICKED_COLOUR, radius + 4, "ring")
            panels[v, c] = render.draw_markers(img, px[keys], KEY_COLOUR, radius, "dot")
    return panels


def write_comparison(path: Path, problem, r: dict) -> None:
    """The goal-vs-result figure of one trial (``comparison_panels``) at one image pixel per
    screen pixel, with its title and a legend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    panels = comparison_panels(problem, r)
    rows, cols, h, w = panels.shape[:4]
    left, top, bottom, gap = 28, 62, 34, 6                                  # pixels
    W, H = left + cols * w + (cols - 1) * gap, top + rows * h + (rows - 1) * gap + bottom
    fig = plt.figure(figsize=(W / 100, H / 100), dpi=100)
    for i in range(rows):
        for j in range(cols):
            ax = fig.add_axes(((left + j * (w + gap)) / W,
                               1 - (top + i * (h + gap) + h) / H, w / W, h / H))
            ax.imshow(panels[i, j], interpolation="none")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(("goal" if j == 0 else "result of the executed plan"),
                             fontsize=12, pad=4)
            if j == 0:
                ax.set_ylabel(("from above (floor see-through)", "oblique")[i], fontsize=11)
    n_stages = len(problem.stages)
    n_picks = sum(int(i) >= 0 for a in r["actions"] for i in a["particles"])
    fig.suptitle(_title(problem, r) + (f" ({n_stages} stages)" if n_stages > 1 else ""),
                 y=1 - 8 / H, fontsize=14, fontweight="bold")
    handles = [
        Line2D([], [], ls="", marker="o", ms=8, mfc=np.array(KEY_COLOUR) / 255, mec="k",
               label=f"key particles ({len(problem.stages[-1].keys)}, last stage)"),
        Line2D([], [], ls="", marker="o", ms=12, mfc="none", mew=2.5,
               mec=np.array(PICKED_COLOUR) / 255,
               label=f"picked particles ({len(_picked(r))}; {n_picks} picks)"),
        Line2D([], [], color="k", marker="x", ms=8, lw=1.5,
               label="key particle -> its goal position"),
        Line2D([], [], color=np.array(OUTLINE_COLOUR) / 255, lw=2.5, label="goal outline"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, frameon=False, fontsize=11,
               bbox_to_anchor=(0.5, 0.0))
    with atomic.writing(path) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def plan_frames(problem, r: dict, size=GIF_SIZE, max_frames: int = GIF_FRAMES) -> tuple:
    """The executed plan of one trial replayed (``dopt.tasks.pick.replay``) and rendered
    obliquely: (F, H, W, 3) frames with the goal's outline (magenta), the goal positions of
    the last stage's key particles (black x) and the key particles (gold), the replay, and the
    cost (m) of each frame."""
    from dopt import render
    from dopt.tasks.pick.replay import replay
    from dopt.tasks.pick.scene import mean_distance

    scene = problem.scene
    m, spec = scene.model, scene.scene.layout.spec
    fovy, (w, h) = m.vis.global_.fovy, size
    rep = replay(scene, problem.start_state, r["actions"], max_frames)
    pos = scene.positions(rep.states)                                       # (F, N, 3)
    goal, keys = problem.final_goal, problem.stages[-1].keys
    # frame the start, the goal and whatever of the motion stays near them: an object flung
    # far away leaves the frame instead of shrinking every frame to a dot
    core = np.concatenate([pos[0], goal])
    centre = 0.5 * (core.min(axis=0) + core.max(axis=0))
    reach = 1.5 * np.linalg.norm(core - centre, axis=1).max() + 0.05
    moving = pos.reshape(-1, 3)
    moving = moving[np.linalg.norm(moving - centre, axis=1) <= reach]
    cam = render.fit_camera(np.concatenate([core, moving]), *render.OBLIQUE, fovy=fovy,
                            aspect=w / h)
    frames = render.render_states(m, rep.states, spec, cam, w, h)
    goal_state = scene.with_positions(scene.initial_state, goal)
    outline = render.mask_outline(render.object_mask(render.render_states(
        m, goal_state, spec, cam, w, h, hide_geoms=_hidden(scene), segmentation=True)[0]), 1)
    target = render.project(goal[keys], cam, w, h, fovy)
    out = np.empty_like(frames)
    for f, (img, p) in enumerate(zip(frames, pos, strict=True)):
        img = img.copy()
        img[outline] = OUTLINE_COLOUR
        img = render.draw_markers(img, target, ERROR_COLOUR, 3.5, "cross", outline=None)
        out[f] = render.draw_markers(img, render.project(p[keys], cam, w, h, fovy),
                                     KEY_COLOUR, 3.5, "dot")
    return out, rep, mean_distance(pos, goal)


def write_plan_gif(path: Path, problem, r: dict) -> None:
    """An animated GIF of the executed plan with a caption per frame (method, seed, final
    cost; stage, action and the cost so far); the last frame is held."""
    import imageio.v3 as iio
    from PIL import Image, ImageDraw

    frames, rep, costs = plan_frames(problem, r)
    if abs(costs[-1] - r["final_cost"]) > 1e-3:     # e.g. a trial file with rounded actions
        log.warning("%s seed %d: the replayed plan ends at %.1f mm, the trial at %.1f mm; the "
                    "GIF shows the replay", r["method"], r["seed"], costs[-1] * 1e3,
                    r["final_cost"] * 1e3)
    font, small = _font(12), _font(11)
    n_stages = len(problem.stages)
    dt = problem.scene.model.opt.timestep
    title = (f"{problem.settings.goal}: {LABELS[r['method']]}, seed {r['seed']}, "
             f"final {r['final_cost'] * 1e3:.1f} mm")
    bar = 48
    captioned = []
    for f, img in enumerate(frames):
        canvas = Image.new("RGB", (img.shape[1], img.shape[0] + bar), "white")
        canvas.paste(Image.fromarray(img), (0, bar))
        draw = ImageDraw.Draw(canvas)
        stage, action = rep.stage[f], rep.action[f]
        particles = r["actions"][stage]["particles"]
        where = (f"stage {stage + 1}/{n_stages}, " if n_stages > 1 else "") \
            + f"action {action + 1}/{len(particles)}: " \
            + (f"pick {particles[action]}" if particles[action] >= 0 else "no pick")
        for k, (text, ft, colour) in enumerate((
                (title, font, "black"), (where, small, (50, 50, 50)),
                (f"t = {rep.step[f] * dt:.2f} s, cost now {costs[f] * 1e3:.1f} mm", small,
                 (50, 50, 50)))):
            draw.text((4, 1 + 15 * k), text, fill=colour, font=ft)
        captioned.append(np.asarray(canvas))
    captioned += [captioned[-1]] * GIF_HOLD
    with atomic.writing(path) as tmp:
        iio.imwrite(tmp, np.stack(captioned), duration=GIF_MS_PER_FRAME, loop=0)


def _font(size: int):
    """matplotlib's DejaVu Sans at ``size`` points for PIL (PIL's default bitmap font if that
    fails)."""
    from PIL import ImageFont
    try:
        from matplotlib import font_manager
        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
    except Exception:
        return ImageFont.load_default()
