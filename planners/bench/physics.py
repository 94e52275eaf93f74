"""python -m planners.bench cloth|rope: the physics presets measured, setting by setting.

Per setting (scene-config overrides) and size: CPU ms per simulated step (wall x threads /
steps, from the random-action batch), steps per pick-and-place action, unstable rollouts per
1000 random actions (``dopt.stability`` verdict; bounded displacements, random particles, from
the flat start and from a folded one), the strain percentiles and the energy gain while nothing
holds the object those actions reach, and the
scripted policy's error on the task's goals (Fig. 7 protocol, one trial each) with its
verdict. Lives in planners.bench, not dopt.bench, because the scripted folds need the goals
(deformables) and the scripted policy (planners).
"""

from __future__ import annotations

import time
from dataclasses import fields, replace

import numpy as np

from dopt.lab.provenance import provenance
from dopt.rollout import RolloutConfig, RolloutService
from dopt.tasks.pick.picker import CONTROL_SPEC, PickerConfig
from planners.pick_place import (
    GOALS,
    PickPlaceSettings,
    ScriptedPlanner,
    make_problem,
    pick_task,
    run_problem,
)


def grid(**fields) -> dict:
    """Scene overrides on MuJoCo's own grid triangulation ("mujoco"), which the default sheet
    does not use."""
    return {"triangulation": "mujoco", **fields}


#: the settings the sweep compares: name -> scene-config overrides (on top of the config's
#: defaults, or of the physics preset named by their "physics" key); "preset:<name>" entries
#: are the named presets themselves
CLOTH_SETTINGS = {
    "preset:fast": None, "preset:default": None, "preset:accurate": None,
    "E5e4 dt.02 CG30": grid(young=5e4, timestep=0.02, solver="CG", iterations=30),
    "E2e5 dt.02 CG30": grid(young=2e5, timestep=0.02, solver="CG", iterations=30),
    "E1e6 dt.02 CG30": grid(young=1e6, timestep=0.02, solver="CG", iterations=30),
    "E1e6 dt.01 CG30": grid(young=1e6, timestep=0.01, solver="CG", iterations=30),
    "E1e6 dt.02 Newton": grid(young=1e6, timestep=0.02, solver="Newton", iterations=30),
    "E1e6 dt.02 CG30 damp.01": grid(young=1e6, timestep=0.02, solver="CG", iterations=30,
                                    damping=0.01),
    "E1e6 dt.02 CG30 selfcollide": grid(young=1e6, timestep=0.02, solver="CG", iterations=30,
                                        selfcollide=True),
    # the 4.0 guide's range starts at 1-4 ms; 5 ms is the largest step at which the scripted
    # folds of 16 x 16 sheets of 1e5-5e5 Pa stayed unflagged in a first look
    "E5e4 dt.005 CG30": grid(young=5e4, timestep=0.005, solver="CG", iterations=30),
    "E1e5 dt.005 CG30": grid(young=1e5, timestep=0.005, solver="CG", iterations=30),
    "E2e5 dt.005 CG30": grid(young=2e5, timestep=0.005, solver="CG", iterations=30),
    "E5e5 dt.005 CG30": grid(young=5e5, timestep=0.005, solver="CG", iterations=30),
    "E5e5 dt.005 CG30 selfcollide": grid(young=5e5, timestep=0.005, solver="CG", iterations=30,
                                         selfcollide=True),
    # a stiffer sheet at half the step: the scripted folds of 20 x 20 and 25 x 25 sheets stay
    # unflagged on the diagonal and side goals in a first look, where the default's are not
    "E1e5 dt.01 CG30": grid(young=1e5, timestep=0.01, solver="CG", iterations=30),
    # stretching only (no bending stiffness): about half the step at 40 x 40
    "E5e4 dt.02 CG30 stretch": grid(young=5e4, timestep=0.02, solver="CG", iterations=30,
                                    bending=False),
    "E1e5 dt.01 CG30 stretch": grid(young=1e5, timestep=0.01, solver="CG", iterations=30,
                                    bending=False),
    # strain under random drags is quasi-static (friction 1.5 against a 50 N/m membrane: flex
    # damping 0.01-0.2 leaves it unchanged in a first look), so the sheet has to be stiffer,
    # and a stiffer sheet needs a shorter step than 20 ms
    "E2e5 dt.01 CG30": grid(young=2e5, timestep=0.01, solver="CG", iterations=30),
    "E5e5 dt.01 CG30": grid(young=5e5, timestep=0.01, solver="CG", iterations=30),
    "E5e5 dt.01 CG30 stretch": grid(young=5e5, timestep=0.01, solver="CG", iterations=30,
                                    bending=False),
    # membrane stiffness goes with E t, bending with E t^3 / 12: a thinner, stiffer sheet
    # stretches like E 5e5 at 1 mm (500 N/m) and bends like E 5e4 at 1 mm (as cloth does:
    # stiff in stretch, soft in bending)
    "E1.7e6 t.3mm dt.02 CG30": grid(young=1.7e6, thickness=3e-4, timestep=0.02, solver="CG",
                                    iterations=30),
    "E1.7e6 t.3mm dt.01 CG30": grid(young=1.7e6, thickness=3e-4, timestep=0.01, solver="CG",
                                    iterations=30),
    "E1e6 t.5mm dt.01 CG30": grid(young=1e6, thickness=5e-4, timestep=0.01, solver="CG",
                                  iterations=30),
    "E5e6 t.3mm dt.01 CG30": grid(young=5e6, thickness=3e-4, timestep=0.01, solver="CG",
                                  iterations=30),
    "E1.7e6 t.3mm dt.005 CG30": grid(young=1.7e6, thickness=3e-4, timestep=0.005, solver="CG",
                                     iterations=30),
    # linear triangles lock: a crease across their diagonals must stretch them. The library's
    # diagonal fold (corner N-1 onto corner 0) creases along x = -y, across MuJoCo's grid
    # diagonals (x = y); "anti" splits the squares along the crease, "alternating" (the
    # default) both ways
    "E5e4 dt.02 CG30 tri anti": dict(young=5e4, timestep=0.02, solver="CG", iterations=30,
                                     triangulation="anti"),
    "E2e5 dt.005 CG30 tri anti": dict(young=2e5, timestep=0.005, solver="CG", iterations=30,
                                      triangulation="anti"),
    "E5e5 dt.005 CG30 tri anti": dict(young=5e5, timestep=0.005, solver="CG", iterations=30,
                                      triangulation="anti"),
    # the default sheet at twice its step, and the 2e5 Pa sheet on the default's triangles
    "E5e5 dt.01 CG30 tri alt": dict(young=5e5, timestep=0.01, solver="CG", iterations=30,
                                    triangulation="alternating"),
    "E2e5 dt.005 CG30 tri alt": dict(young=2e5, timestep=0.005, solver="CG", iterations=30,
                                     triangulation="alternating"),
    # on the default sheet (5e5 Pa, 5 ms, alternating triangles): self-collision by MuJoCo's
    # midphase ("auto" is sap for a sheet), MuJoCo 4.0's passive flex contact (self and floor
    # contacts as a frictionless penalty force, off the solver), and the Newton solver that
    # 4.0's guide recommends for flex, at the default step and at twice it
    "default selfcollide": dict(selfcollide=True),
    "default selfcollide bvh": dict(selfcollide="bvh"),
    "default passive": dict(passive=True),
    "default selfcollide passive": dict(selfcollide=True, passive=True),
    "default Newton": dict(solver="Newton"),
    "default Newton dt.01": dict(solver="Newton", timestep=0.01),
    # the solver per preset (issue 90): each preset as it is, but with Newton ("physics":
    # the preset the overrides go on top of)
    "fast Newton": dict(physics="fast", solver="Newton"),
    "accurate Newton": dict(physics="accurate", solver="Newton"),
}
ROPE_SETTINGS = {
    "preset:fast": None, "preset:default": None, "preset:accurate": None,
    "dt.02 CG50 damp.001": dict(timestep=0.02, solver="CG", iterations=50, damping=1e-3),
    "dt.01 CG50 damp.001": dict(timestep=0.01, solver="CG", iterations=50, damping=1e-3),
    "dt.02 Newton damp.001": dict(timestep=0.02, solver="Newton", iterations=50, damping=1e-3),
    "dt.02 CG50 damp.01": dict(timestep=0.02, solver="CG", iterations=50, damping=0.01),
    "dt.005 CG50 damp.001": dict(timestep=0.005, solver="CG", iterations=50, damping=1e-3),
    # the strain flags of the rope are dynamic (neighbours of the grasped particle overshoot it
    # during a lift; a rope without bending elasticity is flagged on every action, friction 0.3
    # changes nothing): damping of the rod's bending and twist removes them in a first look;
    # damping 0.1 at dt 0.02 and 0.01 are the fast and default presets' rows
    "dt.02 CG50 damp.3": dict(timestep=0.02, solver="CG", iterations=50, damping=0.3),
    "dt.02 CG50 damp1": dict(timestep=0.02, solver="CG", iterations=50, damping=1.0),
    "dt.02 CG50 E1e5 damp.1": dict(timestep=0.02, solver="CG", iterations=50, young=1e5,
                                   damping=0.1),
}


#: task -> the settings its sweep compares
SETTINGS = {"cloth": CLOTH_SETTINGS, "rope": ROPE_SETTINGS}


def _preset_and_fields(name: str, overrides: dict | None) -> tuple[str | None, dict]:
    """A setting's physics preset (a "preset:<name>" row's, or its overrides' "physics" key;
    None: the defaults) and the scene-config fields set on top of it."""
    if overrides is None:
        return name.split(":", 1)[1], {}
    fields = dict(overrides)
    return fields.pop("physics", None), fields


def _config(task: str, name: str, overrides: dict | None, n: int):
    cls = pick_task(task).config
    preset, fields = _preset_and_fields(name, overrides)
    base = cls.physics(preset, n=n) if preset is not None else cls(n=n)
    return replace(base, **fields)


def differing_fields(config) -> dict:
    """The fields of a scene config that differ from its class defaults (a preset row then
    says what the preset was when it was measured), besides the size."""
    default = type(config)(n=config.n)
    return {f.name: getattr(config, f.name) for f in fields(config)
            if getattr(config, f.name) != getattr(default, f.name)}


def random_actions(task: str, config, actions: int, threads: int, seed: int,
                   bound: float, picker_speed: float = PickerConfig.speed) -> dict:
    """``actions`` random pick-and-place actions (two per sequence; half from the flat start,
    half after folding one corner onto the opposite one): unstable per 1000, strain
    percentiles, CPU ms per step. ``picker_speed``: ``PickerConfig.speed`` (m/s)."""
    picker = PickerConfig(bound=(bound,) * 3, speed=picker_speed)
    scene = pick_task(task).build(config, picker)
    N = scene.n_particles
    svc = RolloutService(scene.scene, RolloutConfig(threads=threads))
    # the folded start: the last particle carried onto the first, released
    far = scene.positions(scene.initial_state)
    move = np.clip(far[0] - far[-1] + [0, 0, 0.02], -bound, bound)
    folded = svc.rollout(scene.initial_state, scene.picker.encode([[N - 1]], move[None, None]),
                         control_spec=CONTROL_SPEC)
    rng = np.random.default_rng(seed)
    P = max(1, actions // 4)
    out = {"unstable": 0, "actions": 0, "steps": 0, "wall_s": 0.0, "strain": [],
           "penetration": [], "speed": [], "energy": [], "reasons": {}}
    for start in (scene.initial_state, folded.final_states[0]):
        particles = rng.integers(0, N, (P, 2))
        disp = rng.uniform(-bound, bound, (P, 2, 3))
        U = scene.picker.encode(particles, disp)
        t0 = time.perf_counter()
        res = svc.rollout(start, U, control_spec=CONTROL_SPEC)
        out["wall_s"] += time.perf_counter() - t0
        st = res.stability
        out["unstable"] += st.n_unstable
        out["actions"] += 2 * P
        out["steps"] += U.shape[0] * U.shape[1]
        out["strain"] += st.max_strain.tolist()
        out["penetration"] += st.max_penetration.tolist()
        out["speed"] += st.max_speed.tolist()
        out["energy"] += st.max_energy_gain.tolist()
        for r in st.reason:
            if r:
                key = r.split(" ", 1)[0]
                out["reasons"][key] = out["reasons"].get(key, 0) + 1
    svc.close()
    strain = np.array(out["strain"])
    gain = np.array(out["energy"])
    return {
        "unstable_per_1000_actions": 1000.0 * out["unstable"] / out["actions"],
        "actions": out["actions"], "reasons": out["reasons"],
        "cpu_ms_per_step": 1e3 * out["wall_s"] * svc.threads / out["steps"],
        "steps_per_action": scene.picker.steps_per_action,
        "strain_p50": float(np.median(strain)), "strain_p90": float(np.percentile(strain, 90)),
        "strain_max": float(strain.max()),
        "penetration_max_mm": 1e3 * float(np.max(out["penetration"])),
        "speed_max": float(np.max(out["speed"])),
        # J/kg while nothing holds the object (dopt.stability; up to a rollout's first
        # broken bound)
        "energy_gain_p99": float(np.percentile(gain, 99)), "energy_gain_max": float(gain.max()),
    }


def scripted_problem(settings: PickPlaceSettings, name: str, overrides: dict | None):
    """The problem of ``settings`` under the bench's setting ``name`` (its ``overrides`` on
    top of the physics preset their "physics" key names, as ``_config`` builds them)."""
    preset, fields = _preset_and_fields(name, overrides)
    if preset is not None:
        settings = replace(settings, physics=preset)
    return make_problem(settings, scene_overrides=fields or None)


def scripted_goals(task: str, name: str, overrides: dict | None, n: int,
                   threads: int, picker_speed: float | None = None) -> dict:
    """The scripted policy on every goal of ``task`` (Fig. 7 settings, one trial): error (mm)
    and verdict."""
    out = {}
    for goal in GOALS[task]:
        s = replace(PickPlaceSettings.preset(task, goal), n=n, threads=threads,
                    picker_speed=picker_speed)
        res = run_problem(scripted_problem(s, name, overrides), ScriptedPlanner(),
                          method="scripted")
        out[goal] = {"error_mm": 1e3 * res.metrics["final_cost"], "unstable": res.unstable,
                     "reason": res.unstable_reason, "wall_s": res.wall_s}
    return out


def bench_physics(task: str, sizes: list[int] | None, settings: list[str] | None,
                  actions: int, threads: int, seed: int, scripted: bool = True,
                  picker_speeds: list[float | None] = (None,)) -> dict:
    """The sweep: one row per (setting, size, picker speed); a speed of None is
    ``PickerConfig``'s default. The bound (and with ``sizes`` None the size) is the preset's
    of the task's first goal."""
    if task not in SETTINGS:
        raise ValueError(f"unknown task {task!r}; the physics bench knows {', '.join(SETTINGS)}")
    table = SETTINGS[task]
    names = settings or list(table)
    unknown = [s for s in names if s not in table]
    if unknown:
        raise ValueError(f"unknown {task} settings {unknown}; choose from {list(table)}")
    preset = PickPlaceSettings.preset(task, GOALS[task][0])
    bound, sizes = preset.bound, sizes or [preset.n]
    rows = []
    for n in sizes:
        for name in names:
            config = _config(task, name, table[name], n)
            for speed in picker_speeds:
                speed = PickerConfig.speed if speed is None else float(speed)
                row = {"setting": name, "n": n, "overrides": table[name],
                       "fields": differing_fields(config), "picker_speed": speed,
                       **random_actions(task, config, actions, threads, seed, bound, speed)}
                if scripted:
                    row["scripted"] = scripted_goals(task, name, table[name], n, threads,
                                                     speed)
                rows.append(row)
    return {"experiment": "physics", "bench": task, "sizes": sizes, "seed": seed,
            "actions_per_setting": actions, "rows": rows, "provenance": provenance()}
