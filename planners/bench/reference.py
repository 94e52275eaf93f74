"""python -m planners.bench reference: dopt's rope and cloth held against analytic references.

Each physics preset's scene is built as the pick tasks build it (``pick_task(task).build``),
then pinned (``dopt.tasks.pick.pinned``) and relaxed to static equilibrium:

- **catenary**: the rope pinned at both ends, span ``SPAN`` of its length, released from a
  circular arc of its length (cosseratbench's start shape: smooth, not the answer). Against
  cosseratbench's catenary (``cosseratbench.experiments.catenary.reference_curve``) of an
  inextensible rod: the rope's edges are equality constraints meant to keep their length, so
  any stretch is the preset's error. Also the exact equilibrium of the discrete chain of the
  same links (``hanging_chain``: the discretisation's share, a few hundredths of a percent).
- **cantilever**: the rope cut to ``CANTILEVER_PARTICLES`` particles (its spacing, section and
  material), clamped by pinning its first two particles, gravity off, a tip force bending it
  by ``CANTILEVER_DEFLECTION`` of its length. Against Euler-Bernoulli, F L^3 / (3 E I) with
  MuJoCo's circle section I = pi r^4 / 4: cosseratbench's cantilever reference, whose load is
  fixed (7.5 mN, sized for its beam of E I some 25000 times the rope's), scaled linearly to
  this load (the reference is linear). L runs from the middle of the clamped edge:
  a discrete elastic rod's first bending vertex owns the half edges on either side of it.
- **sheet**: the cloth pinned along two opposite edges, span ``SPAN`` of its side. Against
  cosseratbench's elastic catenary of the strip it is (weight of the free rows, EA = E t W;
  the sheet's bending neglected, as the reference neglects the rod's).

- **rope-actions** (no reference): the cost of the planners' own workload, random
  pick-and-place actions on the rope (``pick_cost``).

Cost: the relaxation's steps and simulated seconds per CPU second of its thread (one thread;
CPU time, which a busy machine inflates less than wall time), each preset against
``default``. Each row also gives its residual speed (m/s), near zero once it has settled.
The references come from the dev dependency ``cosseratbench`` (``pip install -e .[dev]``).

Shapes: N particles.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
from scipy.optimize import brentq

from dopt.lab.provenance import provenance
from dopt.tasks.pick.picker import CONTROL_SPEC, PickerConfig
from dopt.tasks.pick.pinned import PinnedScene, Relaxed
from planners.bench.physics import differing_fields
from planners.pick_place import pick_task

#: pin span as a fraction of the rope's length (the cloth's side): cosseratbench's default
SPAN = 0.8
#: height of the pins above the floor (m): the rope (sag 0.13 m) and sheet hang clear of it
HEIGHT = 0.5
GRAVITY = 9.81
#: particles of the cantilever (the rope's spacing): short, so that its slowest bending mode
#: settles in seconds (the whole 0.5 m rope's period is about a minute)
CANTILEVER_PARTICLES = 16
#: tip deflection of the cantilever's load, in lengths: small enough for the linear reference
CANTILEVER_DEFLECTION = 0.02
#: presets the bench compares
PRESETS = ("fast", "default", "accurate")
#: relaxation time, in periods of the slowest mode (critically damped, about 1e-4 of the
#: start's distance is left)
PERIODS = 3.0


def _cosseratbench():
    """cosseratbench's references (a dev dependency); ImportError naming the extra."""
    try:
        import cosseratbench
        from cosseratbench.experiments import cantilever, catenary
    except ImportError as e:
        raise ImportError("the physics references need cosseratbench: pip install "
                          "cosseratbench (dopt's dev extra)") from e
    return cosseratbench, catenary, cantilever


def _rod(length: float, radius: float, young: float, weight: float):
    """A cosseratbench rod (straight along x from 0) of ``weight`` N/m and Young's modulus
    ``young``."""
    cb, _, _ = _cosseratbench()
    area = np.pi * radius ** 2
    material = cb.Material(young, young / 3.0, weight / GRAVITY / area)
    return cb.Rod(centerline=((0.0, 0.0, 0.0), (length, 0.0, 0.0)), radius=radius,
                  material=material)


def catenary_curve(length: float, span: float, young: float = np.inf, radius: float = 0.005,
                   weight: float = 1.0) -> np.ndarray:
    """cosseratbench's elastic catenary from (0, 0, 0) to (span, 0, 0): (M, 3), z <= 0.
    ``young`` inf: inextensible (1e30 Pa stands in); ``radius`` and ``weight`` (N/m) matter
    only with a finite ``young``."""
    _, catenary, _ = _cosseratbench()
    young = 1e30 if np.isinf(young) else young
    return catenary.reference_curve(_rod(length, radius, young, weight), GRAVITY, span)


def hanging_chain(links: int, length: float, span: float) -> np.ndarray:
    """The exact equilibrium of ``links`` rigid links of equal length with equal weights at
    the ``links - 1`` joints, pinned at (0, 0, 0) and (span, 0, 0): (links + 1, 3) nodes.

    The horizontal tension H is the same in every link and link k carries the vertical load
    of the joints beyond the middle, so tan(angle_k) = ((links - 1) / 2 - k) W / H; H / W is
    the root of the span.
    """
    if not 0 < span < length:
        raise ValueError(f"span must be in (0, length {length:g}), got {span!r}")
    step = length / links
    load = (links - 1) / 2 - np.arange(links)

    def nodes(h: float) -> np.ndarray:
        norm = np.hypot(h, load)
        xz = step * np.stack([h / norm, -load / norm], axis=1)
        return np.vstack([[0.0, 0.0], np.cumsum(xz, axis=0)])

    slack = step * (links % 2)           # all links vertical but an odd count's middle one
    if not span > slack:
        raise ValueError(f"{links} links of {step:.4g} cannot hang across a span of {span:g} "
                         f"(at least {slack:.4g})")
    h = brentq(lambda h: nodes(h)[-1, 0] - span, 1e-12, 1e12, xtol=1e-15, rtol=1e-15)
    xz = nodes(h)
    return np.stack([xz[:, 0], np.zeros(links + 1), xz[:, 1]], axis=1)


def circular_arc(length: float, span: float, points: int) -> np.ndarray:
    """``points`` points evenly spaced along an arc of ``length`` hanging below the chord
    (0, 0, 0)-(span, 0, 0): (points, 3), cosseratbench's start shape of its catenary."""
    _, catenary, _ = _cosseratbench()
    arc = catenary._circular_arc(length, span, 4001)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(arc, axis=0), axis=1))])
    at = np.linspace(0.0, s[-1], points)
    return np.stack([np.interp(at, s, arc[:, k]) for k in range(3)], axis=1)


def distance_to_curve(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Distance of each of ``points`` (P, 3) to the polyline ``curve`` (M, 3): (P,)."""
    a, b = curve[:-1], curve[1:]
    ab = b - a
    t = np.clip(np.einsum("pmk,mk->pm", points[:, None] - a, ab) / (ab * ab).sum(1), 0, 1)
    closest = a + t[..., None] * ab
    return np.linalg.norm(points[:, None] - closest, axis=2).min(axis=1)


def _scene(task: str, preset: str, **fields):
    """(config, scene) of the pick task ``task``'s physics ``preset`` with ``fields`` on top,
    the scene built as the planners build it (every particle pickable)."""
    spec = pick_task(task)
    config = spec.config.physics(preset, **fields)
    return config, spec.build(config, PickerConfig())


def _strain(pinned: PinnedScene, rest: float, positions: np.ndarray) -> np.ndarray:
    """Relative stretch of every edge of ``pinned``'s flex at ``positions``: (E,)."""
    e = pinned.edges
    return np.linalg.norm(positions[e[:, 1]] - positions[e[:, 0]], axis=1) / rest - 1


def _cost(relaxed: Relaxed, dt: float) -> dict:
    """The relaxation's cost (per CPU second of its thread) and its residual speed (m/s)."""
    return {"steps": relaxed.steps, "cpu_s": relaxed.cpu_s, "wall_s": relaxed.wall_s,
            "steps_per_cpu_s": relaxed.steps / relaxed.cpu_s,
            "sim_s_per_cpu_s": relaxed.steps * dt / relaxed.cpu_s,
            "residual_speed": relaxed.speed}


def _relax_time(omega: float, rate_of: float = 2.0) -> tuple[float, float]:
    """(seconds, damping rate) that relax a mode of angular frequency ``omega`` critically
    for ``PERIODS`` of its periods."""
    return PERIODS * 2 * np.pi / omega, rate_of * omega


def rope_catenary(preset: str, **fields) -> dict:
    """The rope of ``preset`` (``fields`` of ``RopeSceneConfig`` on top) pinned at both ends,
    span ``SPAN`` of its length, relaxed from a circular arc: sag and shape errors against
    the inextensible catenary and the discrete chain, edge strain, cost."""
    c, scene = _scene("rope", preset, **fields)
    N, L = c.n, c.length
    span = SPAN * L
    left = np.array([-span / 2, 0.0, HEIGHT])
    start = circular_arc(L, span, N) + left
    pinned = PinnedScene(scene, {0: start[0], N - 1: start[-1]})
    # the slowest mode is the pendulum swing of the hanging rope, about sqrt(g / L)
    seconds, rate = _relax_time(np.sqrt(GRAVITY / L))
    relaxed = pinned.relax(start, seconds, rate)
    x = relaxed.positions - left
    curve = catenary_curve(L, span)
    chain = hanging_chain(N - 1, L, span)
    sag, ref_sag = -x[:, 2].min(), -curve[:, 2].min()
    strain = _strain(pinned, L / (N - 1), relaxed.positions)
    return {"preset": preset, "n": N, "fields": differing_fields(c),
            "sag_m": float(sag), "reference_sag_m": float(ref_sag),
            "sag_error": float(sag / ref_sag - 1),
            "chain_sag_error": float(-chain[:, 2].min() / ref_sag - 1),
            "shape_error": float(distance_to_curve(x, curve).max() / L),
            "strain_mean": float(strain.mean()), "strain_max": float(strain.max()),
            **_cost(relaxed, scene.model.opt.timestep)}


def rope_cantilever(preset: str, **fields) -> dict:
    """The rope of ``preset`` (``fields`` on top) cut to ``CANTILEVER_PARTICLES`` particles at
    its own spacing, clamped at particle 0 and 1, gravity off, a tip force bending it by
    ``CANTILEVER_DEFLECTION`` lengths: tip deflection and shape against Euler-Bernoulli."""
    _, _, cantilever = _cosseratbench()
    full = pick_task("rope").config.physics(preset, **fields)
    N = CANTILEVER_PARTICLES
    spacing = full.length / (full.n - 1)
    c, scene = _scene("rope", preset, **{**fields, "n": N, "length": spacing * (N - 1),
                                         "mass": full.mass * N / full.n, "settle": 0.0})
    beam = c.length - spacing / 2               # from the middle of the clamped edge
    rod = _rod(beam, c.radius, c.young, 1.0)
    EI = c.young * rod.second_moment_of_area
    force = CANTILEVER_DEFLECTION * beam * 3 * EI / beam ** 3
    start = np.stack([np.linspace(0, c.length, N), np.zeros(N), np.full(N, HEIGHT)], axis=1)
    start[:, 0] -= c.length / 2
    pinned = PinnedScene(scene, {0: start[0], 1: start[1]})
    # the slowest mode: the cantilever's first, 3.516 sqrt(EI / (rho A)) / L^2
    omega = 3.516 * np.sqrt(EI / (c.mass / c.length)) / beam ** 2
    seconds, rate = _relax_time(omega)
    relaxed = pinned.relax(start, seconds, rate, gravity=(0.0, 0.0, 0.0),
                           forces={N - 1: (0.0, 0.0, -force)})
    scale = force / cantilever.FORCE             # the reference is linear in its load
    tip = start[-1, 2] - relaxed.positions[-1, 2]
    ref_tip = cantilever.reference_tip_deflection(rod) * scale
    # the reference curve from the clamp point, x along the beam, z down
    scenario = _cosseratbench()[0].Scenario(rods=(rod,), duration=1.0)
    curve = cantilever.reference_curve(scenario) * [1.0, 1.0, scale]
    x = relaxed.positions - (start[0] + [spacing / 2, 0.0, 0.0])
    return {"preset": preset, "n": N, "fields": differing_fields(c), "length_m": float(beam),
            "EI": float(EI), "force_N": float(force), "tip_m": float(tip),
            "reference_tip_m": float(ref_tip), "tip_error": float(tip / ref_tip - 1),
            "shape_error": float(distance_to_curve(x[1:], curve).max() / beam),
            **_cost(relaxed, scene.model.opt.timestep)}


def cloth_sheet(preset: str, **fields) -> dict:
    """The cloth of ``preset`` (``fields`` of ``ClothSceneConfig`` on top) pinned along its
    rows ix = 0 and ix = n - 1, span ``SPAN`` of its side, relaxed from a circular arc: sag
    and shape against the elastic catenary of the strip, and against the inextensible one."""
    c, scene = _scene("cloth", preset, **fields)
    side, m = c.side, c.n
    span = SPAN * side
    arc = circular_arc(side, span, m)                                       # (n, 3) along x
    ix, iy = np.divmod(np.arange(m * m), m)
    left = np.array([-span / 2, 0.0, HEIGHT])
    start = arc[ix] + left + np.stack([0 * iy, (iy - (m - 1) / 2) * c.spacing, 0 * iy], 1)
    edge_rows = np.flatnonzero((ix == 0) | (ix == m - 1))
    pinned = PinnedScene(scene, {int(i): start[i] for i in edge_rows})
    seconds, rate = _relax_time(np.sqrt(GRAVITY / side))
    relaxed = pinned.relax(start, seconds, rate)
    x = relaxed.positions - left
    # the free rows' weight over the span's rest length; EA of the whole width
    weight = c.mass * (m - 1) / (m * side) * GRAVITY
    curve = catenary_curve(side, span, young=c.young * c.thickness * side / (np.pi * 0.01 ** 2),
                           radius=0.01, weight=weight)
    stiff = catenary_curve(side, span)
    sag, ref_sag = -x[:, 2].min(), -curve[:, 2].min()
    xz = x * [1.0, 0.0, 1.0]
    return {"preset": preset, "n": m, "fields": differing_fields(c),
            "sag_m": float(sag), "reference_sag_m": float(ref_sag),
            "sag_error": float(sag / ref_sag - 1),
            "inextensible_sag_error": float(sag / -stiff[:, 2].min() - 1),
            "chain_sag_error": float(-hanging_chain(m - 1, side, span)[:, 2].min()
                                     / -stiff[:, 2].min() - 1),
            "shape_error": float(distance_to_curve(xz, curve).max() / side),
            **_cost(relaxed, scene.model.opt.timestep)}


def pick_cost(task: str, preset: str, actions: int = 64, seed: int = 0, **fields) -> dict:
    """The planners' workload under ``preset`` (``fields`` on top): ``actions`` random
    pick-and-place actions, two per sequence from the settled start, displacements within the
    task's first goal's bound, stepped with mj_step on one thread: steps and simulated seconds
    per CPU second."""
    from planners.pick_place import GOALS, PickPlaceSettings

    bound = PickPlaceSettings.preset(task, GOALS[task][0]).bound
    spec = pick_task(task)
    scene = spec.build(spec.config.physics(preset, **fields), PickerConfig(bound=(bound,) * 3))
    rng = np.random.default_rng(seed)
    P = max(1, actions // 2)
    U = scene.picker.encode(rng.integers(0, scene.n_particles, (P, 2)),
                            rng.uniform(-bound, bound, (P, 2, 3)))
    m = scene.model
    data = mujoco.MjData(m)
    cpu = 0.0
    for controls in U:
        mujoco.mj_setState(m, data, scene.initial_state, scene.scene.layout.spec)
        start = time.thread_time()
        for row in controls:
            mujoco.mj_setState(m, data, row, CONTROL_SPEC)
            mujoco.mj_step(m, data)
        cpu += time.thread_time() - start
    steps = U.shape[0] * U.shape[1]
    return {"preset": preset, "n": scene.n_particles, "actions": 2 * P, "steps": steps,
            "cpu_s": cpu, "steps_per_cpu_s": steps / cpu,
            "sim_s_per_cpu_s": steps * m.opt.timestep / cpu}


#: the references the bench runs: name -> (task, function of (preset, **config fields)); and
#: "rope-actions", the cost of the planners' random pick-and-place actions on the rope
CHECKS = {"catenary": ("rope", rope_catenary), "cantilever": ("rope", rope_cantilever),
          "sheet": ("cloth", cloth_sheet),
          "rope-actions": ("rope", lambda preset, **fields: pick_cost("rope", preset, **fields))}


def bench_reference(presets=PRESETS, checks=tuple(CHECKS), rope_n: int | None = None,
                    cloth_n: int | None = None) -> dict:
    """One row per (check, preset): the errors against the reference and the cost, with
    ``cost_vs_default``, the CPU time per simulated second over the default preset's (when
    ``presets`` holds "default"). ``rope_n``, ``cloth_n``: the rope's particles (the
    cantilever keeps CANTILEVER_PARTICLES at that rope's spacing) and the cloth's per side
    (None: the presets')."""
    unknown = [c for c in checks if c not in CHECKS]
    if unknown:
        raise ValueError(f"unknown reference checks {unknown}; choose from {list(CHECKS)}")
    rows, sizes = [], {"rope": rope_n, "cloth": cloth_n}
    for check in checks:
        task, run = CHECKS[check]
        n = sizes[task]
        done = {p: {"check": check, **run(p, **({} if n is None else {"n": n}))}
                for p in presets}
        base = done.get("default")
        for row in done.values():
            if base is not None:
                row["cost_vs_default"] = base["sim_s_per_cpu_s"] / row["sim_s_per_cpu_s"]
            rows.append(row)
    return {"experiment": "physics_reference", "presets": list(presets), "rows": rows,
            "provenance": provenance()}
