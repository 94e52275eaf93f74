"""Stale results on Table 1's protocol (table1, svr_explain, clock_check, fig4): a trial's
settings (every ``SVRMPCSettings`` setting is in each trial's params, flat) against the preset the
summary names (``preset``, else the command's ``--preset``, else "ours") as it resolves today
(``svr_presets``), on the fields the preset sets (``SVR_PRESET_FIELDS``) less those the
command's flags set; and the files that compute its trials (``SVR_COMPUTE_PATHS``) changed since
its trials' commits (``dopt.lab.report.stale.code_findings``; ``verify_trials`` reruns a sample
to the last bit).
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

from dopt.lab.report.base import Result
from dopt.lab.report.stale import _diff, code_findings, command_preset
from dopt.lab.report.trials import TrialInfo, first_params

#: the settings a Table 1 protocol sets, by flat name (a trial's params'; the rest are the
#: row's and the run's)
SVR_PRESET_FIELDS = ("cost", "warm_start", "control_noise", "clock", "nominal_threads",
                     "synchronous", "problem", "layouts", "islands", "fd_centered", "fd_eps",
                     "keypoints", "fd_skip", "box_qp", "executor")
#: experiments/mpc.py's hand-written flags -> the settings they set, by flat name (the derived
#: ones, each setting its own field, are added from ``mapping.SETTINGS``: ``svr_flags``)
SVR_FLAGS = {"--clock-ms": ("clock", "clock_ms"), "--fd": ("fd_centered", "fd_eps"),
             "--fd-skip": ("keypoints", "fd_skip"), "--keypoints": ("keypoints", "fd_skip"),
             "--box-qp": ("box_qp",), "--layouts": ("layouts",),
             "--config": SVR_PRESET_FIELDS}       # a settings file may set any of them


@functools.cache
def svr_flags() -> dict[str, tuple[str, ...]]:
    """Every flag of experiments/mpc.py -> the settings it sets (flat names): ``SVR_FLAGS``
    and the flags derived from the settings (a switch's --no- spelling too)."""
    from planners.svr_mpc.experiments.mapping import SETTINGS

    derived = {}
    for f in SETTINGS.flags:
        name = f.path.rsplit(".", 1)[-1]              # a group's field: its flat name
        derived[f.flag] = (name,)
        if f.kind is bool:
            derived[f"--no-{f.flag[2:]}"] = (name,)
    return {**derived, **SVR_FLAGS}


#: the experiment kinds that run on Table 1's protocol
SVR_KINDS = ("table1", "svr_explain", "clock_check", "fig4")
#: the files that compute an MPC trial on Table 1's protocol (git pathspecs): the runtime
#: (dopt, less the lab: sweeps, packs, file writing, provenance, statistics, the command-line
#: helpers and console scripts, the viewer and its blow-up captures) and the SVR slice's
#: planners; a change elsewhere (summaries, reports, the viewer) cannot change a trial's outcome
SVR_COMPUTE_PATHS = ("dopt", "planners/ilqr.py", "planners/svr.py", "planners/keypoints.py",
                     "planners/_checks.py", "planners/svr_mpc/episode.py",
                     "planners/svr_mpc/optimisers.py", "planners/svr_mpc/settings.py",
                     "planners/svr_mpc/settings_groups.py",
                     "planners/svr_mpc/authors_clock.py", "planners/svr_mpc/presets.py",
                     *(f":(exclude)dopt/{f}" for f in (
                         "lab", "sweep*.py", "trialpack.py", "jsonio.py", "atomic.py",
                         "provenance.py", "stats.py", "multiple.py", "cli.py", "scripts.py",
                         "bench", "render.py", "view", "blowup.py",
                         # the pick wing: no MPC trial loads it (tests/test_layers.py)
                         "tasks/pick")))


@functools.cache
def svr_presets() -> dict:
    """{"ours", "paper", "authors": {task: every setting, flat (``SVRMPCSettings.params``)}}
    of today's code, as JSON values (a preset a task cannot resolve, the authors' clutter
    without their scenes: {"error": why})."""
    from dataclasses import replace

    from dopt.tasks import PUSH_TASKS
    from planners.svr_mpc import SVRMPCSettings

    out: dict = {"ours": {}, "paper": {}, "authors": {}}
    for task in PUSH_TASKS:
        for name, make in (("ours", lambda t: replace(SVRMPCSettings(), task=t)),
                           ("paper", SVRMPCSettings.paper), ("authors", SVRMPCSettings.authors)):
            try:
                out[name][task] = make(task).params()
            except (ValueError, TypeError) as e:
                out[name][task] = {"error": f"{type(e).__name__}: {e}"}
    return json.loads(json.dumps(out))


def _svr_findings(r: Result, params: dict | None) -> list[str]:
    """Findings of a result on Table 1's protocol, from a trial's params (or the summary's
    recorded "settings")."""
    named, flags = command_preset(r.origin_command)
    preset = r.data.get("preset") or named or "ours"
    task = r.data.get("task")
    today = (svr_presets().get(preset) or {}).get(task)
    settings = r.data.get("settings")
    if isinstance(settings, dict) and settings and all(isinstance(v, dict)
                                                       for v in settings.values()):
        params = next(iter(settings.values()))          # {row: settings}: rho_sweep's
    if not isinstance(today, dict) or "error" in today or not isinstance(params, dict):
        return []
    flagged = {f for flag in flags for f in svr_flags().get(flag, ())}
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


def svr_stale(r: Result, results_dir: Path, trials: TrialInfo | None) -> list[str]:
    """The findings of a result on Table 1's protocol: its settings against today's preset
    (from its first baseline trial's params, or the summary's recorded "settings"), then the
    code that computes its trials changed since."""
    return (_svr_findings(r, first_params(trials))
            + code_findings(r, results_dir, SVR_COMPUTE_PATHS))
