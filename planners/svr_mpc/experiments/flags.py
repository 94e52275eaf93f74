"""The command-line flags of the state-vector-reduction experiments (Table 1, Fig. 4, the
explanation and the clock check): the rows, the run's task, protocol, timing, derivatives,
trials and outputs, and their checks as usage errors (``parse_args``). What the parsed flags
mean as settings and trials is ``mapping``'s.

The flag vocabulary is the project's (issue 91): ``--trials``/``--seed``, ``--task``,
``--preset`` (the papers' protocol), ``--rows`` (Table 1 rows by name), ``--rules`` (the
DoF-selection rules, mpc.py's; ``--methods`` its old spelling), and on every sweep ``--out``,
``--record``, ``--fresh``, ``--reuse-any``, ``--workers``, ``--threads``, ``--quick``, ``-v``.
A renamed flag keeps its old spelling as a hidden alias (``add_alias``) so that every
recorded command still runs. The flags that set one ``SVRMPCSettings`` field are derived from
it (``mapping.SETTINGS``, ``dopt.lab.flags``: the field's name, type, bounds, choices and
documentation, the default under each preset), with ``--config FILE`` (TOML or JSON settings,
or a run's summary.json) between the preset and the flags.
"""

from __future__ import annotations

import argparse
import importlib.util
import logging
from pathlib import Path

from dopt.lab.cli import (
    no_repeats,
    nonneg_int,
    output_dir,
    output_file,
    positive_int,
)
from dopt.lab.record import add_reuse_argument, check_outputs
from dopt.tasks import PUSH_TASKS
from planners.ilqr import FINITE_DIFFERENCES
from planners.svr_mpc import TABLE1_ROWS, parse_row
from planners.svr_mpc.authors_data import TASK_DIRS
from planners.svr_mpc.experiments import mapping

log = logging.getLogger(__name__)
#: task instances (seeds) per method without --trials (1 with --quick)
DEFAULT_TRIALS = 20
#: the task without --task (or a --config file's)
DEFAULT_TASK = "clutter"
#: the files a run writes under --out (besides its trials): checked before the first trial
RUN_FILES = ("summary.json", "table1.md")
#: --keep-controls: which trials keep their start state and executed controls for dopt-view's
#: exact replay (about ``CONTROLS_BYTES_PER_STEP`` bytes per agent step of JSON); "first"
#: (the default) is one episode per row, the one the plots show, and reuses a stored trial as
#: it is; "all" reruns a stored trial that lacks them
KEEP_CONTROLS = ("first", "all", "none")
#: bytes of kept controls per agent step (the Panda's seven controls as JSON, measured)
CONTROLS_BYTES_PER_STEP = 142
#: the flags of --quick, each applied where it is not given: a short episode in which SVR
#: visibly acts (|C| falls from the full set, the rows' costs differ)
QUICK = {"preset": "paper", "rows": ("sum-t10-r1", "baseline"), "trials": 1, "timeout": 300,
         "clock": "model"}


def rows_list(text: str) -> list[str]:
    """--rows: comma-separated ``parse_row`` specs, none twice (argparse ``type=``)."""
    names = [name.strip() for name in text.split(",")]
    try:
        for name in names:
            parse_row(name)
        return no_repeats(names, "row(s)")
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_rows_argument(ap: argparse.ArgumentParser, default: tuple[str, ...] | None) -> None:
    """--rows: Table 1 rows by name (``default``; None: all nine with --preset paper)."""
    ap.add_argument("--rows", type=rows_list,
                    default=None if default is None else ",".join(default),
                    help="comma-separated Table 1 rows by name (" + ", ".join(TABLE1_ROWS)
                    + ", or an optimiser's name: unoptimised runs the push plan as it is; "
                    "planners.svr_mpc.OPTIMISERS), "
                    "each optionally with derivative variants +skip<K>, +adaptive, "
                    "+boxqp, +central (e.g. sum-t10-r1+skip5; they override --fd-skip, "
                    "--keypoints, --box-qp and --fd for that row); default "
                    + ("with --preset paper: all nine" if default is None
                       else ",".join(default)))


def add_run_arguments(ap: argparse.ArgumentParser) -> None:
    """The flags of any MPC sweep (every experiment of this package but paper_reference):
    task, protocol, trials, seeds, timing, feedback, workers, output, logging."""
    ap.add_argument("--task", default=None, choices=list(PUSH_TASKS),
                    help=f"the pushing task (default {DEFAULT_TASK}, or the --config file's)")
    ap.add_argument("--preset", default=None, choices=["ours", "paper", "authors"],
                    help="paper: the authors' protocol on our problems (Eq. 2 cost without the "
                         "end-effector term, on soft with their terminal reach residual; their "
                         "set-up motion and initial push plan, 5%% control noise, virtual "
                         "clock); authors: the same protocol on the authors' own problems "
                         "(their scenes, objects, contacts and cost weights, no control cost, "
                         "no control noise; clutter needs --layouts); ours: cost with the "
                         "end-effector term, zero initial plan, real clock (default ours; "
                         "paper with --quick). --config and the flags below override it")
    ap.add_argument("--layouts", type=Path, default=None, metavar="DIR",
                    help="the authors' clutter scenes (a folder of {0..99}.csv, e.g. "
                         "../shared/external/ilqr_svr/push_mcl_layouts); seed i runs scene i")
    ap.add_argument("--authors-data", type=Path, default=None, metavar="DIR",
                    help="the authors' PaperData folder (e.g. ../shared/external/ilqr_svr/"
                         "paper_data): the summary then holds their rows' goal distances and, "
                         "with --layouts, travel, beside ours (authors_rows)")
    mapping.SETTINGS.add_to(ap)
    ap.add_argument("--fd", default=None, choices=list(FINITE_DIFFERENCES),
                    help="finite differences: forward eps 1e-3 (default) or the authors' "
                         "central eps 1e-6")
    ap.add_argument("--fd-skip", type=positive_int, default=None,
                    help="finite differences every K-th timestep, A and B linear between "
                         "(default 1: every timestep)")
    ap.add_argument("--keypoints", default=None, choices=["adaptive"],
                    help="adaptive key timesteps for the finite differences "
                         "(planners.keypoints) instead of --fd-skip")
    ap.add_argument("--box-qp", action="store_true", default=None,
                    help="control limits in iLQR's backward pass (mju_boxQP)")
    ap.add_argument("--trials", type=positive_int, default=None,
                    help=f"task instances (seeds) per method (default {DEFAULT_TRIALS}; 1 with "
                         f"--quick)")
    ap.add_argument("--seed", type=nonneg_int, default=0,
                    help="first seed; trials use seed..seed+N-1 (default %(default)s)")
    ap.add_argument("--feedback", nargs="?", const="on", default="off",
                    choices=["off", "on", "both"],
                    help="execute u + K (x - x_nom) on the measured state (authors: off); "
                         "'both' runs every trial open-loop and with feedback back to back, "
                         "so the pair sees the same machine load (rows 'METHOD +fb')")
    ap.add_argument("--workers", type=positive_int, default=1,
                    help="local worker processes (default %(default)s)")
    ap.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                    help="run the trials on Ray (local instance if no ADDRESS)")
    ap.add_argument("--threads", type=nonneg_int, default=None,
                    help="simulation threads per trial (default: all cores, 1 with workers>1)")
    add_episode_arguments(ap)
    ap.add_argument("--out", type=output_dir, default=None,
                    help="output folder (default results/<script>_<task>); finished trials "
                         "are kept under OUT/trials and a rerun resumes")
    ap.add_argument("--fresh", action="store_true",
                    help="recompute every trial (old trial files go to OUT/trials/outdated/)")
    add_reuse_argument(ap)
    ap.add_argument("--record", type=output_file, default=None, metavar="PATH",
                    help="also write the summary to PATH (docs/results/...)")
    ap.add_argument("-v", "--verbose", action="store_true",
                    help="log at INFO (each optimisation's progress), not only warnings")


class _Renamed(argparse.Action):
    """A flag's former spelling: stores into the new flag's destination and logs one
    deprecation line naming the new spelling."""

    def __init__(self, *args, new: str, **kwargs):
        super().__init__(*args, **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None):
        log.warning("%s is the old spelling of %s (it still works)", option_string, self.new)
        setattr(namespace, self.dest, values)


def add_alias(ap: argparse.ArgumentParser, old: str, new: str) -> None:
    """``old``, the former spelling of the flag ``new`` of ``ap`` (added before), accepted as
    it with a deprecation line: the same type, choices and destination, hidden from --help, so
    that every recorded command still runs."""
    action = next(a for a in ap._actions if new in a.option_strings)
    ap.add_argument(old, action=_Renamed, new=new, dest=action.dest, type=action.type,
                    choices=action.choices, metavar=action.metavar,
                    default=argparse.SUPPRESS, help=argparse.SUPPRESS)


def add_episode_arguments(ap: argparse.ArgumentParser) -> None:
    """--quick (``QUICK``) and --keep-controls (``KEEP_CONTROLS``): the flags of every MPC
    script that say how long its episodes are and whether dopt-view can replay them."""
    ap.add_argument("--quick", action="store_true",
                    help="a short episode where SVR visibly acts, in seconds: "
                         + " ".join(f"--{k} {','.join(v) if isinstance(v, tuple) else v}"
                                    for k, v in QUICK.items())
                         + " (each where not given; --rows only where the script has it)")
    ap.add_argument("--keep-controls", nargs="?", const="all", default="first",
                    choices=KEEP_CONTROLS,
                    help="which trials keep their start state and executed controls for "
                         "dopt-view's exact replay, about "
                         f"{CONTROLS_BYTES_PER_STEP} bytes per agent step (280 KB a 2000-step "
                         "trial): first (default: the first seed of each row, the episode the "
                         "plots show; a stored trial is reused as it is), all (the bare flag; "
                         "a stored trial without them is rerun), none")


def parse_args(argv, ap: argparse.ArgumentParser,
               one_feedback: bool = False) -> argparse.Namespace:
    """The flags ``argv`` (None: this process's) of an experiment's parser ``ap`` (built with
    ``add_run_arguments``) checked as usage errors; ``one_feedback``: the script runs one
    feedback setting, so --feedback both is refused."""
    args = ap.parse_args(argv)
    try:
        config = mapping.config_of(args)
    except ValueError as e:
        ap.error(f"argument --config: {e}")
    args.task = args.task or config.get("task") or DEFAULT_TASK
    if args.task not in PUSH_TASKS:
        ap.error(f"argument --config: {args.config}: unknown task {args.task!r} (choose from "
                 f"{', '.join(PUSH_TASKS)})")
    if one_feedback and args.feedback == "both":
        ap.error(f"--feedback both is for experiments/mpc.py; give on or off to {ap.prog}")
    if args.ray is not None and importlib.util.find_spec("ray") is None:
        ap.error("--ray needs the ray package (pip install 'dopt[cluster]')")
    if args.clock_ms is not None and args.clock not in (None, "model"):
        ap.error(f"--clock-ms sets the model clock's duration; it cannot go with --clock "
                 f"{args.clock}")
    if args.authors_data is not None and not (args.authors_data / TASK_DIRS[args.task]).is_dir():
        ap.error(f"--authors-data: no {TASK_DIRS[args.task]} folder under {args.authors_data} "
                 f"(the authors' PaperData)")
    quick_defaults(args)
    if args.threads is None:
        args.threads = 1 if (args.workers > 1 or args.ray) else 0
    if args.layouts is not None and (args.preset, args.task) != ("authors", "clutter"):
        ap.error(f"argument --layouts: only --preset authors on --task clutter reads the "
                 f"authors' clutter scenes, not --preset {args.preset} on --task {args.task} "
                 f"(leave it out)")
    base = settings_checked(ap, args)
    try:               # the pipeline's own checks of each row's settings, as usage errors
        for row in mapping.grid(args):
            mapping.settings_of(args, row, args.feedback == "on", base)
    except (ValueError, TypeError) as e:
        ap.error(str(e))
    if (problem := layouts_problem(args)) is not None:
        ap.error(problem)
    check_outputs(ap, args, f"{Path(ap.prog).stem}_{args.task}", files=RUN_FILES)
    return args


def settings_checked(ap: argparse.ArgumentParser, args):
    """The run's settings before its rows (``mapping.base_settings``: preset < --config <
    flags), or a usage error naming the flag (else --config) whose value they refuse."""
    try:
        return mapping.base_settings(args)
    except (ValueError, TypeError) as e:
        given = mapping.flag_overrides(args)
        flag = next((f.flag for f in mapping.SETTINGS.flags if f.path in given
                     and f.path.rsplit(".", 1)[-1] in str(e)), None)
        if flag is None and mapping.config_of(args):
            flag = "--config"
        ap.error(f"argument {flag}: {e}" if flag else str(e))


def quick_defaults(args) -> None:
    """Resolve the flags whose default depends on --quick: the preset (ours; ``QUICK``'s with
    --quick) and, with --quick, one trial and each other flag of ``QUICK`` where it is not
    given (--rows only where the script has it and neither --rows nor --rules is given;
    --clock not beside --clock-ms, which sets the model clock; none the --config file sets); an
    explicit --trials stands. Without --task (nor a --config file's), ``DEFAULT_TASK``."""
    args.task = args.task or DEFAULT_TASK
    config = {path.rsplit(".", 1)[-1]: v for path, v in mapping.config_of(args).items()}
    if args.trials is None:                  # an explicit --trials stands with --quick
        args.trials = QUICK["trials"] if args.quick else DEFAULT_TRIALS
    if not args.quick:
        args.preset = args.preset or "ours"
        return
    for name, value in QUICK.items():
        if name == "trials" or not hasattr(args, name) or getattr(args, name) is not None \
                or name in config:
            continue
        if (name == "rows" and getattr(args, "rules", None) is not None) or \
                (name == "clock" and (args.clock_ms is not None
                                      or config.get("clock_ms") is not None)):
            continue
        setattr(args, name, list(value) if isinstance(value, tuple) else value)


def layouts_problem(args) -> str | None:
    """Why the --layouts scenes of the run's seeds cannot be run (a seed without a scene, a
    file that is not a layout or whose scene makes no sense: ``check_layout``), or None;
    before any trial, so that a bad scene is not found by its trial alone."""
    if args.layouts is None:
        return None
    from dopt.tasks import N_AUTHORS_LAYOUTS
    from dopt.tasks.push.authors import check_layout

    for seed in range(args.seed, args.seed + args.trials):
        if seed >= N_AUTHORS_LAYOUTS:
            return (f"argument --trials: seed {seed} names no scene of the authors' clutter "
                    f"(scenes 0-{N_AUTHORS_LAYOUTS - 1})")
        path = args.layouts / f"{seed}.csv"
        try:
            check_layout(path)
        except FileNotFoundError:
            return f"argument --layouts: no {path} (the scene of seed {seed})"
        except ValueError as e:
            return f"argument --layouts: {e}"
    return None
