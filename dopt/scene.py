"""A compiled MuJoCo model with named groups of DoFs.

Groups are built automatically and may be extended by the caller:

- ``robot``: every DoF of a kinematic tree that an actuator drives (through a joint);
- ``object:<name>``: every DoF of another tree with joints, named after its root body;
- ``vertex:<i>``: the DoFs of flex vertex i (vertices numbered across all flexes);
  ``flex:<name>``: all vertex DoFs of that flex;
- ``joint:<name>``: the DoFs of one named joint.

A DoF set is a sorted array of indices into qvel (the tangent space): a free joint has 6 DoFs,
a ball joint 3, hinge and slide 1. ``tangent_indices`` maps it into the 2*nv tangent state
[dq; dv] that ``mjd_transitionFD`` uses.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping

import mujoco
import numpy as np

from dopt.stability import Monitor, StabilityBounds
from dopt.state import INTEGRATION, StateLayout, Tangent, check_data
from dopt.validation import index_array


class Scene:
    """A compiled MjModel plus named DoF groups.

    Args:
        model: the compiled model.
        groups: extra or overriding groups, name -> DoF indices (into qvel).
        stability: the bounds every rollout on this scene is judged by (``dopt.stability``).
    """

    def __init__(self, model: mujoco.MjModel, groups: Mapping[str, Iterable[int]] | None = None,
                 stability: StabilityBounds = StabilityBounds()):
        if not isinstance(model, mujoco.MjModel):
            raise TypeError(f"model must be a mujoco.MjModel, got {type(model).__name__}")
        self.model = model
        self.monitor = Monitor(model, stability)
        self.layout = StateLayout.of(model, INTEGRATION)
        self.tangent = Tangent(model)
        self.groups: dict[str, np.ndarray] = _default_groups(model)
        for name, dofs in (groups or {}).items():
            if not isinstance(name, str):
                raise TypeError(f"groups: DoF group names must be str, got {name!r}")
            if isinstance(dofs, str):
                raise TypeError(f"groups[{name!r}] must be DoF indices, got {dofs!r}")
            if isinstance(dofs, Iterable) and not isinstance(dofs, np.ndarray):
                dofs = list(dofs)
            self.groups[name] = self._checked_dofs(dofs, name)

    @classmethod
    def from_xml(cls, xml: str, groups: Mapping[str, Iterable[int]] | None = None,
                 stability: StabilityBounds = StabilityBounds()) -> Scene:
        """Compile an MJCF string."""
        if not isinstance(xml, str):
            raise TypeError(f"xml must be an MJCF string, got {type(xml).__name__}")
        return cls(mujoco.MjModel.from_xml_string(xml), groups, stability)

    @property
    def stability(self) -> StabilityBounds:
        """The bounds every rollout on this scene is judged by."""
        return self.monitor.bounds

    @property
    def nv(self) -> int:
        return self.model.nv

    @property
    def nu(self) -> int:
        return self.model.nu

    @property
    def nstate(self) -> int:
        """Length ns of one mjSTATE_INTEGRATION row."""
        return self.layout.size

    def dofs(self, *names: str) -> np.ndarray:
        """Union of the named groups as a sorted DoF index array (into qvel).

        ``dofs()`` with no name is every DoF. Unknown names raise ValueError.
        """
        if not names:
            return np.arange(self.nv)
        parts = []
        for name in names:
            if not isinstance(name, str):
                raise TypeError(f"DoF group names must be str, got {name!r}")
            if name not in self.groups:
                close = difflib.get_close_matches(name, self.groups, n=3)
                hint = f"; did you mean {close}?" if close else ""
                raise ValueError(f"unknown DoF group {name!r}{hint} "
                                 f"({len(self.groups)} groups, e.g. {list(self.groups)[:6]})")
            parts.append(self.groups[name])
        return np.unique(np.concatenate(parts))

    def as_dofs(self, dofs) -> np.ndarray:
        """Accept a group name, a list of names, or DoF indices; return sorted unique indices.

        Indices must be ints in [0, nv) (no negative wrap-around; floats, bools and NaN raise
        TypeError); names must be known groups."""
        if isinstance(dofs, str):
            return self.dofs(dofs)
        if dofs is None:
            raise TypeError("dofs must be DoF indices or group names, got None")
        names = _names(dofs)
        if names is not None:
            return self.dofs(*names)
        return self._checked_dofs(dofs, "dofs")

    def tangent_indices(self, dofs) -> np.ndarray:
        """Indices of the DoF set in the 2*nv tangent state [dq; dv]: (2|C|,)."""
        d = self.as_dofs(dofs)
        return np.concatenate([d, self.nv + d])

    def qpos_indices(self, dofs) -> np.ndarray:
        """qpos entries that the DoF set moves: for a free or ball joint's rotational DoFs, the
        whole quaternion (4 entries), otherwise one entry per DoF. Sorted, unique."""
        d = self.as_dofs(dofs)
        m = self.model
        out = []
        for dof in d:
            j = m.dof_jntid[dof]
            qa, k, jt = m.jnt_qposadr[j], dof - m.jnt_dofadr[j], int(m.jnt_type[j])
            if jt == int(mujoco.mjtJoint.mjJNT_FREE):
                out += [qa + k] if k < 3 else range(qa + 3, qa + 7)
            elif jt == int(mujoco.mjtJoint.mjJNT_BALL):
                out += range(qa, qa + 4)
            else:
                out.append(qa)
        return np.unique(np.asarray(out, dtype=int))

    def linear_qpos_indices(self, dofs) -> np.ndarray:
        """qpos index of each DoF, in the given order (group names: sorted), for DoFs whose
        tangent coordinate is their qpos coordinate (hinge, slide, free-joint translation);
        ValueError for the rotational DoFs of ball and free joints. Indices are checked as in
        ``as_dofs``."""
        if isinstance(dofs, str) or _names(dofs) is not None:
            order = self.as_dofs(dofs)
        elif dofs is None:
            raise TypeError("dofs must be DoF indices or group names, got None")
        else:
            order = index_array(dofs, "dofs", self.nv)
        m, out = self.model, []
        for dof in order:
            j = m.dof_jntid[dof]
            k, jt = dof - m.jnt_dofadr[j], int(m.jnt_type[j])
            if jt == int(mujoco.mjtJoint.mjJNT_BALL) or (
                    jt == int(mujoco.mjtJoint.mjJNT_FREE) and k >= 3):
                raise ValueError(f"DoF {dof} is rotational (ball/free joint): it has no single "
                                 "qpos coordinate")
            out.append(int(m.jnt_qposadr[j] + k))
        return np.asarray(out, dtype=int)

    def state_of(self, data: mujoco.MjData) -> np.ndarray:
        """The (ns,) mjSTATE_INTEGRATION row of data."""
        check_data(self.model, data)
        state = np.empty(self.nstate)
        mujoco.mj_getState(self.model, data, state, INTEGRATION)
        return state

    def _checked_dofs(self, dofs, what: str) -> np.ndarray:
        """DoF indices -> sorted unique int array; ``what`` names them in errors."""
        return np.unique(index_array(dofs, what, self.nv))


def _names(dofs) -> list[str] | None:
    """The group names in ``dofs`` (a list or array of str), None if it holds no str."""
    if isinstance(dofs, np.ndarray):
        if dofs.dtype.kind == "U" or (dofs.dtype == object and dofs.size
                                      and all(isinstance(n, str) for n in dofs.ravel())):
            return [str(n) for n in dofs.ravel()]
        return None
    if isinstance(dofs, (list, tuple)) and dofs and all(isinstance(n, str) for n in dofs):
        return list(dofs)
    return None


_JOINT_NDOF = {int(mujoco.mjtJoint.mjJNT_FREE): 6, int(mujoco.mjtJoint.mjJNT_BALL): 3}


def _default_groups(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """robot / object:<root body> / vertex:<i> / flex:<name> / joint:<name> groups."""
    groups: dict[str, list[int]] = {}

    def name_of(kind, i, fallback):
        return mujoco.mj_id2name(model, kind, i) or f"{fallback}{i}"

    vertex_bodies = {}
    for f in range(model.nflex):
        fname = name_of(mujoco.mjtObj.mjOBJ_FLEX, f, "flex")
        start, n = model.flex_vertadr[f], model.flex_vertnum[f]
        for v in range(start, start + n):
            body = int(model.flex_vertbodyid[v])
            if body > 0 and model.body_dofnum[body] > 0:
                vertex_bodies[body] = (v, fname)

    actuated_roots = set()
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) in (int(mujoco.mjtTrn.mjTRN_JOINT),
                                              int(mujoco.mjtTrn.mjTRN_JOINTINPARENT)):
            body = model.jnt_bodyid[model.actuator_trnid[a, 0]]
            actuated_roots.add(int(model.body_rootid[body]))

    for body in range(1, model.nbody):
        adr, n = model.body_dofadr[body], model.body_dofnum[body]
        if n == 0:
            continue
        dofs = list(range(adr, adr + n))
        if body in vertex_bodies:
            v, fname = vertex_bodies[body]
            groups.setdefault(f"vertex:{v}", []).extend(dofs)
            groups.setdefault(f"flex:{fname}", []).extend(dofs)
            continue
        root = int(model.body_rootid[body])
        key = "robot" if root in actuated_roots else \
            f"object:{name_of(mujoco.mjtObj.mjOBJ_BODY, root, 'body')}"
        groups.setdefault(key, []).extend(dofs)

    for j in range(model.njnt):
        jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        if jname:
            adr = model.jnt_dofadr[j]
            n = _JOINT_NDOF.get(int(model.jnt_type[j]), 1)
            groups[f"joint:{jname}"] = list(range(adr, adr + n))
    return {k: np.unique(np.asarray(v, dtype=int)) for k, v in groups.items()}
