"""Bench of a cloth action on MuJoCo Warp (a GPU) beside MuJoCo's own CPU step.

Per size n (particles per side): the scene is built and settled on the CPU (``make_cloth``),
then the action ``python -m dopt.bench cloth-steps`` times (``cloth_steps.action_rows``) is
stepped from the settled state

- on the CPU by ``mj_step`` (this process's one thread; the row names the processor and the
  GPU): ms per step, MuJoCo's warnings (the
  messages its hook received and its counters) and the final particle positions;
- on MuJoCo Warp once per batch size W (W worlds step the same action in lockstep, as CEM's
  population would): the first step alone (it compiles the kernels), then the remaining
  steps, each a CUDA graph of ``mujoco_warp.step`` after copying that step's control row:
  ms per batched step and per world-step, MuJoCo Warp's overflow flags, whether every world
  stayed finite, and world 0's final particle distance to the CPU run (mean and max over the
  particles; MuJoCo Warp computes in float32, MuJoCo in float64). Where the step cannot be
  captured as a CUDA graph, its kernels are launched one by one (``cuda_graph`` false, and
  ``cuda_graph_error`` says why).

Nothing else in dopt imports warp or mujoco_warp; without them this bench raises ImportError
with the install line. The contact and constraint buffers are sized from the sheet (one
contact per particle against the floor, four pyramid rows per contact) plus the picker's.
"""

from __future__ import annotations

import importlib.metadata
import logging
import os
import time

import mujoco
import numpy as np

from dopt import blas
from dopt.bench.cloth_steps import _step_action, action_rows, mujoco_messages
from dopt.state import INTEGRATION, get_state

#: condim-3 pyramidal contact rows, and the non-zeros per row a particle contact needs
#: (its 3 slider dofs, padded for the picker's equality rows)
_ROWS_PER_CONTACT = 4
_NNZ_PER_ROW = 8

logger = logging.getLogger(__name__)


def _import_warp():
    try:
        import mujoco_warp
        import warp
    except ImportError as err:
        raise ImportError("the cloth-warp bench needs MuJoCo Warp: pip install mujoco-warp "
                          "(it brings warp-lang); a CUDA GPU runs it, the CPU only slowly"
                          ) from err
    return warp, mujoco_warp


def bench_cloth_warp(sizes: list[int], nworlds: list[int], preset: str = "default",
                     device: str | None = None, on_rows=None,
                     preload_workers: int = 0) -> list[dict]:
    """One row per size: the CPU step's timings and warnings, and per W in ``nworlds`` the
    MuJoCo Warp step's (``device``: warp's device name, None its default). ``on_rows(rows)``
    is called with the rows so far after the CPU run and after each batch size, the last row
    possibly unfinished (a long bench writes as it goes; a run stopped mid-size keeps what it
    measured). ``preload_workers`` > 0 on a CUDA device compiles and loads every kernel module
    MuJoCo Warp registers at import on that many threads before the first size
    (``warp.force_load``; ``machine["preload_s"]``), so the first step compiles only the kernels
    MuJoCo Warp generates for the model."""
    from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
    from dopt.tasks.pick.picker import CONTROL_SPEC

    if not sizes or any(int(n) < 2 for n in sizes):
        raise ValueError(f"sizes must be particle counts per side >= 2, got {sizes}")
    if not nworlds or any(int(w) < 1 for w in nworlds):
        raise ValueError(f"nworlds must be world counts >= 1, got {nworlds}")
    if int(preload_workers) < 0:
        raise ValueError(f"preload_workers must be >= 0, got {preload_workers}")
    wp, mjw = _import_warp()
    wp.config.quiet = True
    wp.init()
    dev = wp.get_device(device)
    machine = {"cpu": blas.cpuinfo("model name") or None, "cpu_count": os.cpu_count(),
               "warp_device": dev.name, "warp": wp.__version__,
               "mujoco_warp": importlib.metadata.version("mujoco-warp")}
    if preload_workers and dev.is_cuda:
        t0 = time.perf_counter()
        try:
            wp.force_load(device=dev, max_workers=int(preload_workers))
        except Exception as err:            # a module that does not compile: the steps say
            logger.warning("cloth-warp kernel preload failed: %s", err)
            machine["preload_error"] = f"{type(err).__name__}: {err}"
        machine.update(preload_s=time.perf_counter() - t0, preload_workers=int(preload_workers))
    rows: list[dict] = []
    for n in sizes:
        config = ClothSceneConfig.physics(preset, n=int(n))
        with mujoco_messages() as messages:
            t0 = time.perf_counter()
            scene = make_cloth(config)
            build = time.perf_counter() - t0
            d_cpu = mujoco.MjData(scene.model)
            t0 = time.perf_counter()
            cpu = _step_action(scene, CONTROL_SPEC, d_cpu)
            cpu["wall_ms_per_step"] = 1e3 * (time.perf_counter() - t0) / cpu["steps_per_action"]
        cpu["messages"] = dict(messages)
        final_cpu = scene.positions(get_state(scene.model, d_cpu))
        row = {"preset": preset, "n": int(n), "particles": int(n) * int(n),
               "nv": int(scene.model.nv), "neq": int(scene.model.neq), "build_s": build,
               "machine": machine, "cpu": cpu, "warp": []}
        rows.append(row)
        if on_rows is not None:
            on_rows(rows)
        for w in nworlds:
            out = {"nworld": int(w)}
            row["warp"].append(out)
            try:
                _warp_action(wp, mjw, dev, scene, out, final_cpu)
            except Exception as err:        # out of memory, an unsupported feature: say which
                logger.warning("cloth-warp n=%d W=%d failed in %s: %s", n, w, out["phase"], err)
                out["error"] = f"{type(err).__name__}: {err}"
            if on_rows is not None:
                on_rows(rows)
    return rows


def _captured_step(wp, mjw, dev, wm, wd, out: dict):
    """``mujoco_warp.step`` captured as a CUDA graph, or None where the capture fails (MuJoCo
    Warp 4.0's flex cloth on an H200: CUDA error 906, a memset on the legacy stream, which a
    capture refuses): the steps then launch their kernels one by one, and
    ``out["cuda_graph_error"]`` says why. A capture executes nothing, so the worlds' state
    is the first step's either way."""
    try:
        with wp.ScopedCapture(device=dev) as capture:
            mjw.step(wm, wd)
        return capture.graph
    except Exception as err:                # a CUDA graph is a speed-up, not the measurement
        logger.warning("cloth-warp: the step could not be captured as a CUDA graph, "
                       "timing it launch by launch: %s", err)
        out["cuda_graph_error"] = f"{type(err).__name__}: {err}"
        wp.synchronize_device(dev)
        return None


def _warp_action(wp, mjw, dev, scene, out: dict, final_cpu: np.ndarray) -> None:
    """The benched action on ``out["nworld"]`` MuJoCo Warp worlds, filling ``out`` as it goes
    (``out["phase"]``: the phase reached, so a failure says where); see the module
    docstring."""
    from dopt.tasks.pick.picker import CONTROL_SPEC

    m, nworld = scene.model, out["nworld"]
    out.update(device=str(dev), phase="upload")
    d0 = mujoco.MjData(m)
    mujoco.mj_setState(m, d0, scene.initial_state, INTEGRATION)
    mujoco.mj_forward(m, d0)
    # the control rows decoded into ctrl and eq_active, one block per step: (T, W, nu|neq)
    rows_u = action_rows(scene)
    scratch = mujoco.MjData(m)
    ctrl = np.empty((len(rows_u), m.nu))
    eq = np.empty((len(rows_u), m.neq), dtype=bool)
    for t, u in enumerate(rows_u):
        mujoco.mj_setState(m, scratch, u, CONTROL_SPEC)
        ctrl[t], eq[t] = scratch.ctrl, scratch.eq_active
    nconmax = scene.n_particles + 64
    njmax = _ROWS_PER_CONTACT * nconmax + 64          # one grasp equality (3 rows) is on
    t0 = time.perf_counter()
    with wp.ScopedDevice(dev):
        wm = mjw.put_model(m)
        wm.opt.warn_overflow = 0        # the flags are read from wd.overflow, not printed per step
        wd = mjw.put_data(m, d0, nworld=nworld, nconmax=nconmax, njmax=njmax,
                          njmax_nnz=_NNZ_PER_ROW * njmax)
        ctrl_all = wp.array(np.repeat(ctrl[:, None], nworld, 1), dtype=wd.ctrl.dtype)
        eq_all = wp.array(np.repeat(eq[:, None], nworld, 1), dtype=wd.eq_active.dtype)
        wp.synchronize_device(dev)
        out.update(upload_s=time.perf_counter() - t0, phase="first step")

        def controls(t: int) -> None:
            wp.copy(wd.ctrl, ctrl_all[t])
            wp.copy(wd.eq_active, eq_all[t])

        t0 = time.perf_counter()
        controls(0)
        mjw.step(wm, wd)
        wp.synchronize_device(dev)
        out.update(first_step_s=time.perf_counter() - t0, phase="steps")
        graph = None
        if dev.is_cuda:
            graph = _captured_step(wp, mjw, dev, wm, wd, out)
        t0 = time.perf_counter()
        for t in range(1, len(rows_u)):
            controls(t)
            if graph is not None:
                wp.capture_launch(graph)
            else:
                mjw.step(wm, wd)
        wp.synchronize_device(dev)
        ms = 1e3 * (time.perf_counter() - t0) / max(len(rows_u) - 1, 1)
        out.update(cuda_graph=graph is not None, ms_per_step=ms, ms_per_world_step=ms / nworld,
                   steps_timed=len(rows_u) - 1, phase="read back")
        qpos = wd.qpos.numpy()
        overflow = int(np.bitwise_or.reduce(wd.overflow.numpy().ravel()))
    state = np.array(scene.initial_state, dtype=float)       # world 0's qpos in a state row
    state[scene.scene.layout["qpos"]] = qpos[0]
    gap = np.linalg.norm(scene.positions(state) - final_cpu, axis=-1)
    out.update(all_finite=bool(np.isfinite(qpos).all()),
               overflow_flags=[f.name for f in mjw.OverflowType
                               if f and f != mjw.OverflowType.ALL and overflow & f],
               gap_to_cpu_mean_m=float(gap.mean()), gap_to_cpu_max_m=float(gap.max()),
               phase="done")
