"""Blow-up captures: the last states of an executed rollout that the stability verdict
(``dopt.stability``) flagged, written so that ``dopt-view`` opens them at the failing step
(its reader is the viewer's, ``dopt.view.episode.load_blowup``; the runtime that writes them,
``dopt.mpc`` and the pick scenes, imports nothing of ``dopt.view``).

A capture is one folder::

    blowup.json   {"format": "dopt-blowup/1", "step", "first_row", "reason", "body",
                   "body_id", "spec", "nstate", "rows", "label", "created", "version"}
    states.npy    (R, ns) float64: rows first_row .. first_row + R - 1 of the rollout
                  (row 0 its start, row t + 1 the state after step t); the last row is the
                  state after the failing step ``step``
    model.mjb     the model exactly as it ran (mj_saveModel: run-time changes included)
    model.xml     MJCF of it, for reading (MjSpec.to_xml of the given spec, the given XML, or
                  mj_saveLastXML where it matches), when one could be written

``list_captures`` reads the captures of a run folder, ``retire_captures`` moves some aside
(a rerun of their trials), ``warning_body`` names the body a MuJoCo warning points at.

``capture_blowup`` re-simulates an executed rollout's controls up to the failing step with
``mj_step`` (bit-identical to both rollout routes) keeping a ring buffer of the last ``keep``
states, and calls ``save_blowup``. The offending body is named by the verdict's reason
(``speed ... (body NAME)``, ``(flex vertex i)``, ``(flex edge i)``), else it is the body whose
DoFs move fastest (or first go non-finite) in the failing state.

Shapes: R rows kept, ns state row, T control rows, nc control row size.
"""

from __future__ import annotations

import collections
import json
import logging
import os
import re
import time
from pathlib import Path

import mujoco
import numpy as np

from dopt import atomic
from dopt.state import INTEGRATION, StateLayout, check_model, check_spec, check_states
from dopt.validation import check_int, float_array

log = logging.getLogger(__name__)

FORMAT = "dopt-blowup/1"
#: states a capture keeps by default (the ring buffer's length)
KEEP = 100


def save_blowup(out_dir, model: mujoco.MjModel, states: np.ndarray, step: int, reason: str,
                *, first_row: int | None = None, spec: int = INTEGRATION,
                xml: str | mujoco.MjSpec | None = None, label: str = "") -> Path:
    """Write a capture (module docstring) into the folder ``out_dir`` (created; an existing
    capture there is replaced) and return it.

    Args:
        model: the model the rollout ran on.
        states: (R, ns) the last state rows of the rollout, the last one the state after the
            failing step (non-finite values allowed: they are what blew up).
        step: the failing step (the verdict's ``Stability.step``).
        reason: the verdict's reason (names the bound and, where it can, the body).
        first_row: the rollout row of ``states[0]``; default ``step + 2 - R`` (the last row
            is the state after ``step``).
        spec: the mjtState bits of the rows.
        xml: the model's MJCF (a string or the MjSpec it was compiled from), for model.xml.
        label: a name for the console and the viewer (e.g. "original seed 3 stage 1").

    Raises:
        TypeError / ValueError: rows that do not fit the model and spec, a negative step, a
            first_row below 0, a reason that is not a string.
    """
    check_model(model)
    spec = check_spec(spec)
    step = check_int(step, "step", 0)
    if not isinstance(reason, str) or not isinstance(label, str):
        raise TypeError(f"reason and label must be strings, got {reason!r}, {label!r}")
    rows = float_array(states, "states", finite=False, ndim=2)
    ns = mujoco.mj_stateSize(model, spec)
    if rows.shape[1] != ns or not len(rows):
        raise ValueError(f"states must have shape (R, {ns}) with R >= 1, got {rows.shape}")
    first = step + 2 - len(rows) if first_row is None else check_int(first_row, "first_row")
    if first < 0:
        raise ValueError(f"first_row {first} < 0: {len(rows)} rows cannot end after step "
                         f"{step}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with atomic.writing(out / "model.mjb") as tmp:
        mujoco.mj_saveModel(model, str(tmp), None)
    wrote_xml = _write_xml(out / "model.xml", model, xml)
    with atomic.writing(out / "states.npy") as tmp:
        np.save(tmp, rows)
    body = offending_body(model, rows[-1], reason, spec)
    meta = {"format": FORMAT, "step": step, "first_row": first, "reason": reason,
            "body": _body_name(model, body), "body_id": body, "spec": spec, "nstate": ns,
            "rows": len(rows), "label": label, "xml": wrote_xml,
            "created": time.strftime("%Y-%m-%dT%H:%M:%S"), "version": _version()}
    atomic.write_text(out / "blowup.json", json.dumps(meta, indent=1) + "\n")
    log.warning("blow-up capture %s: step %d, %s (body %s)", out, step, reason, meta["body"])
    return out


def capture_blowup(out_dir, model: mujoco.MjModel, start_state: np.ndarray,
                   controls: np.ndarray, step: int, reason: str, *, keep: int = KEEP,
                   spec: int = INTEGRATION,
                   control_spec: int = int(mujoco.mjtState.mjSTATE_CTRL),
                   xml: str | mujoco.MjSpec | None = None, label: str = "") -> Path:
    """Re-simulate an executed rollout from ``start_state`` (ns,) with its controls (T, nc)
    (rows of ``control_spec``, set before each step) up to the failing ``step``, keep the last
    ``keep`` state rows in a ring buffer and write them with ``save_blowup``.

    A step in which MuJoCo raises ends the replay there (the rows so far are kept)."""
    check_model(model)
    spec, control_spec = check_spec(spec), check_spec(control_spec, "control_spec")
    x0 = check_states(model, start_state, spec, batched=False, name="start_state")
    U = float_array(controls, "controls", finite=False, ndim=2)
    step, keep = check_int(step, "step", 0), check_int(keep, "keep", 1)
    if step >= len(U):
        raise ValueError(f"step {step} is beyond the {len(U)} control rows")
    if U.shape[1] != mujoco.mj_stateSize(model, control_spec):
        raise ValueError(f"controls must have shape (T, "
                         f"{mujoco.mj_stateSize(model, control_spec)}), got {U.shape}")
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, x0, spec)
    ring = collections.deque([x0.copy()], maxlen=keep)
    last = 0
    for t in range(step + 1):
        mujoco.mj_setState(model, data, U[t], control_spec)
        try:
            mujoco.mj_step(model, data)
        except Exception as e:                       # MuJoCo gave up on this step
            log.warning("blow-up replay: MuJoCo raised at step %d: %s", t, e)
            break
        row = np.empty(len(x0))
        mujoco.mj_getState(model, data, row, spec)
        ring.append(row)
        last = t + 1
    return save_blowup(out_dir, model, np.array(ring), max(last - 1, 0), reason,
                       first_row=last + 1 - len(ring), spec=spec, xml=xml, label=label)


def capture_dir(out, label: str) -> Path:
    """A new capture folder ``OUT/blowups/<label>`` (``-2``, ``-3``, ... where it exists);
    the label's characters outside [A-Za-z0-9._-] become '-'. Not created."""
    base = Path(out) / "blowups"
    name = re.sub(r"[^A-Za-z0-9._-]+", "-", str(label)).strip("-") or "blowup"
    path, k = base / name, 1
    while path.exists():
        k += 1
        path = base / f"{name}-{k}"
    return path


def list_captures(out) -> list[dict]:
    """The captures under ``OUT/blowups`` (not those retired to ``blowups/outdated``), in
    name order: each its blowup.json with "path" (the folder) added; a folder whose
    blowup.json is unreadable or of another format is left out (logged)."""
    found = []
    for meta_file in sorted((Path(out) / "blowups").glob("*/blowup.json")):
        try:
            meta = json.loads(meta_file.read_text())
        except (OSError, ValueError) as e:
            log.warning("%s: unreadable (%s)", meta_file, e)
            continue
        if isinstance(meta, dict) and meta.get("format") == FORMAT:
            found.append({**meta, "path": str(meta_file.parent)})
        else:
            log.warning("%s: not a %s capture", meta_file, FORMAT)
    return found

def captures_of(out, labels) -> list[dict]:
    """The captures under OUT/blowups of the trials ``labels`` (their capture labels): a
    summary's "blowups", each {"trial", "path" (relative to OUT), "step", "reason", "body"}."""
    labels = set(labels)
    return [{"trial": c["label"], "path": os.path.relpath(c["path"], out), "step": c["step"],
             "reason": c["reason"], "body": c["body"]}
            for c in list_captures(out) if c.get("label") in labels]



def retire_captures(out, labels) -> list[Path]:
    """Move the captures under ``OUT/blowups`` whose label is in ``labels`` to
    ``OUT/blowups/outdated/`` (a run that recomputes those trials); returns where they went."""
    labels, moved = set(labels), []
    for meta in list_captures(out):
        if meta.get("label") in labels:
            src = Path(meta["path"])
            dst, k = Path(out) / "blowups" / "outdated" / src.name, 1
            while dst.exists():
                k += 1
                dst = dst.with_name(f"{src.name}-{k}")
            dst.parent.mkdir(parents=True, exist_ok=True)
            moved.append(src.rename(dst))
    return moved


def warning_body(model: mujoco.MjModel, warning, index: int) -> int | None:
    """The body a MuJoCo warning's ``lastinfo`` ``index`` points at: the qpos entry of
    mjWARN_BADQPOS, the DoF of mjWARN_BADQVEL and mjWARN_BADQACC, the actuator of
    mjWARN_BADCTRL (a joint, body or site transmission); None otherwise."""
    W, i = mujoco.mjtWarning, int(index)
    if warning == W.mjWARN_BADQPOS and 0 <= i < model.nq:
        j = int(np.searchsorted(model.jnt_qposadr, i, side="right") - 1)
        return int(model.jnt_bodyid[j])
    if warning in (W.mjWARN_BADQVEL, W.mjWARN_BADQACC) and 0 <= i < model.nv:
        return int(model.dof_bodyid[i])
    if warning != W.mjWARN_BADCTRL or not 0 <= i < model.nu:
        return None
    T, target = mujoco.mjtTrn, int(model.actuator_trnid[i, 0])
    kind = int(model.actuator_trntype[i])
    if kind in (T.mjTRN_JOINT, T.mjTRN_JOINTINPARENT):
        return int(model.jnt_bodyid[target])
    if kind == T.mjTRN_BODY:
        return target
    return int(model.site_bodyid[target]) if kind == T.mjTRN_SITE else None


def offending_body(model: mujoco.MjModel, state: np.ndarray, reason: str = "",
                   spec: int = INTEGRATION) -> int | None:
    """The body a verdict's ``reason`` names (a body name, a flex vertex or edge), else the
    body with the first non-finite, else the fastest, DoF in ``state`` (ns,); None when the
    model has no DoF."""
    named = _body_of_reason(model, reason)
    if named is not None:
        return named
    layout = StateLayout.of(model, spec)
    if model.nv == 0 or "qvel" not in layout.slices:
        return None
    qvel = np.asarray(state, dtype=float)[layout["qvel"]]
    bad = np.flatnonzero(~np.isfinite(qvel))
    dof = int(bad[0]) if len(bad) else int(np.argmax(np.abs(qvel)))
    return int(model.dof_bodyid[dof])


def _body_of_reason(model: mujoco.MjModel, reason: str) -> int | None:
    m = re.search(r"\(body ([^)]+)\)", reason or "")
    if m:
        name = m.group(1).strip()
        if name.isdigit() and int(name) < model.nbody:
            return int(name)
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        return int(b) if b >= 0 else None
    m = re.search(r"\(flex (vertex|edge) (\d+)\)", reason or "")
    if not m:
        return None
    i = int(m.group(2))
    if m.group(1) == "vertex":
        return int(model.flex_vertbodyid[i]) if i < model.nflexvert else None
    if i >= model.nflexedge:
        return None
    f = int(np.searchsorted(model.flex_edgeadr, i, side="right") - 1)
    v = int(model.flex_vertadr[f] + model.flex_edge[i, 0])
    return int(model.flex_vertbodyid[v])


def _body_name(model: mujoco.MjModel, body: int | None) -> str | None:
    if body is None:
        return None
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"


def _write_xml(path: Path, model: mujoco.MjModel, xml) -> bool:
    """model.xml from an MjSpec, an MJCF string, or mj_saveLastXML; False when none fits."""
    try:
        if isinstance(xml, mujoco.MjSpec):
            atomic.write_text(path, xml.to_xml())
        elif isinstance(xml, str):
            atomic.write_text(path, xml)
        elif xml is None:
            with atomic.writing(path) as tmp:
                mujoco.mj_saveLastXML(str(tmp), model)
        else:
            raise TypeError(f"xml must be an MJCF string or an MjSpec, got {type(xml).__name__}")
    except (ValueError, RuntimeError, mujoco.FatalError) as e:
        log.info("no model.xml for the capture (%s); model.mjb holds the model", e)
        path.unlink(missing_ok=True)
        return False
    return True


def _version() -> str:
    from dopt import __version__
    return __version__
