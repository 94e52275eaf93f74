"""The state-vector-reduction authors' push problems (dopt.tasks.push.authors): their clutter
scenes read from their layout files, their soft bodies, and ``build_push_task``.

The numbers checked against are the authors' own (DMackRus/mujoco_models
``Franka_emika_scenes_V1/cylinder_pushing_heavyClutter.xml``, ``push_soft.xml``,
``push_soft_rigid.xml``), written out here rather than imported, so a changed constant fails.
The clutter tests read the authors' files from ``../shared/external`` beside the project and
skip where it is absent (a user's clone has none)."""

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService
from dopt.scene import Scene
from dopt.tasks import AUTHORS_PUSH_TASKS, PUSH_TASKS, build_push_task
from dopt.tasks.panda import TABLE_NAME
from dopt.tasks.push import authors
from dopt.tasks.push.clutter import DISTRACTORS, GOAL_CYLINDER
from dopt.tasks.push.soft import SoftMaterial, add_soft_block, block_mesh
from tests.external import LAYOUTS

needs_layouts = pytest.mark.skipif(
    not LAYOUTS.is_dir(), reason=f"the authors' layout files are not here ({LAYOUTS})")
INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION

# (geom type, size, mass, solref): the goal cylinder, then obstacle_1 .. obstacle_7
CYL, BOX = mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_BOX
THEIR_OBJECTS = [
    (CYL, (0.05, 0.06), 0.3, (0.08, 1.1)),
    (CYL, (0.05, 0.06), 0.55, (0.06, 1.1)),
    (BOX, (0.04, 0.05, 0.06), 0.5, (0.06, 1.1)),
    (CYL, (0.05, 0.04), 0.6, (0.06, 1.1)),
    (CYL, (0.03, 0.05), 0.5, (0.06, 1.1)),
    (CYL, (0.06, 0.05), 0.6, (0.06, 1.1)),
    (CYL, (0.04, 0.05), 0.4, (0.06, 1.1)),
    (CYL, (0.06, 0.05), 0.6, (0.06, 1.1)),
]
SOFT_SEEDS = range(12)


def start_data(task) -> mujoco.MjData:
    data = mujoco.MjData(task.model)
    mujoco.mj_setState(task.model, data, task.initial_state, INTEGRATION)
    mujoco.mj_forward(task.model, data)
    return data


def arm_contacts(task, data) -> int:
    arm = {task.model.body(n).id for n in task.robot_bodies}
    return sum(bool({task.model.geom_bodyid[g] for g in c.geom if g >= 0} & arm)
               for c in data.contact[: data.ncon])


def assert_quiet(task, data, steps: int) -> None:
    """``steps`` of zero control from ``data`` raise no MuJoCo warning (the settling before
    the start raised none either: ``rest_state`` raises on one)."""
    work = mujoco.MjData(task.model)
    mujoco.mj_setState(task.model, work, task.initial_state, INTEGRATION)
    for _ in range(steps):
        mujoco.mj_step(task.model, work)
    assert [w.number for w in work.warning] == [0] * len(work.warning)
    assert np.all(np.isfinite(work.qpos))


def write_row(path: Path, values) -> Path:
    path.write_text(",".join(str(v) for v in values) + ",\n")  # their files end with a comma
    return path


# ------------------------------------------------------------------------------ clutter
@needs_layouts
def test_layout_file_is_read_in_their_order():
    layout = authors.read_layout(LAYOUTS / "0.csv")
    values = [float(v) for v in (LAYOUTS / "0.csv").read_text().strip().rstrip(",").split(",")]
    assert len(values) == 75
    np.testing.assert_array_equal(layout.arm_qpos, values[:7])
    np.testing.assert_array_equal(layout.poses.ravel(), values[7:55])
    np.testing.assert_array_equal(layout.goal, values[55:57])
    np.testing.assert_array_equal(layout.poses[0, :2], [0.4, -0.0100302])  # the goal cylinder
    # their obstacles' targets are their start positions
    np.testing.assert_array_equal(layout.targets[4:18].reshape(7, 2), layout.poses[1:, :2])


@needs_layouts
@pytest.mark.parametrize("scene", [0, 37, 99])
def test_clutter_scene_has_their_objects_contacts_and_poses(scene):
    path = LAYOUTS / f"{scene}.csv"
    task = authors.build_clutter_authors(path)
    layout = authors.read_layout(path)
    model, data = task.model, start_data(task)
    assert (model.nv, model.nu) == (55, 7)
    assert task.name == "clutter" and task.goal_object == GOAL_CYLINDER
    assert task.distractors == DISTRACTORS and task.soft_body is None
    assert (task.horizon, task.timeout, task.slowdown) == (80, 2000, 1)
    assert task.dt == model.opt.timestep == 0.004
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    assert len(task.robot_dofs) + len(task.cost_dofs) == 23
    np.testing.assert_array_equal(task.goal_position[:2], layout.goal)
    np.testing.assert_array_equal(model.geom(TABLE_NAME).friction, [1.0, 0.005, 0.0001])
    for k, (name, (kind, size, mass, solref)) in enumerate(
            zip((GOAL_CYLINDER, *DISTRACTORS), THEIR_OBJECTS, strict=True)):
        body, geom = model.body(name), model.geom(name)
        assert model.jnt_type[body.jntadr[0]] == mujoco.mjtJoint.mjJNT_FREE
        assert geom.type == kind
        np.testing.assert_allclose(geom.size[: len(size)], size, rtol=0, atol=1e-12)
        assert body.mass == pytest.approx(mass, abs=1e-12)
        np.testing.assert_allclose(geom.solref, solref, atol=1e-12)
        np.testing.assert_allclose(geom.solimp, [0, 0.99, 0.01, 0.5, 2], atol=1e-12)
        assert geom.margin == pytest.approx(0.001) and geom.condim == 3
        np.testing.assert_array_equal(geom.friction, [1.0, 0.005, 0.0001])
        # where their file puts it (xy), standing on the table: their soft contacts let it
        # sink about 2 mm, and it is upright and turned by the file's yaw
        xpos = data.body(name).xpos
        np.testing.assert_allclose(xpos[:2], layout.poses[k, :2], atol=2e-3)
        assert abs(xpos[2] - size[-1]) < 2.5e-3
        xmat = data.body(name).xmat.reshape(3, 3)
        assert xmat[2, 2] > math.cos(1e-3)
        assert math.atan2(xmat[1, 0], xmat[0, 0]) == pytest.approx(layout.poses[k, 5], abs=1e-3)
    assert arm_contacts(task, data) == 0


@needs_layouts
def test_all_their_scenes_load_and_settle_at_rest():
    """Every one of the 100 scenes: no MuJoCo warning while it settles or after, the objects at
    rest, the arm touching nothing, the pusher behind the goal cylinder."""
    speeds = []
    for scene in range(100):
        task = authors.build_clutter_authors(LAYOUTS / f"{scene}.csv")
        data = start_data(task)
        assert_quiet(task, data, 50)
        speeds.append(np.abs(np.delete(data.qvel, task.robot_dofs)).max())
        assert arm_contacts(task, data) == 0, scene
        tip = data.site(task.ee_site).xpos[:2]
        cylinder = data.body(GOAL_CYLINDER).xpos[:2]
        to_cyl, to_goal = cylinder - tip, task.goal_position[:2] - cylinder
        assert np.dot(to_cyl, to_goal) > 0.999 * np.linalg.norm(to_cyl) * np.linalg.norm(to_goal)
    assert max(speeds) < 1e-3


@needs_layouts
def test_build_push_task_reads_the_seeds_scene():
    task = build_push_task("clutter", "authors", 7, LAYOUTS)
    again = authors.build_clutter_authors(LAYOUTS / "7.csv")
    np.testing.assert_array_equal(task.initial_state, again.initial_state)
    np.testing.assert_array_equal(task.goal_position, again.goal_position)


def test_our_clutter_keeps_its_table():
    task = PUSH_TASKS["clutter"](np.random.default_rng(0))
    np.testing.assert_array_equal(task.model.geom(TABLE_NAME).friction, [0.5, 0.005, 0.0001])


@pytest.mark.parametrize("name", sorted(PUSH_TASKS))
@pytest.mark.parametrize("seed", [0, 2])
def test_ours_through_build_push_task_is_todays_task(name, seed):
    task = build_push_task(name, "ours", seed)
    today = PUSH_TASKS[name](np.random.default_rng(seed))
    np.testing.assert_array_equal(task.initial_state, today.initial_state)
    np.testing.assert_array_equal(task.goal_position, today.goal_position)
    assert task.model.nv == today.model.nv


# ------------------------------------------------------------------------- soft tasks
def front_gap(task, data) -> float:
    """Distance (m) from the soft block's front face (vertices plus radius) to the cylinder's
    surface, along the line from the cylinder to the goal (negative: pressed in)."""
    cylinder = data.body(task.goal_object).xpos[:2]
    along = task.goal_position[:2] - cylinder
    along /= np.linalg.norm(along)
    flex = mujoco.mj_name2id(task.model, mujoco.mjtObj.mjOBJ_FLEX, task.soft_body)
    front = (data.flexvert_xpos[:, :2] @ along).max() + task.model.flex_radius[flex]
    return float(cylinder @ along - task.model.geom(task.goal_object).size[0] - front)


def elastic_stiffness(counts: tuple[int, int, int]) -> np.ndarray:
    """MuJoCo's compiled element stiffness (``flex_stiffness``) of a block of ``counts``
    vertices 0.07 m apart with Young 4e3 Pa and Poisson 0 (it does not depend on the pose)."""
    from dopt.tasks.panda import table_scene_spec
    points, tets = block_mesh(counts, 0.07)
    spec = table_scene_spec(0.004, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, points, tets, np.zeros(2), 0.0,
                   SoftMaterial(spacing=0.07, radius=0.005, young=4e3, poisson=0.0,
                                damping=0.005, mass=1.0))
    return spec.compile().flex_stiffness.copy()


@pytest.mark.parametrize(("builder", "name", "nv", "counts", "mass", "damping", "cost_dofs"), [
    (authors.build_soft_authors, "soft", 115, (3, 4, 3), 1.0, 0.0078, 72),
    (authors.build_soft_rigid_authors, "soft_rigid", 154, (3, 4, 4), 2.0, 0.0069, 2),
])
def test_soft_scenes_over_many_seeds(builder, name, nv, counts, mass, damping, cost_dofs):
    """Their block (and cylinder) for every seed: sizes, material, a clean start at rest, the
    cylinder touching the block, the costs reading 2 cylinder DoFs or the vertices' x, y."""
    stiffness = elastic_stiffness(counts)
    for seed in SOFT_SEEDS:
        task = builder(np.random.default_rng(seed))
        model, data = task.model, start_data(task)
        assert task.name == name and (model.nv, model.nu) == (nv, 7)
        assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE
        assert model.nflex == 1 and model.flex_vertnum[0] == math.prod(counts)
        assert model.body_mass[task._bodies_of(task.soft_body)].sum() == pytest.approx(mass)
        np.testing.assert_allclose(model.flex_stiffness, stiffness, rtol=1e-9, atol=1e-6)
        assert model.flex_damping[0] == damping and model.flex_edgedamping[0] == 0.0
        assert model.flex_radius[0] == 0.005
        np.testing.assert_allclose(np.sort(model.flexedge_length0)[:4], 0.07, rtol=1e-9)
        assert len(task.cost_dofs) == cost_dofs
        assert_quiet(task, data, 50)
        assert np.abs(np.delete(data.qvel, task.robot_dofs)).max() < 1e-3
        assert arm_contacts(task, data) == 0, seed
        if name == "soft_rigid":
            assert abs(front_gap(task, data)) < 1e-3, seed
            geom = model.geom(task.goal_object)
            cylinder_flex = [c for c in data.contact[: data.ncon]
                             if geom.id in c.geom and c.flex.max() >= 0]
            assert cylinder_flex, "the cylinder does not touch the block"
            np.testing.assert_allclose(geom.size[:2], [0.06, 0.08])
            assert model.body(task.goal_object).mass == pytest.approx(0.74)
            np.testing.assert_allclose(geom.solimp[:3], [0.0, 0.8, 0.01])
            np.testing.assert_allclose(geom.solref, [0.06, 1.0])
            assert geom.margin == pytest.approx(0.001)


def test_soft_rigid_cylinder_slides_along_world_axes_with_its_position_in_qpos():
    """Three slides (x, y, z; no rotation): qpos holds the world position, as a free joint's
    first three coordinates do, which is what the costs read."""
    task = authors.build_soft_rigid_authors(np.random.default_rng(3))
    model, data = task.model, start_data(task)
    body = model.body(task.goal_object)
    assert body.jntnum[0] == 3
    joints = range(body.jntadr[0], body.jntadr[0] + 3)
    assert all(model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE for j in joints)
    np.testing.assert_array_equal([model.jnt_axis[j] for j in joints], np.eye(3))
    qpos = data.qpos[[model.jnt_qposadr[j] for j in joints]]
    np.testing.assert_allclose(qpos, data.body(task.goal_object).xpos, atol=1e-12)
    np.testing.assert_array_equal(task.cost_dofs, [model.jnt_dofadr[j] for j in joints][:2])


def test_soft_rigid_goal_distance_reads_the_cylinder():
    from dopt.tasks.push.costs import goal_distance
    task = authors.build_soft_rigid_authors(np.random.default_rng(1))
    data = start_data(task)
    want = np.linalg.norm(data.body(task.goal_object).xpos[:2] - task.goal_position[:2])
    assert goal_distance(task, Scene(task.model))(task.initial_state) == pytest.approx(want)
    assert 0.24 - 2e-3 < want < 0.30 + 2e-3


@pytest.mark.parametrize("builder", [authors.build_soft_authors,
                                     authors.build_soft_rigid_authors])
def test_soft_scenes_stay_stable_under_zero_control(builder):
    """dopt.stability's verdict over 500 steps of zero control from the start."""
    task = builder(np.random.default_rng(0))
    with RolloutService(Scene(task.model), RolloutConfig(threads=1)) as service:
        result = service.rollout(task.initial_state, np.zeros((500, task.model.nu)))
    verdict = result.stability
    assert verdict.n_unstable == 0, verdict.first()
    assert verdict.max_speed[0] < 1e-3


@pytest.mark.parametrize("name", ["soft", "soft_rigid"])
def test_build_push_task_gives_their_soft_scenes(name):
    task = build_push_task(name, "authors", 4)
    again = AUTHORS_PUSH_TASKS[name](np.random.default_rng(4))
    np.testing.assert_array_equal(task.initial_state, again.initial_state)
    assert task.model.nv == (115 if name == "soft" else 154)


def test_edge_damping_is_rejected_under_discrete():
    """Why their edge damping is carried as Rayleigh damping (module docstring)."""
    from dopt.tasks.panda import table_scene_spec
    points, tets = block_mesh((3, 4, 3), 0.07)
    spec = table_scene_spec(0.004, mujoco.mjtIntegrator.mjINT_DISCRETE)
    add_soft_block(spec, points, tets, np.array([0.5, 0.0]), 0.0, authors.SOFT_MATERIAL)
    spec.flex(authors.SOFT_BODY).edgedamping = 0.9
    with pytest.raises(ValueError, match="edge stiffness and damping are not supported"):
        spec.compile()


@pytest.mark.parametrize(("counts", "edge_damping"), [((3, 4, 3), 0.9), ((3, 4, 4), 0.8)])
def test_rayleigh_damping_matches_their_edge_damping(counts, edge_damping):
    """EDGE_TO_RAYLEIGH: the median over the block's deformation modes of the Rayleigh
    coefficient that damps each mode as their edge damping does (phi' D phi / phi' K phi, K the
    elastic stiffness by central differences of the passive force, D = b sum_e u_e u_e')."""
    material = SoftMaterial(spacing=0.07, radius=0.005, young=4e3, poisson=0.0, damping=0.001,
                            mass=1.0)
    points, tets = block_mesh(counts, material.spacing)
    spec = mujoco.MjSpec()
    spec.option.gravity = [0.0, 0.0, 0.0]
    add_soft_block(spec, points, tets, np.zeros(2), 0.0, material)
    model = spec.compile()
    data = mujoco.MjData(model)
    n, h = model.nv, 1e-6

    def force(q):
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        return data.qfrc_passive.copy()

    stiffness = np.zeros((n, n))
    for i in range(n):
        step = np.zeros(n)
        step[i] = h
        stiffness[:, i] = -(force(model.qpos0 + step) - force(model.qpos0 - step)) / (2 * h)
    stiffness = (stiffness + stiffness.T) / 2
    assert np.abs(stiffness).max() > 100  # the elasticity is in qfrc_passive
    force(model.qpos0)
    mass = np.zeros((n, n))
    mujoco.mj_fullM(model, data, mass)
    x = data.flexvert_xpos.copy()  # at rest (the vertices' qpos are displacements)
    damping = np.zeros((n, n))
    for a, b in model.flex_edge:
        u = (x[b] - x[a]) / np.linalg.norm(x[b] - x[a])
        row = np.zeros(n)
        row[3 * b:3 * b + 3], row[3 * a:3 * a + 3] = u, -u
        damping += edge_damping * np.outer(row, row)
    # modes of K phi = lambda M phi (mass-normalised), rigid ones left out
    inv = np.linalg.inv(np.linalg.cholesky(mass))
    lam, vec = np.linalg.eigh(inv @ stiffness @ inv.T)
    phi = inv.T @ vec
    keep = lam > 1e-3 * lam.max()
    beta = np.einsum("ji,jk,ki->i", phi, damping, phi)[keep] / lam[keep]
    assert authors.EDGE_TO_RAYLEIGH[edge_damping] == pytest.approx(np.median(beta), rel=0.02)


# --------------------------------------------------------------------------- bad input
def test_read_layout_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere.csv"):
        authors.read_layout(tmp_path / "nothere.csv")


@pytest.mark.parametrize(("values", "match"), [
    (np.zeros(74), "75 numbers, got 74"),
    (np.zeros(76), "75 numbers, got 76"),
    (np.r_[np.zeros(30), np.nan, np.zeros(44)], "number 30 is nan, not finite"),
    (np.r_[np.zeros(74), np.inf], "number 74 is inf"),
    (["0"] * 10 + ["x"] + ["0"] * 64, "could not convert"),
])
def test_read_layout_rejects_bad_rows_naming_the_file(tmp_path, values, match):
    path = write_row(tmp_path / "bad.csv", values)
    with pytest.raises(ValueError, match=match) as error:
        authors.read_layout(path)
    assert "bad.csv" in str(error.value)


def test_read_layout_rejects_two_rows(tmp_path):
    path = tmp_path / "two.csv"
    path.write_text("0," * 75 + "\n" + "0," * 75 + "\n")
    with pytest.raises(ValueError, match=r"two.csv: .*got 2 rows"):
        authors.read_layout(path)


def test_read_layout_takes_a_row_without_the_trailing_comma(tmp_path):
    path = tmp_path / "ok.csv"
    path.write_text(",".join(["1.5"] * 75))
    layout = authors.read_layout(path)
    assert layout.poses.shape == (8, 6) and layout.targets.shape == (20,)


@pytest.mark.parametrize("seed", [100, 1000])
def test_authors_clutter_seed_outside_their_scenes(tmp_path, seed):
    with pytest.raises(ValueError, match="scenes 0-99"):
        build_push_task("clutter", "authors", seed, tmp_path)


def test_authors_clutter_needs_layouts(tmp_path):
    with pytest.raises(ValueError, match="needs layouts"):
        build_push_task("clutter", "authors", 0, None)
    with pytest.raises(ValueError, match="layouts: no folder"):
        build_push_task("clutter", "authors", 0, tmp_path / "absent")
    with pytest.raises(ValueError, match="layouts: no scene file .*3.csv"):
        build_push_task("clutter", "authors", 3, tmp_path)


@pytest.mark.parametrize(("args", "error", "match"), [
    (("clutter", "theirs", 0), ValueError, "unknown problem 'theirs'"),
    (("cloth", "authors", 0), ValueError, "unknown task 'cloth'"),
    (("soft", "authors", -1), ValueError, "seed must be >= 0"),
    (("soft", "authors", 1.0), TypeError, "seed must be an int"),
    (("soft", "ours", True), TypeError, "seed must be an int"),
])
def test_build_push_task_rejects_bad_arguments(args, error, match):
    with pytest.raises(error, match=match):
        build_push_task(*args)


def test_the_authors_soft_blocks_carry_their_strain_bound_into_the_controller():
    """Their 4 kPa blocks compress by about half under the push, so their tasks judge strain
    at SOFT_STRAIN_BOUND; ours keep the default; the MPC controller's scene uses the task's."""
    from dopt.stability import StabilityBounds
    from dopt.tasks.push.authors import SOFT_STRAIN_BOUND
    from planners.svr import SelectionConfig
    from planners.svr_mpc import build_controller

    ours = build_push_task("soft_rigid", "ours", 0)
    theirs = build_push_task("soft_rigid", "authors", 0)
    assert ours.stability == StabilityBounds()
    assert theirs.stability.max_strain == SOFT_STRAIN_BOUND > StabilityBounds().max_strain
    ctl = build_controller(theirs, SelectionConfig("baseline"), np.random.default_rng(0))
    try:
        assert ctl.scene.monitor.bounds.max_strain == SOFT_STRAIN_BOUND
    finally:
        ctl.service.close()


def _strain_after_first_plan(task, height: float, steps: int) -> tuple[float, bool]:
    """The largest flex-edge strain while ``task`` runs its first plan pushed at ``height``
    and then ``steps`` more of its last control (what MPC executes while no optimisation
    lands), with the verdict's own judge: (strain, whether the task's bounds flag it)."""
    from dopt.tasks.push import warm_start

    config = warm_start.WarmStartConfig(height=height)
    start = warm_start.setup(task, config=config).final_state
    plan = warm_start.push(task, start, task.horizon, config).controls
    U = np.concatenate([plan, np.repeat(plan[-1:], steps, axis=0)])
    with RolloutService(Scene(task.model, stability=task.stability),
                        RolloutConfig(threads=1)) as svc:
        res = svc.rollout(start, U)
    return float(res.stability.max_strain[0]), bool(res.stability.unstable[0])


def test_soft_rigid_pushes_one_spacing_up_where_the_block_does_not_fold():
    """Seed 2 (module docstring of dopt.tasks.push.authors): pushed at EE_HEIGHT the block's
    bottom layer, squeezed against the cylinder, breaks the strain bound within 200 steps of
    the plan's last control; at the task's push height it stays under it."""
    from dopt.tasks.push.clutter import EE_HEIGHT

    task = build_push_task("soft_rigid", "authors", 2)
    assert task.push_height == authors.SOFT_RIGID_PUSH_HEIGHT > EE_HEIGHT
    assert build_push_task("soft", "authors", 2).push_height == EE_HEIGHT
    low, low_flagged = _strain_after_first_plan(task, EE_HEIGHT, 200)
    high, high_flagged = _strain_after_first_plan(task, task.push_height, 200)
    assert low_flagged and low > authors.SOFT_STRAIN_BOUND
    assert not high_flagged and high < authors.SOFT_STRAIN_BOUND
