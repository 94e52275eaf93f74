"""The experiments' flags (``flags``) as settings and trials: the settings flags derived from
``SVRMPCSettings`` (``SETTINGS``: preset < ``--config`` < flags), each Table 1 row's settings
under them (``settings_of``), the rows of the flags (``grid``), the sweep's trials with their
keys (``make_trials``: ``trial_key``; a committed trial of an older name is found through
the sweep's schema, ``runner.SCHEMA``) and the protocol a
summary records (``protocol``), which a summary given to ``--config`` gives back
(``summary_config``)."""

from __future__ import annotations

from dataclasses import replace

from dopt.lab.flags import SettingsFlags, apply, default_text, read_config
from dopt.lab.provenance import rooted
from dopt.lab.sweep import Trial
from dopt.tasks import PUSH_TASKS
from planners.ilqr import FINITE_DIFFERENCES
from planners.svr import METHODS, paper_theta
from planners.svr_mpc import (
    PRESETS,
    TABLE1_ROWS,
    Derivatives,
    Row,
    SVRMPCSettings,
    parse_row,
    row_label,
    task_defaults,
    trial_key,
    trial_params,
)
from planners.svr_mpc.presets import protocol_fields
from planners.svr_mpc.settings import RECORD_NAMES, record_path

#: --feedback -> the feedback settings each trial runs under
FEEDBACK = {"off": (False,), "on": (True,), "both": (False, True)}
#: the SVRMPCSettings fields (dotted paths) with a flag of their own name, derived from the
#: field (``dopt.lab.flags``); the rest are set by the rows (method, theta, rho, the derivative
#: variants, the fixes), by flags of the run (--task, --feedback, --threads, --layouts, and
#: --fd/--fd-skip/--keypoints/--box-qp, which build one ``Derivatives``) or by the preset
SETTINGS_FIELDS = ("cost", "start.warm_start", "execution.control_noise", "timing.clock",
                   "timing.clock_ms", "execution.executor", "timing.nominal_threads",
                   "timing.slowdown", "execution.timeout", "scene.islands", "start.push_tail")
#: the settings (flat names) a --config file may not set: the rows' and those of flags that
#: always decide (each with the flag that sets it)
NOT_CONFIG = {"method": "--rows/--rules", "rho": "--rows/--rho", "theta": "--rows/--theta",
              "feedback": "--feedback", "threads": "--threads"}


def _show(value) -> str:
    """A default in the help: a switch's on/off, a number as %g."""
    if isinstance(value, bool):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, float) else str(value)


def preset_text(path: str) -> str | None:
    """The default of a settings field (its dotted ``path``) in its flag's help: its value
    under each preset (``planners.svr_mpc.presets``, by flat name) per task, where they differ
    (``default_text``)."""
    name, plain = path.rsplit(".", 1)[-1], SVRMPCSettings().params()
    return default_text({preset: {task: protocol_fields(preset, task).get(name, plain[name])
                                  for task in PUSH_TASKS} for preset in PRESETS}, _show)


def summary_config(data: dict) -> dict:
    """The settings of a run's summary.json (a --config file), by flat name (a trial's
    params'): the protocol it records (``protocol``: the settings, --fd as fd_centered and its
    step) and its task; a fig4 summary's per-row "settings", the fields common to its rows. The
    rows' and the run flags' fields (``NOT_CONFIG``) are left to this run."""
    rows = data.get("settings")
    if isinstance(rows, dict) and rows and all(isinstance(v, dict) for v in rows.values()):
        rows = list(rows.values())
        out = {k: v for k, v in rows[0].items() if all(r.get(k) == v for r in rows[1:])}
    else:
        out = {k: v for k, v in data.items() if k in RECORD_NAMES}
        if data.get("fd") in FINITE_DIFFERENCES:
            named = FINITE_DIFFERENCES[data["fd"]]
            out.update(fd_centered=named.centered, fd_eps=named.eps)
    out.pop("seed", None)
    return {k: v for k, v in out.items() if k not in NOT_CONFIG}


#: the settings flags of every SVR experiment, with --config (a file names a setting by its
#: dotted path or by its flat name: ``record_path``)
SETTINGS = SettingsFlags(SVRMPCSettings, SETTINGS_FIELDS, defaults=preset_text,
                         summary=summary_config, record=record_path)


def config_of(args) -> dict:
    """The --config file's settings ({dotted path: value}; empty without one), read once
    (``read_config``: ValueError naming the file and the key) and kept on ``args``."""
    if getattr(args, "config", None) is None:
        return {}
    if getattr(args, "config_values", None) is None:
        values = read_config(args.config, SVRMPCSettings, summary_config, record_path)
        bad = sorted(name for k in values if (name := k.rsplit(".", 1)[-1]) in NOT_CONFIG)
        if bad:
            raise ValueError(f"{args.config}: setting {bad[0]!r} is this run's own "
                             f"({NOT_CONFIG[bad[0]]}), not a settings file's")
        args.config_values = values
    return args.config_values


def flag_overrides(args) -> dict:
    """The settings the flags give ({dotted path: value}): the derived flags' (``SETTINGS``),
    and --clock-ms's model clock."""
    over = SETTINGS.overrides(args)
    if over.get("timing.clock_ms") is not None:
        over.setdefault("timing.clock", "model")
    return over


def base_settings(args) -> SVRMPCSettings:
    """The run's settings before its rows: the preset on the task, then the --config file's
    settings (``config_of``), then the flags' (``flag_overrides``); TypeError / ValueError as
    the settings refuse them."""
    config = dict(config_of(args))
    config.pop("task", None)                  # --task's, or the config's (flags.parse_args)
    layouts = args.layouts or (rooted(config["scene.layouts"]) if args.preset == "authors"
                               and config.get("scene.layouts") else None)
    preset = SVRMPCSettings.preset(args.task, protocol=args.preset,
                                    layouts=str(layouts) if layouts else None)
    if layouts is not None:
        config.pop("scene.layouts", None)
    return apply(apply(preset, config), flag_overrides(args))


def derivatives_of(args, base: Derivatives) -> Derivatives:
    """``base`` (the preset's and the config's) with what --fd, --keypoints, --fd-skip and
    --box-qp give: --keypoints adaptive, else --fd-skip K > 1 the skip (1: every timestep)."""
    d = base
    if getattr(args, "fd", None) is not None:
        d = replace(d, fd=args.fd, fd_eps=None)
    if getattr(args, "keypoints", None) is not None or getattr(args, "fd_skip", None):
        skip = args.fd_skip or 1
        kp = args.keypoints or ("skip" if skip > 1 else "every")
        d = replace(d, keypoints=kp, fd_skip=skip if kp == "skip" else 1)
    if getattr(args, "box_qp", None):
        d = replace(d, box_qp=True)
    return d


def settings_of(args, row: Row, feedback: bool, base: SVRMPCSettings | None = None
                ) -> SVRMPCSettings:
    """The settings of one row (``parse_row``) under the flags: the preset's, the --config
    file's and the flags' (``base_settings``; ``base``: them, computed once), then the row's
    own method, theta, rho, derivative variants and fixes."""
    base = base_settings(args) if base is None else base
    s = row.apply(replace(base, derivatives=derivatives_of(args, base.derivatives)))
    slowdown = base.timing.slowdown or task_defaults(args.task)[0]
    return replace(s, task=args.task, threads=args.threads or 0,
                   timing=replace(s.timing, slowdown=slowdown),
                   execution=replace(s.execution, feedback=feedback))


def baseline_label(args) -> str:
    """The row label (``row_label``) of the baseline trials of the flags: the row every other
    is normalised by."""
    return row_label(settings_of(args, Row("baseline", 0, 1.0), args.feedback == "on").params())


def grid(args, rules=None, rhos=None, thetas=None) -> list[Row]:
    """The rows of the flags: those of --rows (default with --preset paper or authors and no
    --rules: the nine of Table 1; ``parse_row``), else every (rule, rho, theta) of the
    arguments or flags (--rules' default: all five DoF-selection rules, ``METHODS``), without
    variants of their own."""
    rows, flag = getattr(args, "rows", None), getattr(args, "rules", None)
    if (rows is None and rules is None and flag is None
            and args.preset in ("paper", "authors") and hasattr(args, "rows")):
        rows = list(TABLE1_ROWS)
    if rows:
        return [parse_row(r) for r in rows]
    flag = flag or (list(METHODS) if hasattr(args, "rules") else ["baseline"])
    return [Row(m, t, rho) for m in rules or flag
            for rho in rhos or [getattr(args, "rho", 1.0)]
            for t in thetas or [_theta(getattr(args, "theta", None), m)]]


def make_trials(args, rules=None, rhos=None, thetas=None, **override) -> list[Trial]:
    """Every (seed, row, feedback) trial of the flags (``grid``; ``rules``, ``rhos``,
    ``thetas``: the grid's in place of the flags'), each with its key (``trial_key``);
    ``override``: settings replaced in every trial, as ``SVRMPCSettings.with_params`` takes
    them (e.g. clock="real")."""
    out, base = [], base_settings(args)
    for seed in range(args.seed, args.seed + args.trials):
        for row in grid(args, rules, rhos, thetas):
            for feedback in FEEDBACK[args.feedback]:
                s = settings_of(args, row, feedback, base).with_params(**override)
                p = trial_params(s, seed, row.optimiser)
                out.append(Trial(trial_key(p), p))
    return out


def _theta(theta: int | None, method: str) -> int:
    """--theta, or the paper's Table 1 value for the rule (rand 5, svr 10; unused else)."""
    return paper_theta(method) if theta is None else theta


def protocol(args, params: dict) -> dict:
    """The protocol a summary records: preset, cost, warm start, clock, nominal threads,
    control noise, finite differences, slowdown (and a timeout, a --config file where given)
    of a trial's params under the flags; ``summary_config`` reads it back."""
    return {"preset": args.preset, "cost": params["cost"], "warm_start": params["warm_start"],
            "clock": params["clock"], "nominal_threads": params["nominal_threads"],
            "control_noise": params["control_noise"],
            "fd": "central" if params["fd_centered"] else "forward",
            "keypoints": params["keypoints"], "fd_skip": params["fd_skip"],
            "box_qp": params["box_qp"], "slowdown": params["slowdown"],
            "problem": params["problem"], "layouts": params["layouts"],
            "islands": params["islands"], "push_tail": params["push_tail"],
            "executor": params.get("executor", "alg1"),
            **({"clock_ms": params["clock_ms"]} if params.get("clock_ms") is not None else {}),
            **({"timeout": params["timeout"]} if params.get("timeout") is not None else {}),
            **({"config": str(args.config)} if getattr(args, "config", None) else {})}
