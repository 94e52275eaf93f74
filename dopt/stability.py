"""A stability verdict on every rollout: physical bounds that MuJoCo itself does not check.

MuJoCo flags a simulation only when a value is NaN or beyond +-1e10. A cloth can go 7 cm
through the floor and be thrown a metre up at 22 m/s with every state finite and no warning.
``StabilityBounds`` (part of a ``dopt.Scene``) names what a trustworthy step must keep:

- speed (m/s), the largest of two kinds, each read from qvel alone:
  - the translational speed of a body moved by a free joint or by slide joints (flex
    particles, picker, free objects), |v| over its linear DoFs (for slide joints the norm over
    up to three of them, which is the speed when their axes are orthonormal, as a flexcomp's
    and the picker's are);
  - the speed of the farthest geometry of a body turned by its own hinge or ball joints (an
    arm's links): sum_j |w_j| r_j over those joints j, where |w_j| is the joint's angular
    speed (|qvel| of a hinge, the norm of a ball's three qvel) and
    r_j = max_g (|p_g - a_j| + rbound_g) over the geoms g of the body and of the bodies welded
    to it (descendants through bodies without joints), p_g the geom's centre and a_j the
    joint's anchor (``jnt_pos``) in the body's frame, rbound_g MuJoCo's bounding-sphere radius
    of the geom. It bounds the speed of every point of that geometry relative to the parent
    body (as the slide joints' speed is relative to theirs: each joint of a chain is judged on
    its own body) and equals it for one joint whose farthest point lies square to its axis
    (a hinge link: |qvel| times the distance from the axis to its tip). The rotation of free
    joints is not judged, and a body without geometry is not either;
- penetration: the deepest flex vertex below a static plane (the floor), counting the
  vertex radius, r - n.(x - p) (m);
- strain: the largest relative length change of a flex edge, |l / l0 - 1|, over the edges
  none of whose vertices an active equality holds (a picker's grasp of one particle is a point
  load whose local stretch belongs to the grasp model; ``strain_at_grasps`` judges them too);
- capped steps: steps whose constraint solver stopped at its iteration cap (counted; a bound
  only if ``max_capped_steps`` is set: CG at 30 iterations caps on cloth often and harmlessly);
- energy gain (only if ``max_energy_gain`` is set): within a *free window*, a run of steps in
  which nothing does work on the judged system (no equality that attaches an unjudged body,
  such as a picker's grasp, is active, and no actuator outside the unjudged bodies exerts a
  force), the model's mechanical energy (MuJoCo's potential + kinetic, ``mjENBL_ENERGY``) can
  only fall; its rise above the lowest value since the window began, per kg of judged mass
  (J/kg), is judged. Soft contacts store and give back a little (a few hundredths of a J/kg
  under the presets' random actions, docs/DESIGN-NOTES.md "Energy"); a cloth thrown 1 m up
  gains about 10 J/kg.

MuJoCo's own warnings and non-finite states stay unstable as before. ``Monitor`` evaluates the
bounds on the fields MuJoCo leaves in MjData after step t: qvel of state t+1, flex vertex
positions, edge lengths and energy of state t (computed during step t), eq_active and
actuator forces applied in step t. The C loops of
``dopt/_rollout_kernels.c`` evaluate the same expressions in the same order, so both rollout
routes give the same verdict (tested).

Shapes: P rollouts, K steps of a chunk, G groups of linear DoFs (a body each), R bodies turned by
their hinge or ball joints (W of those joints at most on one body), V flex vertices, E flex
edges.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.validation import check_config


@dataclass(frozen=True)
class StabilityBounds:
    """What a step must keep to count as physical (see the module docstring).

    Attributes:
        max_speed: m/s, translational speed of any body on a free joint or slide joints, and
            speed of the farthest geometry of any body turned by its hinge or ball joints.
        max_penetration: m, depth of any flex vertex (radius included) below a static plane.
        max_strain: relative elongation or compression |l / l0 - 1| of any flex edge.
        max_capped_steps: steps at the solver's iteration cap a rollout may take (None: counted
            and reported, never unstable).
        unjudged_bodies: names of bodies whose speed is not judged: virtual actuators such as
            the pick scenes' massless picker, which snaps onto a particle at up to 15 m/s.
        strain_at_grasps: judge the strain of edges at a vertex an active equality holds (a
            grasped particle) too; by default they are left out.
        max_energy_gain: J per kg of judged mass: the largest rise of the mechanical energy
            within a free window (module docstring). None: not judged. Setting it turns on
            MuJoCo's energy computation (``mjENBL_ENERGY``) in the scene's model, which reads
            the state and changes no dynamics.
    """

    max_speed: float = 5.0
    max_penetration: float = 0.02
    max_strain: float = 0.5
    max_capped_steps: int | None = None
    unjudged_bodies: tuple[str, ...] = ()
    strain_at_grasps: bool = False
    max_energy_gain: float | None = None

    def __post_init__(self):
        check_config(self, positive=("max_speed", "max_penetration", "max_strain",
                                     "max_energy_gain"),
                     minimum={"max_capped_steps": 0})


@dataclass(frozen=True)
class Stability:
    """The verdict on P rollouts.

    Attributes:
        unstable: (P,) bool; step: (P,) int, the step that first broke a bound or warned
            (-1 where stable); reason: P strings naming it ("" where stable);
        max_speed, max_penetration, max_strain: (P,) the largest values seen up to the end of
            the rollout (or the step it was stopped at); capped_steps: (P,) int;
        max_energy_gain: (P,) J/kg, the largest energy gain within a free window (0 where the
            bound is not set).
    """

    unstable: np.ndarray
    step: np.ndarray
    reason: tuple
    max_speed: np.ndarray
    max_penetration: np.ndarray
    max_strain: np.ndarray
    capped_steps: np.ndarray
    max_energy_gain: np.ndarray

    @property
    def n_unstable(self) -> int:
        return int(self.unstable.sum())

    def first(self) -> tuple[int, int, str] | None:
        """(rollout, step, reason) of the earliest unstable step (lowest rollout on a tie),
        or None if all are stable."""
        if not self.unstable.any():
            return None
        idx = np.flatnonzero(self.unstable)
        i = int(idx[np.argmin(self.step[idx])])
        return i, int(self.step[i]), self.reason[i]


class Monitor:
    """The bounds of one model, evaluated on batches of MjData fields (see ``scan``).

    Attributes (read by the C loops too): groups (G, 3) int32 qvel indices of each body's
    linear DoFs, -1 padded; group_body (G,) their bodies; spin_dofs (R, W, 3) int32 the qvel
    indices of the angular velocity of each hinge (one) or ball (three) joint of each body
    turned by them, -1 padded, and spin_radius (R, W) their r_j (module docstring; 0 for a
    padding slot); spin_body (R,) those bodies; speed_body (G + R,) the body of each speed
    candidate, linear groups first (the index ``speed`` returns); planes (nplane, 4) unit normal and
    offset n.p of each static plane geom; radius (V,) flex vertex radii; length0 (E,) rest
    lengths of the flex edges; edge_grasps (E, w) int32 the equality constraints attaching a
    body to either vertex of each edge, -1 padded (w = 0: none, or ``strain_at_grasps``);
    iteration_cap: the solver's iteration limit; energy_judged: whether the energy bound is
    set; window_eqs (nw,) int32 the equalities that attach an unjudged body (active: no free
    window); working_actuators (na,) int32 the actuators that can do work on the judged system
    (all but those on the joints of unjudged bodies); energy_mass: kg of the judged bodies.
    """

    def __init__(self, model: mujoco.MjModel, bounds: StabilityBounds = StabilityBounds()):
        if not isinstance(bounds, StabilityBounds):
            raise TypeError(f"bounds must be a StabilityBounds, got {type(bounds).__name__}")
        self.model, self.bounds = model, bounds
        unjudged = _body_ids(model, bounds.unjudged_bodies)
        self.groups, self.group_body = _linear_groups(model, unjudged)
        self.spin_dofs, self.spin_radius, self.spin_body = _spin_groups(model, unjudged)
        self.speed_body = np.concatenate([self.group_body, self.spin_body]).astype(np.int32)
        self.energy_judged = bounds.max_energy_gain is not None
        if self.energy_judged:
            model.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_ENERGY)
        self.window_eqs = _equalities_attaching(model, unjudged)
        self.working_actuators = _actuators_outside(model, unjudged)
        self.energy_mass = float(sum(model.body_mass[b] for b in range(1, model.nbody)
                                     if b not in unjudged))
        if self.energy_judged and not self.energy_mass > 0:
            raise ValueError("StabilityBounds.max_energy_gain: the model has no judged mass")
        self.planes = _static_planes(model)
        self.radius = np.repeat(model.flex_radius, model.flex_vertnum).astype(float)
        self.length0 = np.array(model.flexedge_length0, dtype=float)
        self.iteration_cap = int(model.opt.iterations)
        self.has_flex = model.nflexvert > 0
        self.has_edges = bool((self.length0 > 0).any())
        self.edge_grasps = (np.zeros((len(self.length0), 0), np.int32)
                            if bounds.strain_at_grasps else _edge_equalities(model))
        self._safe_length0 = np.where(self.length0 > 0, self.length0, 1.0)

    @property
    def record(self) -> tuple[str, ...]:
        """The MjData fields ``scan`` reads."""
        items = ["qvel", "solver_niter"]
        if self.has_flex:
            items += ["flexvert_xpos", "flexedge_length"]
        if self.edge_grasps.shape[1] or (self.energy_judged and len(self.window_eqs)):
            items.append("eq_active")
        if self.energy_judged:
            items.append("energy")
            if len(self.working_actuators):
                items.append("actuator_force")
        return tuple(items)

    # ---------------------------------------------------------------- per step values
    def speed(self, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(..., nv) -> largest body speed (...), linear or of the farthest geometry turned by
        hinge and ball joints (module docstring), and which candidate (...): i < G the linear
        group i, else the turned body i - G (``speed_body[i]`` names the body either way)."""
        if not len(self.speed_body):
            z = np.zeros(qvel.shape[:-1])
            return z, z.astype(int)
        padded = np.concatenate([qvel, np.zeros(qvel.shape[:-1] + (1,))], axis=-1)
        v = padded[..., self.groups]                                   # (..., G, 3)
        lin = np.sqrt(v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1] + v[..., 2] * v[..., 2])
        w = padded[..., self.spin_dofs]                                # (..., R, W, 3)
        tip = np.sqrt(w[..., 0] * w[..., 0] + w[..., 1] * w[..., 1]
                      + w[..., 2] * w[..., 2]) * self.spin_radius      # (..., R, W)
        spin = np.zeros(tip.shape[:-1])
        for k in range(tip.shape[-1]):             # summed in slot order, as the C loop
            spin = spin + tip[..., k]
        s = np.concatenate([lin, spin], axis=-1)                       # (..., G + R)
        s = np.where(np.isnan(s), -np.inf, s)
        i = s.argmax(axis=-1)
        return np.take_along_axis(s, i[..., None], -1)[..., 0], i

    def penetration(self, xpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(..., V, 3) vertex positions -> deepest penetration (...) and which vertex."""
        if not len(self.planes) or not self.has_flex:
            z = np.zeros(xpos.shape[:-2])
            return z, z.astype(int)
        n, off = self.planes[:, :3], self.planes[:, 3]
        dist = (xpos[..., None, 0] * n[:, 0] + xpos[..., None, 1] * n[:, 1]
                + xpos[..., None, 2] * n[:, 2]) - off                  # (..., V, nplane)
        depth = (self.radius[:, None] - dist).max(axis=-1)             # (..., V)
        depth = np.where(np.isnan(depth), -np.inf, depth)
        i = depth.argmax(axis=-1)
        return np.take_along_axis(depth, i[..., None], -1)[..., 0], i

    def strain(self, length: np.ndarray, eq_active: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        """(..., E) edge lengths -> largest |l / l0 - 1| (...) and which edge; with eq_active
        (..., neq), edges at a vertex an active equality holds are left out."""
        if not self.has_edges:
            z = np.zeros(length.shape[:-1])
            return z, z.astype(int)
        e = np.abs(length / self._safe_length0 - 1.0)
        e = np.where((self.length0 > 0) & ~np.isnan(e), e, -np.inf)
        if eq_active is not None and self.edge_grasps.shape[1]:
            active = np.concatenate([np.asarray(eq_active, bool),
                                     np.zeros(eq_active.shape[:-1] + (1,), bool)], axis=-1)
            e = np.where(active[..., self.edge_grasps].any(axis=-1), -np.inf, e)
        i = e.argmax(axis=-1)
        return np.take_along_axis(e, i[..., None], -1)[..., 0], i

    def capped(self, niter: np.ndarray) -> np.ndarray:
        """(..., nisland) solver iterations -> whether any island hit the cap (...)."""
        return (niter >= self.iteration_cap).any(axis=-1)

    def free(self, fields: dict, shape: tuple) -> np.ndarray:
        """Whether nothing did work on the judged system in each step (``shape``, e.g.
        (n, K)), from the recorded fields eq_active (..., neq) and actuator_force (..., nu)."""
        out = np.ones(shape, bool)
        if len(self.window_eqs):
            out &= ~np.asarray(fields["eq_active"], bool)[..., self.window_eqs].any(axis=-1)
        if len(self.working_actuators):
            out &= (fields["actuator_force"][..., self.working_actuators] == 0).all(axis=-1)
        return out

    def energy_gain(self, energy: np.ndarray, free: np.ndarray, low: np.ndarray,
                    was_free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Energy gain of K steps of n rollouts (J/kg): energy (n, K, 2) of states t, free
        (n, K) whether step t was free; low (n,), was_free (n,) the window carried in from
        the steps before. The energy of state t is judged if step t-1 was free, against the
        lowest energy since its window began (the state its first free step started from).
        Returns (gain (n, K), low, was_free after the K steps)."""
        e_all = energy[..., 0] + energy[..., 1]
        gain = np.zeros(e_all.shape)
        low, was_free = low.copy(), was_free.copy()
        for k in range(e_all.shape[1]):
            e = e_all[:, k]
            gain[:, k] = np.where(was_free, (e - low) / self.energy_mass, 0.0)
            low = np.where(was_free & (e < low), e, low)
            low = np.where(free[:, k] & ~was_free, e, low)
            was_free = free[:, k].copy()
        return gain, low, was_free

    # ------------------------------------------------------------------ scanning
    def start(self, n: int) -> Scan:
        """A verdict in progress for n rollouts."""
        return Scan(self, n)

    def reason(self, bound: str, value: float, index: int) -> str:
        """The reason text of a violated bound."""
        b, m = self.bounds, self.model
        if bound == "speed":
            b_id = int(self.speed_body[index])
            body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b_id)
            where = " at its farthest geometry" if index >= len(self.groups) else ""
            return (f"speed {value:.3g} m/s > {b.max_speed:g} m/s{where} (body "
                    f"{body or b_id})")
        if bound == "penetration":
            return (f"penetration {value * 1e3:.3g} mm > {b.max_penetration * 1e3:g} mm (flex "
                    f"vertex {index})")
        if bound == "strain":
            return f"strain {value:.3g} > {b.max_strain:g} (flex edge {index})"
        if bound == "energy":
            return (f"energy gain {value:.3g} J/kg > {b.max_energy_gain:g} J/kg (while nothing "
                    f"did work on the system)")
        return (f"capped_steps {int(value)} > {b.max_capped_steps} (solver at its "
                f"{self.iteration_cap}-iteration cap)")


class Scan:
    """Running verdict of n rollouts, fed chunk by chunk (``update``) in step order."""

    def __init__(self, monitor: Monitor, n: int):
        self.monitor = monitor
        self.step = np.full(n, -1)
        self.reason = [""] * n
        self.max_speed = np.zeros(n)
        self.max_penetration = np.zeros(n)
        self.max_strain = np.zeros(n)
        self.capped = np.zeros(n, dtype=int)
        self.max_energy_gain = np.zeros(n)
        self.low = np.zeros(n)                   # the energy window in progress
        self.was_free = np.zeros(n, bool)

    @property
    def unstable(self) -> np.ndarray:
        return self.step >= 0

    def update(self, rows: np.ndarray, step0: int, fields: dict, nstep: np.ndarray | None = None
               ) -> np.ndarray:
        """Fold K steps of MjData fields into the verdict of rollouts ``rows`` (n,).

        fields: ``Monitor.record`` name -> (n, K, ...) as after steps step0 .. step0+K-1.
        nstep: (n,) how many of the K steps each row really took (default K), e.g. a
        simulation stopped by a warning. Only the steps before a row's first violation count.
        Returns the rows (a subset of ``rows``) that became unstable in this chunk.
        """
        mon, b = self.monitor, self.monitor.bounds
        K = fields["qvel"].shape[1]
        speed, sp_i = mon.speed(fields["qvel"])                             # (n, K)
        if mon.has_flex:
            pen, pen_i = mon.penetration(fields["flexvert_xpos"])
            strain, st_i = mon.strain(fields["flexedge_length"], fields.get("eq_active"))
        else:
            pen = strain = np.zeros_like(speed)
            pen_i = st_i = np.zeros(speed.shape, int)
        capped = mon.capped(fields["solver_niter"])
        valid = np.ones(speed.shape, bool) if nstep is None else \
            np.arange(K)[None, :] < np.asarray(nstep)[:, None]
        cum_capped = self.capped[rows][:, None] + np.cumsum(capped & valid, axis=1)
        zero = np.zeros_like(sp_i)
        # (bound name, broken, value, index) in the order they are checked within one step,
        # the order of the C file's judge()
        checks = [("speed", speed > b.max_speed, speed, sp_i),
                  ("penetration", pen > b.max_penetration, pen, pen_i),
                  ("strain", strain > b.max_strain, strain, st_i)]
        if b.max_capped_steps is not None:
            checks.append(("capped_steps", cum_capped > b.max_capped_steps,
                           cum_capped.astype(float), zero))
        gain = np.zeros(speed.shape)
        if mon.energy_judged:
            gain, self.low[rows], self.was_free[rows] = mon.energy_gain(
                fields["energy"], mon.free(fields, speed.shape), self.low[rows],
                self.was_free[rows])
            checks.append(("energy", gain > b.max_energy_gain, gain, zero))
        broke = np.zeros(speed.shape, bool)
        for _, over, _, _ in checks:
            broke |= over
        broke &= valid
        newly = []
        for j, r in enumerate(rows):
            if self.step[r] >= 0:
                continue
            hit = np.flatnonzero(broke[j])
            last = hit[0] if len(hit) else (K if nstep is None else int(nstep[j]))
            upto = slice(0, last + 1 if len(hit) else last)
            self.max_speed[r] = max(self.max_speed[r], _max(speed[j, upto]))
            self.max_penetration[r] = max(self.max_penetration[r], _max(pen[j, upto]))
            self.max_strain[r] = max(self.max_strain[r], _max(strain[j, upto]))
            self.capped[r] = int(cum_capped[j, upto.stop - 1]) if upto.stop else self.capped[r]
            self.max_energy_gain[r] = max(self.max_energy_gain[r], _max(gain[j, upto]))
            if len(hit):
                k = hit[0]
                name, _, value, index = next(c for c in checks if c[1][j, k])
                self.step[r] = step0 + k
                self.reason[r] = mon.reason(name, float(value[j, k]), int(index[j, k]))
                newly.append(r)
        return np.array(newly, dtype=int)

    def flag(self, row: int, step: int, reason: str) -> None:
        """Mark a row unstable at ``step`` for a reason found elsewhere (a MuJoCo warning, a
        non-finite state), unless a bound already broke at an earlier step (at the same step
        the warning wins, as in the C loops, which check it first)."""
        if self.step[row] < 0 or step <= self.step[row]:
            self.step[row], self.reason[row] = step, reason

    def result(self) -> Stability:
        return Stability(self.step >= 0, self.step.copy(), tuple(self.reason),
                         self.max_speed.copy(), self.max_penetration.copy(),
                         self.max_strain.copy(), self.capped.copy(),
                         self.max_energy_gain.copy())


def _max(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(x.max()) if len(x) else 0.0


def _body_ids(model: mujoco.MjModel, names: tuple[str, ...]) -> set[int]:
    """Body ids of names; ValueError naming an unknown body."""
    out = set()
    for name in names:
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if b < 0:
            raise ValueError(f"StabilityBounds.unjudged_bodies: the model has no body {name!r}")
        out.add(b)
    return out


def _linear_groups(model: mujoco.MjModel, skip: set[int]) -> tuple[np.ndarray, np.ndarray]:
    """(G, 3) qvel indices of the linear DoFs of each body on a free joint or slide joints
    (-1 padded), and (G,) the bodies; bodies in ``skip`` left out."""
    per_body: dict[int, list[int]] = {}
    for j in range(model.njnt):
        jt, b, v = int(model.jnt_type[j]), int(model.jnt_bodyid[j]), int(model.jnt_dofadr[j])
        if b in skip:
            continue
        if jt == mujoco.mjtJoint.mjJNT_FREE:
            per_body.setdefault(b, []).extend(range(v, v + 3))
        elif jt == mujoco.mjtJoint.mjJNT_SLIDE:
            per_body.setdefault(b, []).append(v)
    groups, bodies = [], []
    for b, dofs in per_body.items():
        for k in range(0, len(dofs), 3):        # more than 3 slides: groups of 3
            part = dofs[k:k + 3]
            groups.append(part + [-1] * (3 - len(part)))
            bodies.append(b)
    return (np.array(groups, dtype=np.int32).reshape(-1, 3),
            np.array(bodies, dtype=np.int32))


def _spin_groups(model: mujoco.MjModel, skip: set[int]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, W, 3) int32 qvel indices of the angular velocity of each hinge or ball joint of each
    body turned by them (-1 padded), (R, W) the joints' r_j (module docstring; 0 in padding),
    and (R,) the bodies; bodies in ``skip``, and joints whose body has no geometry, left out."""
    per_body: dict[int, list[tuple[list[int], float]]] = {}
    points = {}                             # body -> (n, 4): geom centres in its frame, rbound
    for j in range(model.njnt):
        jt, b, v = int(model.jnt_type[j]), int(model.jnt_bodyid[j]), int(model.jnt_dofadr[j])
        if b in skip:
            continue
        if jt == mujoco.mjtJoint.mjJNT_HINGE:
            dofs = [v, -1, -1]
        elif jt == mujoco.mjtJoint.mjJNT_BALL:
            dofs = [v, v + 1, v + 2]
        else:
            continue
        if b not in points:
            points[b] = _welded_geoms(model, b)
        p = points[b]
        if not len(p):
            continue
        r = float(np.max(np.linalg.norm(p[:, :3] - model.jnt_pos[j], axis=1) + p[:, 3]))
        per_body.setdefault(b, []).append((dofs, r))
    width = max((len(e) for e in per_body.values()), default=0)
    dofs = np.full((len(per_body), width, 3), -1, np.int32)
    radius = np.zeros((len(per_body), width))
    for i, entries in enumerate(per_body.values()):
        for k, (d, r) in enumerate(entries):
            dofs[i, k], radius[i, k] = d, r
    return dofs, radius, np.array(list(per_body), dtype=np.int32)


def _welded_geoms(model: mujoco.MjModel, body: int) -> np.ndarray:
    """(n, 4): centre (in ``body``'s frame) and bounding radius of each geom of ``body`` and of
    the bodies welded to it (descendants reached through bodies without joints)."""
    out = []
    stack = [(body, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))]   # body, its pose in `body`
    while stack:
        b, pos, quat = stack.pop()
        for g in range(model.body_geomadr[b], model.body_geomadr[b] + model.body_geomnum[b]):
            p = np.empty(3)
            mujoco.mju_rotVecQuat(p, model.geom_pos[g], quat)
            out.append([*(pos + p), float(model.geom_rbound[g])])
        for c in np.flatnonzero(model.body_parentid == b):
            if c == b or model.body_jntnum[c]:
                continue
            p, q = np.empty(3), np.empty(4)
            mujoco.mju_rotVecQuat(p, model.body_pos[c], quat)
            mujoco.mju_mulQuat(q, quat, model.body_quat[c])
            stack.append((int(c), pos + p, q))
    return np.array(out, dtype=float).reshape(-1, 4)


def _equalities_attaching(model: mujoco.MjModel, bodies: set[int]) -> np.ndarray:
    """(nw,) int32: the connect and weld equalities one of whose bodies (or sites' bodies)
    is in ``bodies``."""
    out = []
    for i in range(model.neq):
        if int(model.eq_type[i]) not in (int(mujoco.mjtEq.mjEQ_CONNECT),
                                         int(mujoco.mjtEq.mjEQ_WELD)):
            continue
        ids = (int(model.eq_obj1id[i]), int(model.eq_obj2id[i]))
        if int(model.eq_objtype[i]) == int(mujoco.mjtObj.mjOBJ_SITE):
            ids = tuple(int(model.site_bodyid[k]) for k in ids)
        if bodies.intersection(ids):
            out.append(i)
    return np.array(out, dtype=np.int32)


def _actuators_outside(model: mujoco.MjModel, bodies: set[int]) -> np.ndarray:
    """(na,) int32: the actuators that do not drive a joint of a body in ``bodies`` (those
    with another transmission count as able to do work on anything)."""
    joint = (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))
    return np.array([a for a in range(model.nu)
                     if not (int(model.actuator_trntype[a]) in joint
                             and int(model.jnt_bodyid[model.actuator_trnid[a, 0]]) in bodies)],
                    dtype=np.int32)


def _edge_equalities(model: mujoco.MjModel) -> np.ndarray:
    """(E, w) int32: the equality constraints (between bodies) that attach a body to either
    vertex of each flex edge, -1 padded; w is the most any edge has (0: none)."""
    by_body: dict[int, list[int]] = {}
    for i in range(model.neq):
        if model.eq_objtype[i] != mujoco.mjtObj.mjOBJ_BODY:
            continue
        for body in (int(model.eq_obj1id[i]), int(model.eq_obj2id[i])):
            if body > 0:                       # the world holds nothing by an equality
                by_body.setdefault(body, []).append(i)
    rows = []
    for f in range(model.nflex):
        a, n, v0 = model.flex_edgeadr[f], model.flex_edgenum[f], model.flex_vertadr[f]
        for v in model.flex_edge[a:a + n]:
            bodies = {int(model.flex_vertbodyid[v0 + int(k)]) for k in v}
            rows.append(sorted({q for b in bodies for q in by_body.get(b, [])}))
    width = max((len(r) for r in rows), default=0)
    out = np.full((len(rows), width), -1, np.int32)
    for e, r in enumerate(rows):
        out[e, :len(r)] = r
    return out


def _static_planes(model: mujoco.MjModel) -> np.ndarray:
    """(nplane, 4) unit normal and offset of each plane geom fixed to the world."""
    out = []
    for g in range(model.ngeom):
        if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE or model.geom_bodyid[g] != 0:
            continue
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, model.geom_quat[g])
        normal = mat.reshape(3, 3)[:, 2]
        out.append([*normal, float(normal @ model.geom_pos[g])])
    return np.array(out, dtype=float).reshape(-1, 4)
