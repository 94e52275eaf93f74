"""dopt.view (and its sources in planners.view): replays end where the trials say they ended,
an MPC episode replays bit for bit from its start and controls, a forced blow-up is captured
and opens at its failing step, the CLI's bad input is one line, the experiments' console
scripts are the scripts themselves."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from fnmatch import fnmatch
from pathlib import Path

import numpy as np
import pytest

from dopt.lab.trialpack import read_trial_text, stored_trials

os.environ.setdefault("MUJOCO_GL", "egl")

ROOT = Path(__file__).resolve().parents[3]
RUNS = ROOT / "docs" / "results" / "runs"
BIN = Path(sys.executable).parent


def committed_trial(run: str, pattern: str) -> Path:
    """The path of the first committed trial of ``run`` whose file name matches ``pattern``
    (its loose file, or the path a packed trial's file would have: ``dopt.lab.trialpack``)."""
    found = [t.path for t in stored_trials(RUNS / run / "trials") if fnmatch(t.name, pattern)]
    if not found:
        pytest.skip(f"no committed trial {run}/trials/{pattern}")
    return found[0]


# ------------------------------------------------------------------------ MPC episode
MPC_SETTINGS = {"task": "clutter", "method": "baseline", "timeout": 40, "synchronous": True}


def write_mpc_trial(path: Path) -> dict:
    """Run ``run_svr_mpc`` on MPC_SETTINGS (seed 0), keep what ``MPC.run`` returned, and write
    a trial file as experiments/mpc.py does, with the proposed optional fields start_state and
    controls. Returns {"path", "start", "states", "controls"}."""
    import planners.svr_mpc.episode as episode
    from planners.svr_mpc import SVRMPCSettings, trial_params

    seen = {}
    run = episode.MPC.run

    def keep(self, initial_state, plan):
        res = run(self, initial_state, plan)
        seen.update(start=np.array(initial_state), res=res)
        return res

    settings = SVRMPCSettings.from_params(MPC_SETTINGS)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(episode.MPC, "run", keep)
        result = episode.run_svr_mpc(settings, seed=0).to_dict()
    res = seen["res"]
    result["start_state"] = [float(v) for v in seen["start"]]
    result["controls"] = res.controls.tolist()
    path.write_text(json.dumps({"key": "clutter-baseline-view-test",
                                "params": trial_params(settings, 0), "result": result}))
    return {"path": path, "start": seen["start"], "states": res.states,
            "controls": res.controls}


@pytest.fixture(scope="module")
def mpc_trial(tmp_path_factory):
    return write_mpc_trial(tmp_path_factory.mktemp("mpc") / "clutter-baseline-seed0.json")


def test_mpc_episode_replays_bit_for_bit(mpc_trial):
    from dopt.view.episode import replay_controls
    from planners.svr_mpc import SVRMPCSettings
    from planners.view import load_mpc

    task = SVRMPCSettings.from_params(MPC_SETTINGS).build_task(0)
    model = task.model
    states = replay_controls(model, mpc_trial["start"], mpc_trial["controls"])
    assert states.shape == mpc_trial["states"].shape
    assert np.max(np.abs(states - mpc_trial["states"])) <= 1e-9       # every row, not just the end
    ep = load_mpc(mpc_trial["path"], max_frames=20)
    assert np.max(np.abs(ep.states[-1] - mpc_trial["states"][-1])) <= 1e-9
    assert ep.replay_error <= 1e-7                 # the trial's final_state is rounded to 1e-7
    # baseline: every DoF in C, so every object fully shaded; the robot keeps its colour
    robot = [model.body(name).id for name in task.robot_bodies]
    objects = [model.body(name).id for name in (task.goal_object, *task.distractors)]
    assert np.all(np.isnan(ep.shade[:, robot]))
    assert np.all(ep.shade[1:, objects] == 1.0)          # frame 0: before the first optimisation
    assert {c.name for c in ep.curves} == {"goal distance", "|C|"}


def test_mpc_trial_without_controls_shows_start_and_end(mpc_trial, tmp_path):
    from planners.view import load_mpc

    record = json.loads(mpc_trial["path"].read_text())
    del record["result"]["controls"], record["result"]["start_state"]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(record))
    ep = load_mpc(path)
    assert ep.n_frames == 2 and ep.replay_error is None
    assert "no controls recorded" in ep.summary


#: a short synchronous MPC trial (deterministic), as the sweeps store it
KEEP_SETTINGS = {"task": "clutter", "method": "baseline", "timeout": 10, "slowdown": 1.0,
                 "synchronous": True, "threads": 1}


def write_run_trial(path: Path, **kwargs) -> tuple[dict, dict]:
    """``planners.svr_mpc.run_trial`` on KEEP_SETTINGS (seed 0) with ``kwargs``, written as
    ``dopt.lab.sweep`` writes a trial: its params and result."""
    from dopt.lab import jsonio
    from planners.svr_mpc import SVRMPCSettings, run_trial, trial_key, trial_params

    params = trial_params(SVRMPCSettings.from_params(KEEP_SETTINGS), 0)
    result = run_trial(params, **kwargs)
    path.write_text(jsonio.dumps({"key": trial_key(params), "params": params,
                                  "result": result}))
    return params, result


@pytest.mark.parametrize("c_kernels", [True, False], ids=["c-kernels", "batch"])
def test_mpc_trial_with_keep_controls_replays_to_its_final_state(c_kernels, tmp_path,
                                                                 monkeypatch):
    """run_trial(keep_controls=True), its optimiser's rollouts on the C kernels or on
    mujoco.batch.Batch alone: the viewer's replay (mj_step) and an open-loop rollout of the
    recorded controls (mujoco.batch.Batch) both end within 1e-9 of the recorded final state,
    and every replayed row matches; the params (and so the key) are those of any trial."""
    import planners.svr_mpc.episode as episode
    from dopt import kernels
    from dopt.rollout import RolloutConfig, RolloutService
    from dopt.scene import Scene
    from planners.svr_mpc import CONTROLS_FIELDS, SVRMPCSettings
    from planners.view import load_mpc

    if c_kernels and kernels.load() is None:
        pytest.skip("dopt.kernels was not built")
    routes = []

    def config(**kw):
        routes.append(c_kernels)
        return RolloutConfig(**kw, c_kernels=c_kernels)

    monkeypatch.setattr(episode, "RolloutConfig", config)
    path = tmp_path / "trial.json"
    params, result = write_run_trial(path, keep_controls=True)
    assert routes == [c_kernels]                  # the episode ran on the route asked for
    assert set(CONTROLS_FIELDS) <= set(result) and "keep_controls" not in params
    final = np.asarray(result["final_state"])
    controls = np.asarray(result["controls"])
    assert controls.shape[0] == result["steps"] == KEEP_SETTINGS["timeout"]
    assert len(result["start_state"]) == len(final)

    ep = load_mpc(path)
    assert ep.replay_error is not None and ep.replay_error <= 1e-9
    assert np.max(np.abs(ep.states[-1] - final)) <= 1e-9
    assert ep.n_frames == result["steps"] + 1
    assert "replay of 10 steps ends" in ep.summary

    task = SVRMPCSettings.from_params(KEEP_SETTINGS).build_task(0)
    with RolloutService(Scene(task.model, stability=task.stability),
                        RolloutConfig(threads=1, c_kernels=c_kernels)) as svc:
        batch = svc.trajectory(result["start_state"], controls).states
    assert np.max(np.abs(batch[-1] - final)) <= 1e-9
    assert np.max(np.abs(batch - ep.states)) <= 1e-9


def test_mpc_trial_without_keep_controls_has_none_and_says_how_to_get_them(tmp_path, caplog):
    """Without keep_controls a trial keeps no controls (its final state rounded, as the
    committed trials') and is otherwise the same episode under the same params and key as
    with them; the viewer's summary and log say to rerun it with --keep-controls."""
    import logging

    from planners.svr_mpc import CONTROLS_FIELDS
    from planners.view import NO_CONTROLS, load_mpc

    path = tmp_path / "trial.json"
    params, result = write_run_trial(path)
    kept_params, kept = write_run_trial(tmp_path / "kept.json", keep_controls=True)
    assert not set(CONTROLS_FIELDS) & set(result) and set(CONTROLS_FIELDS) <= set(kept)
    assert params == kept_params
    assert json.loads(path.read_text())["key"] == \
        json.loads((tmp_path / "kept.json").read_text())["key"]
    assert result["mpc_cost"] == kept["mpc_cost"] and result["steps"] == kept["steps"]
    assert result["final_state"] == [round(v, 7) for v in kept["final_state"]]
    with caplog.at_level(logging.WARNING, logger="planners.view"):
        ep = load_mpc(path)
    assert ep.n_frames == 2 and ep.replay_error is None
    assert "--keep-controls" in NO_CONTROLS and NO_CONTROLS in ep.summary
    assert NO_CONTROLS in caplog.text


# ------------------------------------------------------------------------ pick trials
@pytest.mark.parametrize("run, pattern", [
    ("fig7-ours-cloth-diagonal", "scripted-seed0-*.json"),
    ("fig7-rope-fold", "original-seed0-*.json"),
])
def test_pick_trial_replays_to_its_recorded_final_state(run, pattern):
    from planners.view import load_pick

    path = committed_trial(run, pattern)
    ep = load_pick(path, max_frames=40)
    assert ep.replay_error <= 1e-9, f"{path.name}: the replay ends {ep.replay_error:.2e} away"
    final = np.asarray(json.loads(read_trial_text(path))["result"]["final_state"])
    assert np.max(np.abs(ep.states[-1] - final)) <= 1e-9
    assert ep.n_frames <= 41 and np.all(np.diff(ep.times) > 0)
    names = [m.name for m in ep.markers]
    assert names == ["key particles", "key particles on the goal", "picked particle",
                     "place target"]
    picked = ep.markers[2].positions
    assert np.isfinite(picked).any(), "no frame shows the picked particle"
    assert ep.ghost is not None
    assert ep.ghost.shapes.shape[1:] == (int(ep.model.flex_vertnum[0]), 3)


# ------------------------------------------------------------------------ blow-ups
def violent_rope():
    """A 12-particle rope whose picker moves 0.87 m in 2 steps: the stability verdict flags the
    executed rollout (speed, the picked particle)."""
    from dopt.rollout import RolloutConfig, RolloutService
    from dopt.tasks.pick.picker import PickerConfig
    from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope
    from dopt.tasks.pick.scene import PickPlaceTask

    scene = make_rope(RopeSceneConfig.physics("fast", n=12),
                      PickerConfig(bound=(0.5, 0.5, 0.5), speed=50.0))
    service = RolloutService(scene.scene, RolloutConfig(threads=1))
    task = PickPlaceTask(scene, scene.positions(scene.initial_state), rollout=service)
    particles, displacements = np.array([[5]]), np.array([[[0.5, 0.5, 0.5]]])
    return scene, service, task.execute(particles[0], displacements[0]), \
        scene.picker.encode(particles, displacements)[0]


def test_forced_blowup_is_captured_and_opens_at_the_failing_step(tmp_path):
    from dopt.blowup import capture_blowup, capture_dir
    from dopt.tasks.pick.picker import CONTROL_SPEC
    from dopt.view.episode import collect

    scene, service, done, U = violent_rope()
    assert done.unstable and "body rope_5" in done.reason
    out = capture_blowup(capture_dir(tmp_path, "rope seed 0"), scene.model, scene.initial_state,
                         U, done.step, done.reason, control_spec=CONTROL_SPEC, xml=scene.xml,
                         label="rope seed 0")
    assert out == tmp_path / "blowups" / "rope-seed-0"
    meta = json.loads((out / "blowup.json").read_text())
    assert meta["step"] == done.step and meta["body"] == "rope_5" and meta["xml"]
    # the viewer finds it from the run's folder and opens it at the state after the failing
    # step, which is the executed rollout's state there
    entries = collect(tmp_path)
    assert list(entries) == ["rope-seed-0"]
    source, path = entries["rope-seed-0"]
    ep = source.load(path)
    upto = service.rollout(scene.initial_state, U[None, :done.step + 1],
                           control_spec=CONTROL_SPEC).final_states[0]
    assert np.max(np.abs(ep.states[ep.start_frame] - upto)) <= 1e-9
    assert ep.start_frame == ep.n_frames - 1
    assert "flagged" in ep.captions[ep.start_frame]
    assert ep.marked_body == scene.model.body("rope_5").id
    service.close()


def test_save_blowup_names_bad_input(tmp_path):
    import mujoco

    from dopt.blowup import save_blowup

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body><freejoint/>"
                                           "<geom size='.1'/></body></worldbody></mujoco>")
    with pytest.raises(ValueError, match="states must have shape"):
        save_blowup(tmp_path, model, np.zeros((3, 5)), 2, "x")
    with pytest.raises(TypeError, match="reason"):
        save_blowup(tmp_path, model, np.zeros((1, mujoco.mj_stateSize(
            model, mujoco.mjtState.mjSTATE_INTEGRATION))), 0, None)
    with pytest.raises(ValueError, match="first_row"):
        save_blowup(tmp_path, model, np.zeros((5, mujoco.mj_stateSize(
            model, mujoco.mjtState.mjSTATE_INTEGRATION))), 1, "x")


def test_replay_controls_names_bad_input():
    import mujoco

    from dopt.view.episode import replay_controls

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><joint name='j' type='slide'/><geom size='.1'/></body>"
        "</worldbody><actuator><motor joint='j'/></actuator></mujoco>")
    x0 = np.zeros(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION))
    with pytest.raises(ValueError, match=r"controls must have shape \(T, 1\)"):
        replay_controls(model, x0, np.zeros((4, 2)))
    with pytest.raises(ValueError, match="start_state"):
        replay_controls(model, x0[:-1], np.zeros((4, 1)))


# ------------------------------------------------------------------------ command line
def run_cli(*args, timeout: int = 300) -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "dopt.view", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout, env=env)


def test_cli_bad_input_is_one_line_and_exit_1(tmp_path):
    for args, words in [((tmp_path / "missing",), "does not exist"),
                        ((tmp_path,), "no trial file, trial folder, pack, summary"),
                        ((tmp_path, "--frame", "x"), None)]:
        r = run_cli(*args)
        if words is None:                               # argparse: usage error, status 2
            assert r.returncode == 2 and "--frame" in r.stderr
            continue
        assert r.returncode == 1, r.stderr
        assert r.stderr.startswith("dopt-view: error:") and r.stderr.count("\n") == 1, r.stderr
        assert words in r.stderr


def test_cli_still_of_a_blowup_opens_at_the_failing_step(tmp_path):
    from PIL import Image

    from dopt.blowup import capture_blowup, capture_dir
    from dopt.tasks.pick.picker import CONTROL_SPEC

    scene, service, done, U = violent_rope()
    service.close()
    capture_blowup(capture_dir(tmp_path, "rope"), scene.model, scene.initial_state, U,
                   done.step, done.reason, control_spec=CONTROL_SPEC)
    r = run_cli(tmp_path, "--frame", "99", "--png", tmp_path / "x.png")
    assert r.returncode == 1 and "outside the episode" in r.stderr
    r = run_cli(tmp_path, "--png", tmp_path / "still.png", "--width", "320", "--height", "240")
    if r.returncode and any(w in r.stderr for w in ("OpenGL", "EGL", "GLX", "gladLoadGL")):
        pytest.skip(f"no offscreen OpenGL: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    assert f"frame {done.step + 1} of {done.step + 2}" in r.stdout       # the failing step
    image = np.asarray(Image.open(tmp_path / "still.png").convert("RGB")).astype(int)
    assert image.shape[1:] == (320, 3) and image.shape[0] > 240     # the caption band below
    image = image[:240]
    ring = (image[..., 0] > 200) & (image[..., 1] < 40) & (image[..., 2] < 40)
    assert ring.sum() > 20, "the offending body is not marked"


def test_cli_lists_a_committed_result_folder():
    committed_trial("fig7-ours-cloth-diagonal", "simple-seed0-*.json")
    r = run_cli(RUNS / "fig7-ours-cloth-diagonal", "--list")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) >= 4 and all("\tpick\t" in line for line in lines)


def test_entry_points_register_the_trial_sources():
    from dopt.view.episode import sources

    assert [s.name for s in sources()] == ["blowup", "mpc", "pick"]


@pytest.mark.parametrize("name", ["dopt-fold", "dopt-report"])
def test_console_scripts_are_the_experiment_scripts(name):
    from dopt.lab.scripts import SCRIPTS, experiments_dir

    assert all((experiments_dir() / f).is_file() for f in SCRIPTS.values())
    exe = BIN / name
    if not exe.exists():
        pytest.skip(f"{name} is not installed in {BIN} (pip install -e .)")
    mine = subprocess.run([str(exe), "--help"], capture_output=True, text=True, timeout=120)
    script = subprocess.run([sys.executable, str(ROOT / "experiments" / SCRIPTS[name]),
                             "--help"], capture_output=True, text=True, timeout=120)
    assert mine.returncode == script.returncode == 0, mine.stderr + script.stderr
    # the same help, but for the name in its usage lines (dopt.lab.cli.shown_as)
    assert mine.stdout.startswith(f"usage: {name} ")
    assert mine.stdout.split("\n\n", 1)[1] == script.stdout.split("\n\n", 1)[1]


# ------------------------------------------------------------------------ legibility
def test_a_pack_file_and_a_summary_open_their_sweeps_trials(tmp_path):
    """The pack and the recorded summary of a committed sweep list the same trials as its
    folder, all of them (the pack's records: dopt.lab.trialpack); an OUT/summary.json opens the
    trials beside it; a summary whose folder is gone says so."""
    from dopt.lab.trialpack import stored_trials
    from dopt.view.episode import collect

    run = RUNS / "fig7-cloth-diagonal"
    if not (run / "trials" / "pack.jsonl.gz").is_file():
        pytest.skip("no committed pack of fig7-cloth-diagonal")
    folder = list(collect(run))
    assert folder == sorted(t.stem for t in stored_trials(run / "trials"))
    assert list(collect(run / "trials" / "pack.jsonl.gz")) == folder
    assert list(collect(ROOT / "docs" / "results" / "fig7-cloth-diagonal.json")) == folder
    out = tmp_path / "out"
    (out / "trials").mkdir(parents=True)
    trial = committed_trial("fig7-ours-cloth-diagonal", "simple-seed0-*.json")
    (out / "trials" / trial.name).write_text(read_trial_text(trial))
    (out / "summary.json").write_text(json.dumps({"provenance": {"command": "x"}}))
    assert list(collect(out / "summary.json")) == [trial.stem]
    (tmp_path / "lost.json").write_text(json.dumps(
        {"provenance": {"command": "python x.py --out nowhere/at/all"}}))
    with pytest.raises(ValueError, match="trials folder was not found"):
        collect(tmp_path / "lost.json")


def test_cli_still_of_a_pack_works_without_mujoco_gl_and_carries_caption_and_legend(tmp_path):
    """``dopt-view PACK --png`` with MUJOCO_GL (and PYOPENGL_PLATFORM) unset: it chooses the
    offscreen context itself; the PNG is the requested image with a white band below it
    holding text (the caption and the legend's swatches: the cloth's colour among them)."""
    from PIL import Image

    pack = RUNS / "fig7-cloth-diagonal" / "trials" / "pack.jsonl.gz"
    if not pack.is_file():
        pytest.skip("no committed pack of fig7-cloth-diagonal")
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    out = tmp_path / "still.png"
    r = subprocess.run([sys.executable, "-m", "dopt.view", str(pack), "--png", str(out),
                        "--width", "400", "--height", "300", "--frame", "-1"], cwd=ROOT,
                       capture_output=True, text=True, timeout=300, env=env)
    assert r.returncode == 0, r.stderr
    image = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert image.shape[1] == 400 and image.shape[0] > 300 + 60       # the band below
    band = image[300:]
    assert (band.max(axis=-1) < 80).mean() > 0.01, "no text in the band"
    cloth = (np.abs(band - [204, 77, 51]).max(axis=-1) <= 2).sum()  # flex_rgba .8 .3 .2
    assert cloth >= 100, "the legend's cloth swatch is missing"


def test_legend_names_every_marker_ghost_region_and_shade(mpc_trial):
    from html import escape

    from dopt.view.legend import legend_html, legend_items
    from planners.view import load_mpc, load_pick

    ep = load_pick(committed_trial("fig7-ours-cloth-diagonal", "scripted-seed0-*.json"), 10)
    names = [i.name for i in legend_items(ep)]
    assert all(m.name in names for m in ep.markers)
    assert any(ep.ghost.name in n for n in names)
    assert {"cloth, top face", "cloth, underside"} <= set(names)
    assert "cloth" in [i.name for i in legend_items(ep, browser=False)]
    mpc = load_mpc(mpc_trial["path"], max_frames=10)
    items = legend_items(mpc)
    assert [i.name for i in items if i.kind == "ramp"] and \
        all(r.name in [i.name for i in items] for r in mpc.regions)
    text = legend_html(items)
    assert all(escape(i.name) in text for i in items) and text.count("<span") == 2 * len(items)


def test_mpc_goal_object_and_target_are_marked(mpc_trial):
    """The goal object's marker is its body's position at every frame (MuJoCo's own
    kinematics, here mj_forward), the target the task's goal position."""
    import mujoco

    from planners.svr_mpc import SVRMPCSettings
    from planners.view import load_mpc

    ep = load_mpc(mpc_trial["path"], max_frames=10)
    obj, target = ep.markers
    assert (obj.tag, target.tag) == ("goal object", "target")
    task = SVRMPCSettings.from_params(MPC_SETTINGS).build_task(0)
    body = ep.model.body(task.goal_object).id
    d = mujoco.MjData(ep.model)
    for f in (0, ep.n_frames - 1):
        mujoco.mj_setState(ep.model, d, ep.states[f], mujoco.mjtState.mjSTATE_INTEGRATION)
        mujoco.mj_forward(ep.model, d)
        assert np.allclose(obj.positions[f, 0], d.xpos[body], atol=1e-12)
    assert np.allclose(target.positions[:, 0], task.goal_position)
    assert obj.positions[0, 0, 0] != obj.positions[-1, 0, 0] or ep.n_frames == 1


def _seeded_curves(n_cases: int = 40):
    rng = np.random.default_rng(91)
    for _ in range(n_cases):
        n = int(rng.integers(2, 30))
        x = np.cumsum(rng.uniform(0.01, 1.0, n))
        yield x, rng.normal(size=n), float(rng.uniform(x[0] - 1, x[-1] + 1))


def test_plot_cursor_is_a_vertical_segment_at_the_frame():
    from dopt.view.episode import Curve
    from dopt.view.player import cursor_data

    for x, y, at in _seeded_curves():
        xs, ys, cur = cursor_data(Curve("c", x, y), at)
        assert len(xs) == len(ys) == len(cur) == len(x) + 2
        assert np.all(np.diff(xs) >= 0)
        where = np.flatnonzero(np.isfinite(cur))
        assert len(where) == 2 and where[1] == where[0] + 1
        clipped = min(max(at, x[0]), x[-1])
        assert xs[where[0]] == xs[where[1]] == clipped
        assert list(cur[where]) == [0.0, 1.0]
        assert np.allclose(ys[where], np.interp(clipped, x, y))
        keep = np.ones(len(xs), dtype=bool)
        keep[where] = False
        assert np.array_equal(xs[keep], x) and np.array_equal(ys[keep], y)


def test_nice_length_is_round_and_near_a_quarter():
    from dopt.view.legend import length_text, nice_length

    rng = np.random.default_rng(5)
    for extent in np.exp(rng.uniform(np.log(0.01), np.log(50), 200)):
        L = nice_length(extent)
        mantissa = L / 10 ** np.floor(np.log10(L) + 1e-9)
        assert np.isclose(mantissa, [1, 2, 5]).any(), (extent, L)
        assert L <= extent / 4 + 1e-12 < 2.5 * L
    assert [length_text(v) for v in (0.05, 0.1, 0.002, 2.0)] == ["5 cm", "10 cm", "2 mm",
                                                                "2 m"]


def test_ghost_edges_and_cloth_face_against_trimesh():
    import trimesh

    from dopt.view.mjscene import face_up
    from dopt.view.player import edges

    rng = np.random.default_rng(3)
    for _ in range(10):
        a, b = (int(v) for v in rng.integers(2, 9, 2))
        grid = trimesh.creation.box()           # closed surface: trimesh's own edge count
        assert len(edges(grid.faces)) == len(grid.edges_unique)
        xs, ys = np.meshgrid(np.arange(a), np.arange(b), indexing="ij")
        verts = np.c_[xs.ravel(), ys.ravel(), np.zeros(a * b)]
        i = (np.arange(a - 1)[:, None] * b + np.arange(b - 1)[None]).ravel()
        faces = np.r_[np.c_[i, i + b, i + 1], np.c_[i + 1, i + b, i + b + 1]]
        mesh = trimesh.Trimesh(verts, faces, process=False)
        assert len(edges(faces)) == len(mesh.edges_unique)
        assert face_up(verts, faces) == (mesh.face_normals[:, 2].sum() >= 0)
        assert face_up(verts, faces[:, ::-1]) != face_up(verts, faces)


def test_offscreen_gl_keeps_a_set_choice_and_matches_pyopengl(monkeypatch):
    """MUJOCO_GL set: untouched; PYOPENGL_PLATFORM naming a backend: that one (mujoco.egl
    refuses a mismatch); neither: EGL where libEGL is found, else OSMesa where libOSMesa is,
    PYOPENGL_PLATFORM set to match."""
    from dopt.view import cli

    env = {"MUJOCO_GL": "glfw"}
    assert cli.offscreen_gl(env) is None and env == {"MUJOCO_GL": "glfw"}
    env = {"PYOPENGL_PLATFORM": "osmesa"}
    assert cli.offscreen_gl(env) == "osmesa" and env["MUJOCO_GL"] == "osmesa"
    for found, expected in [({"EGL", "OSMesa"}, "egl"), ({"OSMesa"}, "osmesa"),
                            ({"EGL"}, "egl"), (set(), "egl")]:
        monkeypatch.setattr(cli, "_has_library", lambda name, found=found: name in found)
        env = {}
        assert cli.offscreen_gl(env) == expected
        assert env == {"MUJOCO_GL": expected, "PYOPENGL_PLATFORM": expected}
