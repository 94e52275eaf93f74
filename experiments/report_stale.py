"""Stale results: a result recorded on a named preset (a physics preset, a protocol's budget,
the SVR protocol) that no longer resolves to the fields it ran with, or whose trials ran on
code that has changed since in the files that compute them (``code_findings``).

The presets live in code that needs torch and MuJoCo, which experiments/report.py does not
load. So ``python experiments/presets_snapshot.py`` writes what every preset resolves to today
into ``<results dir>/presets/resolved.json`` (a test fails while that file is not what the
code gives), and this module compares each result's recorded fields with it, standard library
only:

- Fig. 7 (``experiment`` "fig7"): the recorded settings, less their departures and the thread
  count, against the protocol's preset today (``pick.protocols``); the recorded scene
  (``physics.scene``, and ``planning_scene``) against the named physics preset today
  (``pick.physics``), less the fields the settings set themselves (``OWN_SCENE_FIELDS``); the
  stability bounds and the picker (less its bound, workspace and a departing speed) against
  what the protocol's preset resolves to (``pick.resolved``).
- The Panda's execution: per goal, the same against protocol "ours".
- Key particles: the physics presets of its simulated goals.
- Table 1 and the experiments on its protocol (table1, svr_explain, clock_check, fig4): a trial's
  settings (every ``SVRMPCSettings`` field is in each trial's params) against the preset the
  summary names (``preset``, else the command's ``--preset``, else "ours"), on the fields the
  preset sets (``SVR_PRESET_FIELDS``) less those the command's flags set.

A result that records only a preset's name (files written before the resolved fields were
recorded) is compared through the snapshot's "at_commit" part: what the presets resolved to at
the result's commit, which presets_snapshot.py reads from that commit's code (``git
archive``). Where that is missing the result is "not checked", never silently current. Fields a
record does not hold (added to a config since) are not compared.
"""

from __future__ import annotations

import functools
import json
import re
import shlex
import subprocess
from pathlib import Path

from report_base import Result

from dopt.lab.dicts import flatten
from planners.trial_progress import RUN_ONLY_SETTINGS

#: where the snapshot lies under the results folder
SNAPSHOT = Path("presets") / "resolved.json"
#: scene-config fields a pick-and-place trial's own settings set (not the physics preset's)
OWN_SCENE_FIELDS = ("n", "side", "length", "selfcollide", "mass")
#: picker fields its settings set (bound, workspace from the side and the stretch limit)
OWN_PICKER_FIELDS = ("bound", "workspace")
#: the SVRMPCSettings fields a Table 1 protocol sets (the rest are the row's and the run's)
SVR_PRESET_FIELDS = ("cost", "warm_start", "control_noise", "clock", "nominal_threads",
                     "synchronous", "problem", "layouts", "islands", "fd_centered", "fd_eps",
                     "keypoints", "fd_skip", "box_qp", "executor")
#: experiments/mpc.py's flags -> the SVRMPCSettings fields they set
SVR_FLAGS = {"--cost": ("cost",), "--control-noise": ("control_noise",), "--clock": ("clock",),
             "--clock-ms": ("clock", "clock_ms"), "--executor": ("executor",),
             "--warm-start": ("warm_start",), "--nominal-threads": ("nominal_threads",),
             "--fd": ("fd_centered", "fd_eps"), "--fd-skip": ("keypoints", "fd_skip"),
             "--keypoints": ("keypoints", "fd_skip"), "--box-qp": ("box_qp",),
             "--islands": ("islands",), "--layouts": ("layouts",)}
#: the experiment kinds that run on Table 1's protocol
SVR_KINDS = ("table1", "svr_explain", "clock_check", "fig4")
#: the files that compute an MPC trial on Table 1's protocol (git pathspecs): the runtime
#: (dopt, less the lab: sweeps, packs, file writing, provenance, statistics, the command-line
#: helpers and console scripts, the viewer and its blow-up captures) and the SVR slice's
#: planners; a change elsewhere (summaries, reports, the viewer) cannot change a trial's outcome
SVR_COMPUTE_PATHS = ("dopt", "planners/ilqr.py", "planners/svr.py", "planners/keypoints.py",
                     "planners/_checks.py", "planners/svr_mpc/episode.py",
                     "planners/svr_mpc/optimisers.py", "planners/svr_mpc/settings.py",
                     "planners/svr_mpc/authors_clock.py",
                     *(f":(exclude)dopt/{f}" for f in (
                         "lab", "sweep*.py", "trialpack.py", "jsonio.py", "atomic.py",
                         "provenance.py", "stats.py", "multiple.py", "cli.py", "scripts.py",
                         "bench", "render.py", "view", "blowup.py")))


def load_snapshot(results_dir: Path) -> dict | None:
    """The snapshot under ``results_dir`` (``SNAPSHOT``), or None without one."""
    path = Path(results_dir) / SNAPSHOT
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: not a readable presets snapshot ({e})") from e
    return data if isinstance(data, dict) else None


def base_commit(commit) -> str | None:
    """A recorded commit without "-dirty" (None when there is none)."""
    return commit.removesuffix("-dirty") if isinstance(commit, str) and commit else None


def needs_backfill(r: Result) -> bool:
    """Whether ``r`` records only the names of the pick-and-place presets it ran on, so that
    the snapshot's "at_commit" part must say what they meant at its commit."""
    d = r.data
    if r.kind == "fig7":
        return not isinstance(d.get("physics"), dict)
    if r.kind == "panda_execute":
        return not isinstance(d.get("physics"), dict)
    if r.kind == "key_particles":
        simulated = (d.get("robustness") or {}).get("simulated") or []
        return bool(simulated) and "simulated_scenes" not in (d.get("settings") or {})
    return False


def _same(a, b) -> bool:
    """Equal as JSON values (tuples and lists alike; 1 and 1.0 alike)."""
    return json.loads(json.dumps(a)) == json.loads(json.dumps(b))


def _value(v) -> str:
    return f"{v:g}" if isinstance(v, float) else json.dumps(v)


def _diff(recorded: dict, today: dict, skip=()) -> list[str]:
    """"field recorded -> today" of the fields both hold that differ (``skip`` left out)."""
    rec, now = flatten(recorded), flatten(today)
    return [f"{k} {_value(rec[k])} -> {_value(now[k])}" for k in now
            if k in rec and k.split(".")[0] not in skip and k not in skip
            and not _same(rec[k], now[k])]


def _pick_findings(what: str, settings: dict, physics: dict | None, protocol: str,
                   departures: dict, snap: dict, at: dict | None, quick: bool) -> list[str]:
    """Findings of one pick-and-place settings dict (fig7, a Panda goal)."""
    task, goal = settings.get("task"), settings.get("goal")
    out = []
    pick = snap.get("pick") or {}
    preset = ((pick.get("protocols") or {}).get(protocol) or {}).get(f"{task}/{goal}")
    departing = set(flatten(departures or {}))
    if preset is not None and not quick:
        diff = _diff(settings, preset, skip=(*RUN_ONLY_SETTINGS, *departing))
        if diff:
            out.append(f"{what}protocol `{protocol}` now sets " + ", ".join(diff))
    physics_now = (pick.get("physics") or {}).get(task) or {}
    scenes = {"scene": settings.get("physics")}
    if settings.get("planning_physics"):
        scenes["planning_scene"] = settings["planning_physics"]
    for key, name in scenes.items():
        if name not in physics_now:
            continue
        if physics is not None:
            recorded = physics.get(key)
        else:
            recorded = (((at or {}).get("pick") or {}).get("physics") or {}).get(task, {}).get(name)
        if not isinstance(recorded, dict):
            continue
        diff = _diff(recorded, physics_now[name], skip=OWN_SCENE_FIELDS)
        if diff:
            out.append(f"{what}{task} physics preset `{name}` now resolves to "
                       + ", ".join(diff))
    resolved = ((pick.get("resolved") or {}).get(protocol) or {}).get(f"{task}/{goal}")
    if physics is not None and resolved is not None:
        diff = _diff(physics.get("stability") or {}, resolved.get("stability") or {})
        if diff:
            out.append(f"{what}stability bounds now " + ", ".join(diff))
        speed = ("speed",) if settings.get("picker_speed") is not None else ()
        diff = _diff(physics.get("picker") or {}, resolved.get("picker") or {},
                     skip=(*OWN_PICKER_FIELDS, *speed))
        if diff:
            out.append(f"{what}picker now " + ", ".join(diff))
    return out


def command_preset(command: str) -> tuple[str | None, set]:
    """The ``--preset`` a command names (None: none) and the flags it gives."""
    try:
        words = shlex.split(command)
    except ValueError:
        words = command.split()
    flags = {w.split("=")[0] for w in words if w.startswith("--")}
    for i, w in enumerate(words):
        if w == "--preset" and i + 1 < len(words):
            return words[i + 1], flags
        if w.startswith("--preset="):
            return w.split("=", 1)[1], flags
    return None, flags


def _svr_findings(r: Result, snap: dict, params: dict | None) -> list[str]:
    """Findings of a result on Table 1's protocol, from a trial's params (or the summary's
    recorded "settings")."""
    named, flags = command_preset(r.origin_command)
    preset = r.data.get("preset") or named or "ours"
    task = r.data.get("task")
    today = ((snap.get("svr_mpc") or {}).get(preset) or {}).get(task)
    settings = r.data.get("settings")
    if isinstance(settings, dict) and settings and all(isinstance(v, dict)
                                                       for v in settings.values()):
        params = next(iter(settings.values()))          # {row: settings}: rho_sweep's
    if not isinstance(today, dict) or "error" in today or not isinstance(params, dict):
        return []
    flagged = {f for flag in flags for f in SVR_FLAGS.get(flag, ())}
    if r.kind == "clock_check":             # it runs each trial under both clocks itself
        flagged.add("clock")
    fields = [f for f in SVR_PRESET_FIELDS if f not in flagged]
    # a row's own derivative variants (sum-t10-r1+skip5): not the protocol's
    if params.get("method") != "baseline":
        fields = [f for f in fields if f not in ("fd_centered", "fd_eps", "keypoints",
                                                 "fd_skip", "box_qp")]
    diff = _diff({k: params[k] for k in fields if k in params},
                 {k: today[k] for k in fields if k in today})
    return [f"protocol `{preset}` on {task} now sets " + ", ".join(diff)] if diff else []


def stale_findings(r: Result, snap: dict | None, params: dict | None = None) -> list[str] | None:
    """What in ``r`` today's presets no longer give (one string each; empty: current), or
    None where it cannot be checked (no snapshot, or a result that records only preset names
    whose commit the snapshot does not resolve). ``params``: a trial's params (Table 1's
    protocol)."""
    if snap is None:
        return None
    d = r.data
    at = (snap.get("at_commit") or {}).get(base_commit(r.origin.get("git_commit")) or "")
    if needs_backfill(r) and at is None:
        return None
    if r.kind == "fig7" and isinstance(d.get("settings"), dict):
        return _pick_findings("", d["settings"], d.get("physics") if isinstance(
            d.get("physics"), dict) else None, d.get("protocol", "ours"),
            d.get("departures") or {}, snap, at, r.quick)
    if r.kind == "panda_execute" and isinstance(d.get("settings"), dict):
        out = []
        physics = d.get("physics") if isinstance(d.get("physics"), dict) else {}
        for goal, s in d["settings"].items():
            out += _pick_findings(f"{goal}: ", s, physics.get(goal) if physics else None,
                                  "ours", {}, snap, at, r.quick)
        return out
    if r.kind == "key_particles":
        scenes = (d.get("settings") or {}).get("simulated_scenes")
        physics_now = ((snap.get("pick") or {}).get("physics") or {}).get("cloth") or {}
        names = sorted({row.get("physics") for row in (d.get("robustness") or {})
                        .get("simulated") or [] if row.get("physics")})
        out = []
        for name in names:
            recorded = ((scenes or {}).get(name) if scenes is not None else
                        (((at or {}).get("pick") or {}).get("physics") or {}).get("cloth", {})
                        .get(name))
            if isinstance(recorded, dict) and name in physics_now:
                diff = _diff(recorded, physics_now[name], skip=OWN_SCENE_FIELDS)
                if diff:
                    out.append(f"simulated goals: cloth physics preset `{name}` now resolves "
                               "to " + ", ".join(diff))
        return out
    if r.kind in SVR_KINDS:
        return _svr_findings(r, snap, params)
    return []


def _head(root: str) -> str | None:
    """HEAD's sha of the git checkout at ``root`` (None: not one)."""
    try:
        proc = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


@functools.cache
def _changed_since(root: str, commit: str, head: str) -> tuple[str, ...] | None:
    """The files of ``SVR_COMPUTE_PATHS`` that differ between ``commit`` and ``head`` in the
    git checkout at ``root``; None where git cannot say (a commit it does not know)."""
    try:
        proc = subprocess.run(["git", "-C", root, "diff", "--name-only", commit, head, "--",
                               *(f":(top{',exclude' if p.startswith(':(exclude)') else ''})"
                                 + p.removeprefix(":(exclude)") for p in SVR_COMPUTE_PATHS)],
                              capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return tuple(proc.stdout.split()) if proc.returncode == 0 else None


def _verification(root: Path, r: Result, head: str) -> str | None:
    """What ``verified/<result>`` (experiments/verify_trials.py) says of ``r`` today: None
    without one, or when the code that computes trials changed since it ran; "" where every
    rerun gave its recorded outcome at a commit with today's code; a finding where a rerun
    differed."""
    path = Path(root) / "verified" / r.name
    try:
        v = json.loads(path.read_text())
        commit = v["provenance"]["git_commit"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    base = base_commit(commit)
    if not base or base != commit or _changed_since(str(root), base, head) != ():
        return None
    if v.get("all_equal") is True:
        return "verified"
    return (f"the code at {base[:8]} reruns {sum(not t.get('equal') for t in v['trials'])} of "
            f"{len(v['trials'])} sampled trials to other outcomes (verified/{r.name})")


def code_findings(r: Result, root: Path) -> list[str]:
    """Per commit its trials ran on (``trial_commits``), of a result on Table 1's protocol:
    the files that compute its trials and changed since, one finding each (none: the code is
    the same, git cannot say, or a sample of its trials reran to the last bit at a commit whose
    code is today's: ``experiments/verify_trials.py``)."""
    if r.kind not in SVR_KINDS or not isinstance(r.data.get("trial_commits"), dict):
        return []
    head = _head(str(root))
    if head is None:
        return []
    checked = _verification(root, r, head)
    if checked is not None and not checked.startswith("the code "):
        return []                        # a sample reran to the last bit since the change
    out = [checked] if checked else []
    for commit in sorted(r.data["trial_commits"]):
        base = base_commit(commit)
        changed = _changed_since(str(root), base, head) if base else None
        if changed:
            more = f" and {len(changed) - 3} more" if len(changed) > 3 else ""
            out.append(f"the code that computes its trials changed since {base[:8]} ("
                       + ", ".join(changed[:3]) + more + ")")
    return out


def stale_note(findings: list[str] | None, *, short: bool = False) -> str:
    """How a page shows a result's findings: "" when current; the README (``short``) gives
    the first finding and how many more."""
    if findings is None or not findings:
        return ""
    if short:
        more = f" (and {len(findings) - 1} more)" if len(findings) > 1 else ""
        return f"**stale**: {_arrows(findings[0])}{more}"
    presets = [_arrows(f) for f in findings if not f.startswith("the code ")]
    code = [f for f in findings if f.startswith("the code ")]
    return ("**Stale**: " + "; ".join(
        ([f"recorded on presets that today's code resolves otherwise ({'; '.join(presets)})"]
         if presets else []) + code) + "; rerun the command to record it on today's code.")


def _arrows(text: str) -> str:
    return re.sub(r" -> ", " → ", text)
