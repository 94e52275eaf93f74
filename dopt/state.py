"""State rows and tangent-space position arithmetic.

A state is one ``mjSTATE_INTEGRATION`` row (time, qpos, qvel, act, history, warmstart, ctrl,
applied forces, eq_active, mocap, userdata, plugin, plastic): everything MuJoCo needs to
reproduce the next step bit for bit. ``mjSTATE_FULLPHYSICS`` alone is not enough (it lacks the
warmstart, controls and eq_active; cloth branches then diverge by centimetres).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.validation import float_array, is_int

INTEGRATION = int(mujoco.mjtState.mjSTATE_INTEGRATION)
#: mjMAXVAL: MuJoCo rejects a qpos, qvel or qacc entry beyond +-1e10 (or NaN) as unstable
#: (mj_checkPos / mj_checkVel / mj_checkAcc, mjWARN_BADQPOS / BADQVEL / BADQACC)
MAXVAL = 1e10
_NSTATE = int(mujoco.mjtState.mjNSTATE)

# single-bit state components, in the order MuJoCo lays them out in a state row
_COMPONENTS = [(name[len("mjSTATE_"):].lower(), int(bit))
               for name, bit in mujoco.mjtState.__members__.items()
               if name != "mjNSTATE" and int(bit) & (int(bit) - 1) == 0]
_COMPONENTS.sort(key=lambda c: c[1])


@dataclass(frozen=True)
class StateLayout:
    """Where each component sits inside a state row of ``spec``.

    Attributes:
        spec: the mjtState bits of the row.
        size: row length ns.
        slices: component name ("time", "qpos", "qvel", "act", "warmstart", "ctrl",
            "eq_active", ...) -> slice of the row.
    """

    spec: int
    size: int
    slices: dict[str, slice]

    @classmethod
    def of(cls, model: mujoco.MjModel, spec: int = INTEGRATION) -> StateLayout:
        check_model(model)
        spec = check_spec(spec)
        slices, offset = {}, 0
        for name, bit in _COMPONENTS:
            if spec & bit:
                n = mujoco.mj_stateSize(model, bit)
                slices[name] = slice(offset, offset + n)
                offset += n
        size = mujoco.mj_stateSize(model, spec)
        if offset != size:  # a component MuJoCo added that this list does not know
            raise RuntimeError(f"state layout mismatch: components sum to {offset}, "
                               f"mj_stateSize gives {size}")
        return cls(spec, size, slices)

    def __getitem__(self, name: str) -> slice:
        try:
            return self.slices[name]
        except KeyError:
            raise ValueError(f"state spec {self.spec} has no component {name!r}; "
                             f"it has {sorted(self.slices)}") from None


def check_model(model, name: str = "model") -> mujoco.MjModel:
    """TypeError unless ``model`` is a ``mujoco.MjModel``."""
    if not isinstance(model, mujoco.MjModel):
        raise TypeError(f"{name} must be a mujoco.MjModel, got {type(model).__name__}")
    return model


def check_data(model: mujoco.MjModel, data, name: str = "data") -> mujoco.MjData:
    """TypeError unless ``data`` is a ``mujoco.MjData``; ValueError unless it was made for a
    model of ``model``'s sizes (reading or writing a state through another model's sizes would
    run past its buffers)."""
    if not isinstance(data, mujoco.MjData):
        raise TypeError(f"{name} must be a mujoco.MjData, got {type(data).__name__}")
    dm = data.model
    if dm._address != model._address and (
            (dm.nq, dm.nv, dm.nu, dm.na, dm.neq, dm.nmocap)
            != (model.nq, model.nv, model.nu, model.na, model.neq, model.nmocap)
            or mujoco.mj_stateSize(dm, INTEGRATION) != mujoco.mj_stateSize(model, INTEGRATION)):
        raise ValueError(f"{name} was made for another model (nq {dm.nq}, nv {dm.nv}, nu "
                         f"{dm.nu}; this one has nq {model.nq}, nv {model.nv}, nu {model.nu})")
    return data


def check_spec(spec, name: str = "spec") -> int:
    """``spec`` as an int: a non-empty set of mjtState bits."""
    if not is_int(spec):
        raise TypeError(f"{name} must be an int of mjtState bits, got {spec!r}")
    if not 0 < spec < 1 << _NSTATE:
        raise ValueError(f"{name} must be a non-empty set of mjtState bits (1 .. "
                         f"{(1 << _NSTATE) - 1}), got {spec}")
    return int(spec)


def get_state(model: mujoco.MjModel, data: mujoco.MjData, spec: int = INTEGRATION) -> np.ndarray:
    """Save ``data``'s state: returns the (ns,) row of ``spec``."""
    check_data(check_model(model), data)
    spec = check_spec(spec)
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    return state


def set_state(model: mujoco.MjModel, data: mujoco.MjData, state: np.ndarray,
              spec: int = INTEGRATION) -> None:
    """Restore a (ns,) row of ``spec`` into ``data`` (derived quantities are not recomputed)."""
    state = check_states(model, state, spec, batched=False)
    check_data(model, data)
    mujoco.mj_setState(model, data, state, spec)


def check_states(model: mujoco.MjModel, states, spec: int = INTEGRATION, *,
                 batched: bool | None = None, name: str = "state") -> np.ndarray:
    """Validate state rows: (ns,) or (P, ns) float, finite. Returns a C-contiguous float64 array.

    ``batched`` True requires (P, ns), False requires (ns,), None accepts either.
    """
    check_model(model)
    arr = float_array(states, name, finite=False)
    ns = mujoco.mj_stateSize(model, check_spec(spec))
    ndim_ok = {None: (1, 2), True: (2,), False: (1,)}[batched]
    if arr.ndim not in ndim_ok or arr.shape[-1] != ns:
        want = {None: f"({ns},) or (P, {ns})", True: f"(P, {ns})", False: f"({ns},)"}[batched]
        raise ValueError(f"{name} must have shape {want} (mjSTATE_INTEGRATION rows), "
                         f"got {arr.shape}")
    if arr.ndim == 2 and arr.shape[0] == 0:
        raise ValueError(f"{name} is empty")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(np.atleast_2d(arr)))[0]
        raise ValueError(f"{name} contains NaN/inf (first at row {bad[0]}, column {bad[1]})")
    if spec & mujoco.mjtState.mjSTATE_QPOS:
        _check_quaternions(model, np.atleast_2d(arr), StateLayout.of(model, spec), name)
    return arr


#: how far a free or ball joint's quaternion in a given state may be from unit norm: MuJoCo
#: normalises quaternions as it integrates, so rows it wrote are unit to rounding; a row far
#: from it (say all zeros, which mj_normalizeQuat silently turns into the identity) is a
#: caller's mistake
QUAT_TOLERANCE = 1e-6


def _check_quaternions(model: mujoco.MjModel, rows: np.ndarray, layout: StateLayout,
                       name: str) -> None:
    """ValueError naming the joint and row if a free or ball joint's quaternion in ``rows``
    (P, ns) is not of unit norm within ``QUAT_TOLERANCE``."""
    kinds = model.jnt_type
    free = kinds == mujoco.mjtJoint.mjJNT_FREE
    ball = kinds == mujoco.mjtJoint.mjJNT_BALL
    if not (free.any() or ball.any()):
        return
    joints = np.flatnonzero(free | ball)
    start = model.jnt_qposadr[joints] + np.where(free[joints], 3, 0) + layout["qpos"].start
    quats = rows[:, start[:, None] + np.arange(4)]                     # (P, J, 4)
    off = np.abs(np.linalg.norm(quats, axis=-1) - 1.0)
    if (off > QUAT_TOLERANCE).any():
        row, j = np.argwhere(off > QUAT_TOLERANCE)[0]
        joint = model.joint(int(joints[j])).name or f"#{int(joints[j])}"
        raise ValueError(f"{name}: the quaternion of joint {joint!r} in row {row} has norm "
                         f"{np.linalg.norm(quats[row, j]):.6g}, not 1 (within "
                         f"{QUAT_TOLERANCE:g})")


def faulty_rows(layout: StateLayout, states: np.ndarray) -> np.ndarray:
    """Which state rows (..., ns) are no valid state: a qpos or qvel entry NaN or beyond
    +-MAXVAL (what MuJoCo's next step would reject), or any entry non-finite -> (...) bool."""
    q, v = states[..., layout["qpos"]], states[..., layout["qvel"]]
    return (~(np.abs(q) <= MAXVAL).all(axis=-1) | ~(np.abs(v) <= MAXVAL).all(axis=-1)
            | ~np.isfinite(states).all(axis=-1))


def fault(layout: StateLayout, row: np.ndarray) -> str | None:
    """Why the state row (ns,) is no valid state, named as MuJoCo's next step would warn:
    "mjWARN_BADQPOS", "mjWARN_BADQVEL", "non-finite state"; None if it is valid."""
    if not (np.abs(row[layout["qpos"]]) <= MAXVAL).all():
        return "mjWARN_BADQPOS"
    if not (np.abs(row[layout["qvel"]]) <= MAXVAL).all():
        return "mjWARN_BADQVEL"
    return None if np.isfinite(row).all() else "non-finite state"


class Tangent:
    """Vectorised tangent-space arithmetic on qpos for one model (free and ball joints use
    quaternions in qpos but 3 angular-velocity DoFs in qvel).

    ``difference`` equals ``mujoco.mj_differentiatePos`` row by row (to rounding), without a
    Python loop; ``perturb`` calls ``mujoco.mj_integratePos`` so that a perturbed state is
    bit-identical to the one ``mjd_transitionFD`` builds.
    """

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        lin_q, lin_v, quat_q, quat_v = [], [], [], []
        for j in range(model.njnt):
            qa, va, jt = model.jnt_qposadr[j], model.jnt_dofadr[j], int(model.jnt_type[j])
            if jt == int(mujoco.mjtJoint.mjJNT_FREE):
                lin_q += range(qa, qa + 3)
                lin_v += range(va, va + 3)
                quat_q.append(qa + 3)
                quat_v.append(va + 3)
            elif jt == int(mujoco.mjtJoint.mjJNT_BALL):
                quat_q.append(qa)
                quat_v.append(va)
            else:
                lin_q.append(qa)
                lin_v.append(va)
        self._lin_q, self._lin_v = np.array(lin_q, int), np.array(lin_v, int)
        self._quat_q = np.array(quat_q, int)[:, None] + np.arange(4)  # (nquat, 4)
        self._quat_v = np.array(quat_v, int)[:, None] + np.arange(3)  # (nquat, 3)
        self._unit = np.eye(model.nv)
        self._parts_cache: dict[bytes, tuple] = {}

    def difference(self, qpos1: np.ndarray, qpos2: np.ndarray, h: float = 1.0,
                   dofs: np.ndarray | None = None) -> np.ndarray:
        """Velocity taking qpos1 to qpos2 in time h: (..., nq), (..., nq) -> (..., nv), or
        (..., len(dofs)) for just the DoFs ``dofs`` (sorted, unique). Leading dimensions
        broadcast against each other."""
        lin_q, lin_v, quat_q, quat_v = self._parts(dofs)
        lead = np.broadcast_shapes(qpos1.shape, qpos2.shape)[:-1]
        out = np.empty(lead + (self.model.nv,))
        inv_h = 1.0 / h
        out[..., lin_v] = inv_h * (qpos2[..., lin_q] - qpos1[..., lin_q])
        if len(quat_q):
            out[..., quat_v] = inv_h * _quat_difference(qpos1[..., quat_q], qpos2[..., quat_q])
        return out if dofs is None else out[..., dofs]

    def _parts(self, dofs: np.ndarray | None):
        """Index arrays of the linear and quaternion parts needed for ``dofs`` (None: all);
        cached per DoF set, since hot loops difference the same set at every step."""
        if dofs is None:
            return self._lin_q, self._lin_v, self._quat_q, self._quat_v
        key = np.asarray(dofs, dtype=np.int64).tobytes()
        parts = self._parts_cache.get(key)
        if parts is None:
            lin = np.isin(self._lin_v, dofs)
            quat = np.isin(self._quat_v, dofs).any(axis=1)
            parts = self._lin_q[lin], self._lin_v[lin], self._quat_q[quat], self._quat_v[quat]
            if len(self._parts_cache) >= 256:
                self._parts_cache.clear()
            self._parts_cache[key] = parts
        return parts

    def perturb(self, qpos: np.ndarray, dofs: np.ndarray, eps: float) -> np.ndarray:
        """Move each row of qpos (B, nq) by eps along tangent DoF dofs[b] (B,) -> (B, nq).

        Exactly ``mj_integratePos(model, qpos[b], e_dofs[b], eps)``, as mjd_transitionFD does.
        """
        out = np.array(qpos, dtype=np.float64, copy=True)
        for row, dof in zip(out, dofs, strict=True):
            mujoco.mj_integratePos(self.model, row, self._unit[dof], eps)
        return out


def _quat_difference(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """Rotation vector of conj(qa) * qb after normalising both: (..., 4), (..., 4) -> (..., 3).

    As mju_subQuat (angle wrapped to (-pi, pi]); written with few numpy calls because the MPC
    and line-search loops call it at every step on a handful of quaternions."""
    qa = qa / np.sqrt(np.einsum("...i,...i->...", qa, qa))[..., None]
    qb = qb / np.sqrt(np.einsum("...i,...i->...", qb, qb))[..., None]
    aw, bw = qa[..., :1], qb[..., :1]
    av, bv = qa[..., 1:], qb[..., 1:]
    w = aw[..., 0] * bw[..., 0] + np.einsum("...i,...i->...", av, bv)
    v = aw * bv - bw * av - np.cross(av, bv)
    s = np.sqrt(np.einsum("...i,...i->...", v, v))
    angle = 2.0 * np.arctan2(s, w)
    angle = np.where(angle > np.pi, angle - 2.0 * np.pi, angle)
    scale = np.divide(angle, s, out=np.zeros_like(s), where=s > 1e-15)
    return v * scale[..., None]
