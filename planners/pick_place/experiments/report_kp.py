"""The key-particle sections of RESULTS.md besides Fig. 7: the key particles of
each goal, the physics presets, the cloth step benchmarks and a CEM iteration against its
physical limit, and the Panda's execution.
"""

from __future__ import annotations

from pathlib import Path

from dopt.lab.report.base import Result, _finite, cell, clip, mm, num, pm, sci, section, table
from planners.bench.cem import SHARES
from planners.pick_place.experiments.report_paper import (
    family_note,
    scaling_families,
    scaling_key,
)


# ------------------------------------------------------------------------ physics presets
def physics_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        goals = list((d["rows"][0].get("scripted") or {}).keys()) if d["rows"] else []
        header = ["setting", "n", "ms / step", "steps / action", "unstable / 1000 actions",
                  "why", "strain p50 / p90 / max", "energy gain max (J/kg)",
                  *[f"scripted {g}" for g in goals]]
        rows = []
        for row in d["rows"]:
            sc = row.get("scripted") or {}
            setting = f"`{row['setting']}`"
            if row["setting"].startswith("preset:") and row.get("fields") is not None:
                setting += " (" + (", ".join(f"{k} {v:g}" if isinstance(v, float) else
                                             f"{k} {v}" for k, v in row["fields"].items())
                                   or "the config's defaults") + ")"
            if "picker_speed" in row:
                setting += f", picker {row['picker_speed']:g} m/s"
            rows.append([setting, str(row["n"]), num(row["cpu_ms_per_step"], 2),
                         str(row["steps_per_action"]),
                         num(row["unstable_per_1000_actions"], 0),
                         ", ".join(f"{k} {v}" for k, v in sorted(row["reasons"].items()))
                         or "-",
                         " / ".join(num(row[k], 2) for k in ("strain_p50", "strain_p90",
                                                              "strain_max")),
                         num(row["energy_gain_max"], 3) if "energy_gain_max" in row else "-",
                         *[mm(sc[g]["error_mm"] / 1e3) + (" !" if sc[g]["unstable"] else "")
                           for g in goals]])
        sizes = " and ".join(f"{n} x {n}" if d.get("bench") == "cloth" else str(n)
                             for n in d.get("sizes", []))
        seed = f", seed {d['seed']}" if "seed" in d else ""
        return [f"### {d.get('bench')} ({sizes}): {d.get('actions_per_setting')} random "
                f"actions per setting{seed}", "", *table(header, rows)]

    return section("Physics presets: `python -m planners.bench cloth|rope`",
                   "Per setting and size: CPU ms per simulated step (wall x threads / steps of "
                   "the random-action batch), steps per pick-and-place action, rollouts the "
                   "stability verdict flags per 1000 random actions (uniform displacements "
                   "within the picker bound, random particles, half from the flat start and "
                   "half after a fold) and why, the edge strain those actions reach (median / "
                   "90th percentile / max), the largest energy gain while nothing held the object "
                   "(the verdict's energy bound; `-` where the file does not record it), and the "
                   "scripted policy's error on each goal (mm; "
                   "`!` marks an executed plan the verdict flagged). Presets: the `preset:` "
                   "rows.", results, page, body,
                   key=lambda r: (r.data.get("bench", ""), r.data.get("sizes", [])))



# ------------------------------------------------------------ cloth step cost by size (KP)
def cloth_steps_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        def setting(row: dict) -> str:
            return row["preset"] + (f" + {row['variant']}" if row.get("variant") else "")

        rows = []
        for name in dict.fromkeys(setting(row) for row in r.data["rows"]):
            mine = [row for row in r.data["rows"] if setting(row) == name]
            small = min(mine, key=lambda row: row["n"])["ms_per_step"]["step"]
            for row in mine:
                ms = row["ms_per_step"]
                warned = {**row.get("warnings", {}),
                          **{clip(k, 60): v
                             for k, v in row.get("messages", {}).items()}}
                rows.append([name, f"{row['n']} x {row['n']}", num(ms["step"], 2),
                             num(ms["step"] / small if small else None, 1),
                             num(ms["collision"], 2), num(ms["constraint_solve"], 2),
                             num(ms["other"], 2), str(row["steps_per_action"]),
                             num(row["ms_per_action"], 0),
                             sci(row["flex_solve_residual_max"])
                             if "flex_solve_residual_max" in row else "not recorded",
                             "; ".join(f"{k} ({v})" for k, v in warned.items()) or "-"])
        return [f"### `{r.name}`", "",
                *table(["setting", "cloth", "ms / step", "vs smallest", "collision ms",
                        "constraint solve ms", "other ms (implicit solve)", "steps / action",
                        "ms / action", "flex solve residual (unconverged)",
                        "warnings (count)"], rows)]

    return section("Key particles: what a cloth step costs by resolution",
                   "`python -m dopt.bench cloth-steps`: one pick-and-place action per preset "
                   "and size, MuJoCo's own timers per step (collision, constraint solve, and the "
                   "rest of the step, which holds the discrete integrator's implicit solve), "
                   "the step against the smallest size's, the largest relative residual at "
                   "which the discrete integrator's flex solve (M + K) ran out of iterations, "
                   "among the messages MuJoCo printed (it prints a warning's text the first "
                   "times only; \"-\": none printed), and every warning MuJoCo raised "
                   "while the scene was built, settled and stepped. Variant rows change the "
                   "named fields of the preset (`dopt.bench.cloth_steps.VARIANTS`).",
                   results, page, body)


# ------------------------------------------------- a CEM iteration against its limit (KP)


def cem_limit_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = [[f"{row['n']} x {row['n']}", str(row["candidates"]), str(row["steps"]),
                 num(row["mj_step_ms"], 3), str(row["cores"]), num(row["limit_s"], 2),
                 num(row["iteration_s"], 2), num(row["ratio"], 2),
                 num(row["simulate_ratio"], 2), num(row.get("cpu_ratio"), 2),
                 *[num(row["shares"][k], 1, 100) for k in SHARES]]
                for row in d["rows"]]
        return [f"### `{r.name}`: {d.get('task')} {d.get('goal')}, protocol "
                f"{d.get('protocol')}, candidates {d.get('candidates')}, "
                f"{d.get('iterations')} iterations per size", "",
                *table(["cloth", "candidates", "steps / iteration", "ms / mj_step", "cores",
                        "limit s", "iteration s", "ratio", "simulation / limit",
                        "CPU / steps", *[f"{k} %" for k in SHARES]], rows)]

    return section("Key particles: a CEM iteration against its physical limit",
                   "`python -m planners.bench cem-limit`: per cloth size, CEM iterations of the "
                   "paper protocol's diagonal fold (its preset at that size) through the real "
                   "path, against the limit = the steps an iteration simulates (population x "
                   "horizon x steps per action) x one `mj_step` of that scene on one core "
                   "(the median CPU time, from a mid-action state) / the cores used; the "
                   "batched simulation alone against the limit; the process's CPU time against "
                   "the steps' own "
                   "(what a loaded machine's wall ratio hides); and where the iteration's time "
                   "goes (%): the batched simulation, the rollout service's own array building, "
                   "the stability verdict, the control rows' encoding, the cost, CEM's sampling "
                   "and refit, and the rest.", results, page, body)


# ------------------------------------------------ settle until at rest (KP, the bench)
def settle_rest_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = [[f"{row['n']} x {row['n']}", num(row["speed"], 3), num(row["settle_share"], 1, 100),
                 num(row["steps_saved"], 1, 100), num(row["wall_ratio"], 2),
                 *(num(row["cost_change_mm"][k], 2) for k in ("p50", "p90", "max")),
                 "yes" if row["same_elites"] else "no", f"{row['stable']} / {row['samples']}",
                 *(num(row["rms_speed_at_settle_end"][k], 3) for k in ("p10", "p50", "p90"))]
                for row in d["rows"]]
        return [f"### `{r.name}`: {d.get('task')} {d.get('goal')}, protocol "
                f"{d.get('protocol')}, {d.get('samples')} random sequences per size", "",
                *table(["cloth", "rest speed (m/s)", "settle % of steps", "steps saved %",
                        "wall / plain", "cost change p50 (mm)", "p90", "max", "same elites",
                        "stable", "RMS speed at settle end p10 (m/s)", "p50", "p90"], rows)]

    return section("Key particles: settling sampled rollouts until at rest",
                   "`python -m planners.bench settle`: per cloth size, random action sequences "
                   "of the paper protocol's diagonal fold simulated plainly (every sample every "
                   "step) and with the rest test of `dopt.tasks.pick.settle` at each speed (a "
                   "sample's settle ends once its particles' root-mean-square speed is below "
                   "it); the share of an action's steps that are its settle (all a rest test "
                   "can cut), the steps saved, the wall time against the plain rollout's in "
                   "the same run, the change in Eq. 2 over the samples stable in both, whether "
                   "CEM's elites are the same samples, and how fast the particles still move "
                   "when the plain settle ends.", results, page, body)


def _machine_words(mach: dict) -> str:
    """A recorded machine (``dopt.lab.provenance.machine()``) in words: its CPU model and cores."""
    return ", ".join(filter(None, [mach.get("cpu"), mach.get("cpus") and
                                   f"{mach['cpus']} cores"])) or "machine not recorded"


# ------------------------------------------------------ cloth step on MuJoCo Warp (KP)
def cloth_warp_section(results: list[Result], page: Path) -> list[str]:
    def warned(row: dict) -> str:
        """MuJoCo's warning counters over the CPU run of the action (its forward and steps)."""
        return "; ".join(f"{k} ({v})" for k, v in row["cpu"].get("warnings", {}).items()) \
            or "none"

    def body(r: Result) -> list[str]:
        rows, machines = [], {}
        for row in r.data["rows"]:
            mach = row["machine"]
            machines[f"{mach.get('warp_device')}, CPU {_machine_words(mach)}"] = mach
            cpu_ms = row["cpu"]["ms_per_step"]["step"]
            cpu_warned = warned(row)
            for w in row["warp"]:
                per_world = w.get("ms_per_world_step")
                failed = w.get("error", "")
                rows.append([
                    f"{row['n']} x {row['n']}", num(cpu_ms, 2), cpu_warned, str(w["nworld"]),
                    "yes" if w.get("cuda_graph") else ("no" if "cuda_graph" in w else "-"),
                    num(w.get("ms_per_step"), 2), num(per_world, 3),
                    num(cpu_ms / per_world if _finite(per_world) and per_world else None, 1),
                    num(w.get("first_step_s"), 1),
                    ", ".join(w.get("overflow_flags", [])) or ("none" if "overflow_flags" in w
                                                               else "-"),
                    f"{mm(w.get('gap_to_cpu_mean_m'), 2)} / {mm(w.get('gap_to_cpu_max_m'), 2)}",
                    f"{w.get('phase')}: {clip(failed, 90)}"
                    if failed else "-"])
        cpu_only = {row["n"]: (row["cpu"]["ms_per_step"]["step"], warned(row))
                    for row in r.data["rows"] if not row["warp"]}
        notes = [f"Machine: {name}" + (f"; every kernel module MuJoCo Warp registers compiled "
                                        f"on {m['preload_workers']} threads first in "
                                        f"{num(m['preload_s'], 1)} s" if "preload_s" in m
                                        else "") + "." for name, m in machines.items()]
        if cpu_only:
            notes.append("CPU step only (the run stopped before MuJoCo Warp stepped it): "
                         + ", ".join(f"{n} x {n} ({num(ms, 2)} ms / step, warnings: {w})"
                                     for n, (ms, w) in sorted(cpu_only.items())) + ".")
        return [f"### `{r.name}`", "", *notes, "",
                *table(["cloth", "CPU ms / step (one thread)", "CPU warnings (count)",
                        "worlds W", "CUDA graph",
                        "GPU ms / batched step", "GPU ms / world-step",
                        "world-steps per CPU step", "first step s (kernels compiled or loaded)",
                        "overflow flags", "world 0 vs CPU, mean / max (mm)", "failed"], rows)]

    return section("Key particles: a cloth step on MuJoCo Warp beside MuJoCo's CPU step",
                   "`python -m dopt.bench cloth-warp`: the action of `cloth-steps` stepped by "
                   "`mj_step` on one CPU thread and by MuJoCo Warp on W worlds in lockstep on "
                   "the same machine's GPU; world-steps per CPU step is the CPU step's time "
                   "over the GPU's time per world-step (what W worlds on the GPU give against "
                   "one core), the first step includes compiling the kernels it needs (or loading "
                   "them from warp's kernel cache), "
                   "overflow flags are MuJoCo Warp's (ITERATIONS: its solver stopped at its "
                   "iteration limit), and the last column the particle distance between "
                   "world 0 (float32) and the CPU run (float64) after the action.",
                   results, page, body)


# ------------------------------------------------------------------- Panda execution (KP)
def panda_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        rows = [[goal, str(e["n"]), pm(mm(e["picker_final_cost_mean"]),
                                        mm(e["picker_final_cost_ci95"])),
                 pm(mm(e["panda_final_cost_mean"]), mm(e["panda_final_cost_ci95"])),
                 pm(mm(e["difference_mean"]), mm(e["difference_ci95"])),
                 pm(mm(e["picker_vs_panda_mean"]), mm(e["picker_vs_panda_ci95"])),
                 mm(e["grasp_distance_max"]), mm(e["carry_error_max"]),
                 f"{e.get('missed_actions', 0)} / {e.get('n_actions', '?')}",
                 ("not judged" if "panda_unstable_seeds" not in e else
                  ", ".join(map(str, e["panda_unstable_seeds"])) or "none")]
                for goal, e in r.data["goals"].items()]
        return [f"### `{r.name}`" + (" (quick)" if r.quick else ""), "",
                *table(["goal", "seeds", "picker final cost (mm)", "Panda final cost (mm)",
                        "Panda - picker (mm)", "final cloths apart (mm)",
                        "worst grasp distance (mm)", "worst carry error (mm)",
                        "actions skipped (out of reach)", "unstable replays (seeds)"], rows)]

    return section("Key particles, Sec. IV-D: a Panda executes the plans",
                   "CEM(Simple) plans on the floating picker (the goal's preset), replayed "
                   "open-loop by a Franka Panda with a parallel gripper through inverse "
                   "kinematics and computed-torque control (`experiments/panda_execute.py`). "
                   "Final cost: mean particle distance to the goal, mean ± 95 % CI over the "
                   "seeds; the paired difference; the mean particle distance between the two "
                   "final cloths; the worst pinch-to-particle distance at a grasp and the worst "
                   "tracking error of the pinch while carrying; the actions the arm skipped "
                   "because its pinch did not reach the particle.", results, page, body)


def panda_headline(r: Result) -> str:
    return "; ".join(f"{goal}: picker {mm(e['picker_final_cost_mean'])} mm, Panda "
                     f"{mm(e['panda_final_cost_mean'])} mm, final cloths "
                     f"{mm(e['picker_vs_panda_mean'])} mm apart ({e['n']} seeds)"
                     for goal, e in r.data["goals"].items())


# ---------------------------------------------------------------------- key particles
def _short_task(task: str) -> str:
    return task.replace("_", " ")


def kp_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        paper = d.get("paper") or {}
        lines = [f"### Key particles: `{r.name}`" + (" (quick)" if r.quick else ""), "",
                 f"Cloth {d.get('cloth_particles_per_side')} x "
                 f"{d.get('cloth_particles_per_side')} particles; seed {d.get('seed')}.", ""]
        rows = []
        for task, e in (d.get("tasks") or {}).items():
            p = paper.get(task, {})
            inter = "; ".join(f"{_short_task(g.get('goal', '?'))}: {g.get('n_keys')} keys, "
                              f"{g.get('n_elements')} el." for g in e.get("intermediate_goals", []))
            rows.append([_short_task(task), str(e.get("particles", "?")), str(e.get("n_keys")),
                         str(p.get("keys", "-")), str(e.get("n_elements")),
                         str(p.get("triangles", "-")),
                         f"{mm(e.get('error'))} / {mm(e.get('threshold'))}",
                         num(e.get("seconds"), 2), " ".join(str(i) for i in e.get("indices", [])),
                         inter or "-"])
        lines += table(["goal", "particles", "key particles", "paper", "elements",
                        "paper triangles", "error / threshold (mm)", "s", "indices",
                        "intermediate goals"], rows)
        rob = d.get("robustness") or {}
        if rob.get("cloth_grid"):
            lines += ["", *kp_grid(rob["cloth_grid"])]
        if rob.get("noise"):
            lines += ["", *kp_noise(rob["noise"])]
        if rob.get("simulated"):
            lines += ["", *kp_simulated(rob["simulated"])]
        return lines

    return section("Key particles, Fig. 4 and Sec. IV-C.1: key particles of each goal",
                   "Alg. 1 on each goal: the simplified model's elements (rope: segments; cloth: "
                   "triangles), its key particles, its error and threshold (cloth: in the "
                   "z-stretched space) and the wall time; paper: the counts the paper reports.",
                   results, page, body)


def kp_grid(rows: list[dict]) -> list[str]:
    """Key counts of the noise-free cloth goals: goal x resolution, one count per
    triangulation."""
    tris = list(dict.fromkeys(r.get("triangulation") for r in rows))
    cells: dict = {}
    for r in rows:
        k = "fail" if r.get("n_keys") is None else str(r["n_keys"])
        cells.setdefault((r.get("task"), r.get("n")), {})[r.get("triangulation")] = k
    out = ["Cloth key counts by resolution (particles per side), one per triangulation ("
           + " / ".join(map(str, tris)) + "):", ""]
    ns = sorted({r.get("n") for r in rows}, key=lambda n: (n is None, n))
    tasks = list(dict.fromkeys(r.get("task") for r in rows))
    return out + table(["goal", *[str(n) for n in ns]],
                       [[_short_task(t), *[" / ".join(cells.get((t, n), {}).get(x, "-")
                                                      for x in tris) for n in ns]]
                        for t in tasks])


def kp_noise(noise: dict) -> list[str]:
    """Goals whose key count equals the noise-free one, per kind and noise level."""
    sigmas = list(dict.fromkeys(s for cells in noise.values() for s in cells))
    return (["Goals whose key count held under Gaussian goal noise (sigma):", ""]
            + table(["goals", *sigmas],
                    [[kind, *[cells.get(s, "-") for s in sigmas]]
                     for kind, cells in noise.items()]))


def kp_simulated(rows: list[dict]) -> list[str]:
    """Key counts of the goals the simulator made (each fold by a line grasp, settled)."""
    out = ["Goals made by the simulator: each fold made on the MuJoCo cloth (physics preset as "
           "given, self-collision on) by a line grasp of the moving part's far edge turned over "
           "its crease (`dopt.tasks.pick.fold_goals`; the underneath fold as the accordion of "
           "three folds on top that makes the same stack), settled; the reduction gets the "
           "settled positions, the flex's triangles and the settled flat start as rest sheet. "
           "Fold error: mean / largest particle distance to the rigid fold with sharp creases "
           "(`ideal_folds`); `!` marks a folding the stability verdict flagged. Keys and faces "
           "under the default panel projection and under `ClothConfig(panels=\"fold\")` "
           "(every particle onto its panel); `*`: no model up to 40 faces reached the "
           "threshold.", ""]
    body = []
    for r in rows:
        if "error" in r:
            body.append([_short_task(r["task"]), str(r["n"]), r.get("physics", "-"), "-", "-",
                         str(r["reference_keys"]), "failed: " + cell(r["error"]), "-", "-", "-"])
            continue

        def keys(k: dict) -> str:
            return f"{k['n_keys']}{'' if k['reached_threshold'] else '*'}"

        fold = r["fold"]
        body.append([_short_task(r["task"]), str(r["n"]), r["physics"],
                     f"{num(r['fold_error_mm'], 1)} / {num(r['fold_error_max_mm'], 1)}"
                     + (" !" if r["unstable"] else ""),
                     "none found" if r["layer_gap_mm"] is None else num(r["layer_gap_mm"], 2),
                     str(r["reference_keys"]), keys(r), keys(fold),
                     f"{r['n_elements']} / {fold['n_elements']}",
                     " / ".join(str(k) for k in fold["n_keys_by_merge_deg"].values())])
    angles = next((" / ".join(r["fold"]["n_keys_by_merge_deg"]) for r in rows
                   if "fold" in r), "")
    return out + table(["goal", "n", "physics", "fold error (mm)", "layer gap (mm)",
                        "reference keys", "keys", "keys (fold)", "faces (default / fold)",
                        f"keys (fold), merge angle {angles} deg"], body)


def kp_headline(r: Result) -> str:
    tasks = r.data.get("tasks") or {}
    paper = r.data.get("paper") or {}
    parts = []
    for task, e in tasks.items():
        p = paper.get(task, {})
        cloth = task.startswith("cloth")
        text = f"{_short_task(task)} {e.get('n_keys')}" + (
            f" keys / {e.get('n_elements')} triangles" if cloth else "")
        ref = p.get("triangles") if cloth else p.get("keys")
        if ref is not None:
            text += f" (paper {ref}{' triangles' if cloth else ''})"
        parts.append(text)
    return "; ".join(parts)


def _histogram_text(counts: dict) -> str:
    """{value: goals} as "value (goals), ..." ("4 (all)" when one value)."""
    if len(counts) == 1:
        return f"{next(iter(counts))} (all)"
    return ", ".join(f"{k} ({v})" for k, v in counts.items())


def kp_compare_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for name, levels in d["summary"].items():
            for level, folds in levels.items():
                sigma = float(level.removeprefix("noise_"))
                for task, c in folds.items():
                    same = c.get("counts_as_first")
                    rows.append([name, _short_task(task), f"{sigma * 1e3:g}",
                                 f"{c['keys_held']} / {c['goals']}",
                                 f"{c['reached_threshold']} / {c['goals']}",
                                 "-" if same is None else f"{same} / {c['goals']}",
                                 _histogram_text(c["faces"]), _histogram_text(c["keys"]),
                                 num(c["median_seconds"], 2)])
        return [f"Resolutions {', '.join(map(str, d['resolutions']))} per side; triangulations "
                f"{', '.join(d['triangulations'])}; noise 0 and {d['noise_m'] * 1e3:g} mm.", "",
                *table(["pipeline", "fold", "noise (mm)", "reference keys", "threshold reached",
                        "faces and keys as default", "faces (goals)", "keys (goals)",
                        "median s"], rows)]

    return section("Key particles: the paper's pipeline against the default",
                   "`python -m deformables.bench compare`: the same cloth goals (four folds x "
                   "resolutions x four triangulations, exact and with Gaussian noise) reduced by "
                   "`ClothConfig()`, by `ClothConfig.paper()` (one-sided Hausdorff distance in "
                   "metres, one decimation per size from the goal, no restarts, no panel "
                   "projection, no re-triangulation) and, where recorded, by the default with "
                   "each restart decimating the goal itself (`shared_faces=None`, "
                   "separate-restarts). Per fold and noise level: goals whose key count is the "
                   "reference (diagonal 4, side 6, reflective 8, underneath 10), goals whose "
                   "reduction reached its threshold, goals with the default's face and key "
                   "counts, the face and key counts seen (goals), and the median seconds per "
                   "goal.", results, page, body)


def kp_paper_scale_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = [[_short_task(g["task"]), str(g["particles"]), f"{g['noise_m'] * 1e3:g}",
                 f"{g['n_keys']} ({g['reference_keys']})", str(g["n_elements"]),
                 "yes" if g["reached_threshold"] else "no", num(g["seconds"], 2)]
                for g in d["goals"]]
        where = _machine_words(d["provenance"].get("machine", {}))
        stick = d.get("yardstick")
        measure = ([f"Yardstick of the machine, timed in the same run before and after the "
                    f"folds: {stick[0]['what']} ({stick[0]['faces']} to "
                    f"{stick[0]['target_faces']} faces), "
                    f"{' and '.join(num(x['seconds'], 3) for x in stick)} s; the ratio to it "
                    f"compares runs on different machines, the paper's seconds do not.", ""]
                   if stick else [])
        return [f"{d['cloth_n']} x {d['cloth_n']} particles, {d['repeats']} timed run(s) "
                f"per goal, on {where} (the paper's on a Xeon E5-2650).", "",
                *table(["fold", "particles", "noise (mm)", "keys (reference)", "faces",
                        "threshold reached", "s"], rows), "", *measure,
                *table(["noise (mm)", "mean s over the folds", "paper s", "ratio",
                        "ratio to the yardstick", "reference keys"],
                       [[f"{float(k.removeprefix('noise_')) * 1e3:g}",
                         num(v["mean_seconds"], 2), num(v["paper_seconds"], 2),
                         num(v["ratio_to_paper"], 2),
                         num(v["ratio_to_yardstick"], 2) if "ratio_to_yardstick" in v else "-",
                         f"{v['keys_held']} / 4"]
                        for k, v in d["summary"].items()])]

    return section("Key particles at the paper's resolution",
                   "`python -m deformables.bench paper-scale`: the four cloth folds at the "
                   "paper's cloth size, MuJoCo's triangulation, the default pipeline, without "
                   "noise and with Gaussian noise; seconds per reduction (median of the repeats) "
                   "against the paper's 0.73 s average.", results, page, body)




def kp_authors_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d, s = r.data, r.data["summary"]
        rows = [[_short_task(g["task"]), str(g["particles"]), g["triangulation"],
                 f"{g['n_elements']} ({g['paper_elements']})",
                 f"{g['n_keys']} ({g['reference_keys']})", ", ".join(map(str, g["keys"])),
                 ", ".join(map(str, g["authors_keys"])), "yes" if g["keys_agree"] else "no",
                 "yes" if g["reached_threshold"] else "no", num(g["seconds"], 2)]
                for g in d["goals"]]
        where = _machine_words(d["provenance"].get("machine", {}))
        return [f"{s['goals']} goals, {d['repeats']} timed run(s) each, on {where}: the paper's "
                f"triangle count on {s['paper_elements_held']}, its key count on "
                f"{s['keys_held']}, keys within 0.05 m of the authors' (both ways) on "
                f"{s['keys_agree']}; mean {num(s['mean_seconds'], 2)} s per reduction against "
                f"the paper's {num(s['paper_seconds'], 2)} s on a Xeon E5-2650 (ratio "
                f"{num(s['ratio_to_paper'], 2)})"
                + (f"; {num(s['ratio_to_yardstick'], 2)} times the yardstick of the machine "
                   f"timed in the same run ({d['yardstick'][0]['what']}, "
                   f"{' and '.join(num(x['seconds'], 3) for x in d['yardstick'])} s)"
                   if "yardstick" in d else "") + ".", "",
                *table(["fold", "particles", "triangulation", "faces (paper)",
                        "keys (reference)", "our keys", "the authors' keys (before their filter)",
                        "keys agree", "threshold reached", "s"], rows)]

    return section("Key particles on the authors' own goals",
                   "`python -m deformables.bench authors`: the key-particle paper's authors' "
                   "diagonal and side folds (their SoftGym / FleX goals, float32, from their "
                   "repository; not part of this project) in each triangulation of their grid, "
                   "the default pipeline; keys agree when each of ours lies within the authors' "
                   "0.05 m filter radius of one of theirs on the flat sheet and each of theirs "
                   "within it of one of ours.", results, page, body)


# ------------------------------------------------------------ CEM(Random)'s candidate sets
def random_reach_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        rows = []
        for run in r.data["runs"]:
            s, means = run["summary"], run["mean_final_cost"]
            rho = "-" if s["spearman_rho"] is None else \
                f"{num(s['spearman_rho'])} (p {sci(s['spearman_p'])})"
            rows.append([f"{run['task']} {run['goal']} ({run['n']} per side)", str(s["trials"]),
                         rho, f"{s['blind']} (expected {num(s['blind_expected'])}; chance of "
                         f"as many {num(s.get('p_blind_at_least'), 3)})",
                         mm(s["cost_blind"]), mm(s["cost_seeing"]), mm(means.get("random")),
                         mm(means.get("original")), mm(means.get("simple"))])
        return [f"### `{r.name}`", "", f"Threshold: {mm(r.data['moving'])} mm.", "",
                *table(["fold", "Random trials", "Spearman rho of cost and reach",
                        "blind trials", "Random, blind (mm)", "Random, seeing (mm)",
                        "Random (mm)", "Original (mm)", "Simple (mm)"], rows)]

    return section("Key particles, Fig. 7: what CEM(Random)'s candidates can reach",
                   "Each CEM(Random) trial's candidate set re-drawn from its seed "
                   "(`experiments/random_reach.py`, nothing simulated; a test checks that every "
                   "recorded pick is among them). Reach: the largest distance a candidate must "
                   "move in its stage over the largest of all particles (the smallest over "
                   "stages); blind: a stage none of whose candidates moves more than "
                   "the file's threshold; expected: the hypergeometric chance summed over "
                   "trials. "
                   "Costs: mean final cost (mean particle distance to the goal).",
                   results, page, body)


# ----------------------------------------------------- the gain against the particle count
def scaling_section(results: list[Result], page: Path) -> list[str]:
    files, family = scaling_families(results)

    def across(goal: str, key: str) -> str:   # the verdict of every fold's tests together
        return family_note(family.get((goal, key)))

    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for n, count in zip(d["sizes"], d["n_particles"], strict=True):
            e = d["per_size"][str(n)]
            methods = e["methods"]
            rows.append([f"{n} x {n}", str(count),
                         *(pm(mm((methods.get(m) or {}).get("final_cost_mean")),
                              mm((methods.get(m) or {}).get("final_cost_ci95")))
                           + f" ({(methods.get(m) or {}).get('n', 0)})"
                           for m in ("simple", "original", "random")),
                         *(pm(mm((e.get(f"{m}_minus_simple") or {}).get("mean")),
                              mm((e.get(f"{m}_minus_simple") or {}).get("ci95")))
                           for m in ("original", "random"))])
        trends = [f"- {key.replace('_minus_simple', '')} - simple: slope "
                  f"{pm(mm(t['slope']), mm(t.get('slope_ci95')))} mm per unit of log N "
                  f"(95 % interval), Holm p "
                  f"{num(t.get('p_holm'), 3)}, {t['n_points']} paired seeds over "
                  f"{t['n_sizes']} sizes: **{t['verdict']}**{across(scaling_key(r), key)}"
                  for key, t in d["trend"].items()]
        trends += [f"- normalised by the flat sheet's cost, {key.replace('_minus_simple', '')}"
                   f" - simple: slope {pm(num(t['slope'], 3), num(t.get('slope_ci95'), 3))} "
                   f"per unit of log N, Holm p {num(t.get('p_holm'), 3)}: **{t['verdict']}**"
                   for key, t in (d.get("trend_normalised") or {}).items()
                   if t.get("slope") is not None]
        image = page.parent / "images" / f"{r.path.stem}.png"
        figure = ([f"![Final cost and the gaps to CEM(Simple) against the particle count, "
                   f"{d['goal']} fold, 95 % intervals](images/{image.name})", ""]
                  if image.exists() else [])   # the experiment's scaling.png, beside the docs
        return [f"### {scaling_key(r)}: `{r.name}`", "", *figure,
                f"Protocol {d.get('protocol')}, physics preset `{d.get('physics_preset')}` at "
                f"every size; final cost (mm) mean ± 95 % CI (seeds).", "",
                *table(["cloth", "particles N", "CEM(Simple)", "CEM(Original)", "CEM(Random)",
                        "Original - Simple", "Random - Simple"], rows),
                "", *trends]

    return section("Key particles: the gain against the particle count",
                   "`python experiments/fig7_scaling.py`: CEM(Simple), CEM(Original) and "
                   "CEM(Random) on one fold at several particle counts N, the paper's CEM "
                   "budget and one physics preset throughout. What varies: by default the "
                   "resolution of a sheet of one size (a finer sheet: a uniform particle is "
                   "a uniform point at any N under our pick-and-place macros); with `--mode "
                   "size` the sheet grows at the 20 x 20 preset's spacing, as SoftGym's does "
                   "(files marked \"at fixed spacing\"); the drag encoding, where N enters the "
                   "action itself, is `fig7_encoding.py`. Trend: the least-squares slope of "
                   "each seed's paired difference (method - Simple) against log N, its 95 % "
                   "interval, and the p-value Holm-adjusted over the two comparisons (with "
                   "several folds recorded, also over all their tests as one family); a "
                   "positive slope means Simple's gain grows with the particle count. The "
                   "paper (Sec. V) says the improvement of the reduced action space over the "
                   "original grows with the number of particles, shown on cloths far larger "
                   "than these; each verdict below is this test's over the sizes its file "
                   "holds.",
                   results, page, body)
