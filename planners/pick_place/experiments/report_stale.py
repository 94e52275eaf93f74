"""Stale pick-and-place results: recorded settings that today's presets no longer give.

- Fig. 7 (``experiment`` "fig7"): the recorded settings, less their departures and the thread
  count, against the protocol's preset today (``PickPlaceSettings.preset``); the recorded scene
  (``physics.scene``, and ``planning_scene``) against the named physics preset today
  (``ClothSceneConfig.preset`` / ``RopeSceneConfig.preset``), less the fields the settings set
  themselves (``OWN_SCENE_FIELDS``); the stability bounds and the picker (less its bound,
  workspace and a departing speed) against what the protocol's preset resolves to
  (``resolved_physics``).
- The Panda's execution: per goal, the same against protocol "ours".
- Key particles: the physics presets of its simulated goals.

A result that records only a preset's name (files written before the resolved fields were
recorded) is compared with what the presets meant at its commit, as ``AT_COMMIT`` (a file of
history under the results folder, read once from those commits' code) holds it; a commit it
does not hold leaves the result "not checked", never silently current. Fields a record does
not hold (added to a config since) are not compared.
"""

from __future__ import annotations

import functools
import json
from dataclasses import asdict
from pathlib import Path

from dopt.lab.dicts import flatten
from dopt.lab.report.base import Result
from dopt.lab.report.stale import _diff, base_commit
from planners.trial_progress import RUN_ONLY_SETTINGS

#: what the presets meant at the commits of results that record only their names
AT_COMMIT = Path("presets") / "at-commit.json"
#: scene-config fields a pick-and-place trial's own settings set (not the physics preset's)
OWN_SCENE_FIELDS = ("n", "side", "length", "selfcollide", "mass")
#: picker fields its settings set (bound, workspace from the side and the stretch limit)
OWN_PICKER_FIELDS = ("bound", "workspace")


@functools.cache
def today() -> dict:
    """What every pick-and-place preset resolves to today, as JSON values: "physics" {cloth,
    rope: {name: every field of the scene config's preset}}, "protocols" {protocol:
    {"task/goal": ``PickPlaceSettings.preset(...).to_dict()`` less the threads}}, "resolved"
    {protocol: {"task/goal": ``resolved_physics()``}}."""
    import planners.pick_place as pp
    from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS as CLOTH
    from dopt.tasks.pick.cloth_scene import ClothSceneConfig
    from dopt.tasks.pick.rope_scene import PHYSICS_PRESETS as ROPE
    from dopt.tasks.pick.rope_scene import RopeSceneConfig

    out: dict = {"physics": {"cloth": {n: asdict(ClothSceneConfig.physics(n)) for n in CLOTH},
                             "rope": {n: asdict(RopeSceneConfig.physics(n)) for n in ROPE}},
                 "protocols": {}, "resolved": {}}
    for p in pp.PROTOCOLS:
        for task, goals in pp.GOALS.items():
            for goal in goals:
                s = pp.PickPlaceSettings.preset(task, goal, protocol=p)
                d = s.to_dict()
                d.pop("threads", None)
                out["protocols"].setdefault(p, {})[f"{task}/{goal}"] = d
                out["resolved"].setdefault(p, {})[f"{task}/{goal}"] = s.resolved_physics()
    return json.loads(json.dumps(out, default=str))


def _at_commits(results_dir: str) -> dict:
    path = Path(results_dir) / AT_COMMIT
    try:
        return json.loads(path.read_text()).get("at_commit") or {}
    except (OSError, ValueError, AttributeError):
        return {}


def at_commit(results_dir: Path, r: Result) -> dict | None:
    """What the pick-and-place presets meant at ``r``'s commit (``AT_COMMIT``; None: not
    held)."""
    return _at_commits(str(results_dir)).get(base_commit(r.origin.get("git_commit")) or "")


def needs_backfill(r: Result) -> bool:
    """Whether ``r`` records only the names of the pick-and-place presets it ran on, so that
    ``AT_COMMIT`` must say what they meant at its commit."""
    d = r.data
    if r.kind == "fig7":
        return not isinstance(d.get("physics"), dict)
    if r.kind == "panda_execute":
        return not isinstance(d.get("physics"), dict)
    if r.kind == "key_particles":
        simulated = (d.get("robustness") or {}).get("simulated") or []
        return bool(simulated) and "simulated_scenes" not in (d.get("settings") or {})
    return False


def _pick_findings(what: str, settings: dict, physics: dict | None, protocol: str,
                   departures: dict, at: dict | None, quick: bool) -> list[str]:
    """Findings of one pick-and-place settings dict (fig7, a Panda goal) against today's
    presets (``today``); ``at``: what they meant at the result's commit, for a result that
    records only their names (``AT_COMMIT``)."""
    task, goal = settings.get("task"), settings.get("goal")
    out = []
    pick = today()
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




def pick_stale(r: Result, results_dir: Path) -> list[str] | None:
    """What in a Fig. 7, Panda or key-particle result today's presets no longer give (one
    string each; empty: current), or None where it records only preset names whose commit
    ``AT_COMMIT`` does not hold."""
    d = r.data
    at = at_commit(results_dir, r)
    if needs_backfill(r) and at is None:
        return None
    if r.kind == "fig7" and isinstance(d.get("settings"), dict):
        return _pick_findings("", d["settings"], d.get("physics") if isinstance(
            d.get("physics"), dict) else None, d.get("protocol", "ours"),
            d.get("departures") or {}, at, r.quick)
    if r.kind == "panda_execute" and isinstance(d.get("settings"), dict):
        out = []
        physics = d.get("physics") if isinstance(d.get("physics"), dict) else {}
        for goal, s in d["settings"].items():
            out += _pick_findings(f"{goal}: ", s, physics.get(goal) if physics else None,
                                  "ours", {}, at, r.quick)
        return out
    if r.kind == "key_particles":
        return _key_particles(d, at)
    return []


def _key_particles(d: dict, at: dict | None) -> list[str]:
    scenes = (d.get("settings") or {}).get("simulated_scenes")
    physics_now = (today().get("physics") or {}).get("cloth") or {}
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
