"""Generate docs/RESULTS.md and README.md's headline table from the result files.

Every number in the docs comes from a result file ``docs/results/*.json`` that an experiment
wrote itself (``--record PATH``; each file holds a "provenance": command, git commit, package
versions, date, machine). This script reads them all and writes

- ``docs/RESULTS.md``: every table behind the papers' figures, each naming its source file,
  the file's commit and the command that produced it (generated: never edit it by hand),
  and, for each Fig. 7 sweep whose trials are committed under ``docs/results/runs/`` but whose
  summary is not recorded yet, its seeds so far and what a trial cost;
- the block between ``<!-- results:begin -->`` and ``<!-- results:end -->`` in README.md:
  the headline table, paper figure / table -> script -> headline numbers (README.md is left
  alone, with a note, when it has no such markers).

Result kinds (the file's "experiment" field): "fig7" (experiments/cloth_fold.py, rope.py),
"table1" (experiments/mpc.py), "fig4" (experiments/rho_sweep.py), "svr_explain"
(experiments/svr_explain.py), "clock_model" (python -m planners.bench clock), "key_particles"
(experiments/key_particles.py). Files of other kinds are listed by name.

    python experiments/report.py            # regenerate both files
    python experiments/report.py --check    # exit 1 if either file is not what it would write

A result file that cannot be read exits 2 naming it; one whose provenance lacks the command,
the git commit or the versions of dopt, mujoco and torch is named in a note on stderr.
Standard library only (with dopt.cli, the command-line types, and planners.trial_progress, the
reader of a trial's checkpoint, both standard library themselves), so it runs without torch,
numpy or MuJoCo.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
from dataclasses import dataclass, field
from pathlib import Path

# experiments/ is on the path: it is the script's folder (pytest: pythonpath in pyproject)
from cli_args import EPILOG, existing_dir, file_problem, guarded

from planners.trial_progress import iterations_done

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"
REGENERATE = "python experiments/report.py"

#: method labels of the key-particle experiments (planners.pick_place.LABELS; copied here so
#: that this script needs no torch), in the order of the paper's figures
FIG7_LABELS = {"simple": "CEM(Simple)", "original": "CEM(Original)",
               "random": "CEM(Random)", "scripted": "Scripted"}
#: Fig. 7 panel of each (task, goal) of the key-particle paper
FIG7_PANELS = {("rope", "straighten"): "(a) rope straightening",
               ("rope", "fold"): "(b) rope folding",
               ("cloth", "diagonal"): "(c) cloth diagonal fold",
               ("cloth", "side"): "(d) cloth side fold",
               ("cloth", "reflective"): "(e) cloth reflective fold",
               ("cloth", "underneath"): "(f) cloth underneath fold"}
#: what every result file's "provenance" holds (``dopt.provenance.provenance()``)
PROVENANCE_FIELDS = ("command", "git_commit", "versions")
PROVENANCE_VERSIONS = ("dopt", "mujoco", "torch")
KP = "key particles"
SVR = "state-vector reduction"


#: result files of the benchmarks (field "bench") -> the section that renders them
BENCH_KINDS = {"cloth": "physics", "rope": "physics",          # python -m planners.bench
               "key-particles-compare": "kp_compare",          # python -m deformables.bench
               "key-particles-paper-scale": "kp_paper_scale"}


@dataclass(frozen=True)
class Entry:
    """One row of the README's headline table: a paper's figure or table, the command that
    reproduces it, and which result files hold its numbers (``match(result)``)."""

    paper: str
    item: str
    command: str
    kind: str
    where: dict = field(default_factory=dict)

    def match(self, r: Result) -> bool:
        """Its kind, and each ``where`` field equal to the value (a callable: true of it)."""
        return r.kind == self.kind and all(v(r.data.get(k)) if callable(v) else
                                           r.data.get(k) == v for k, v in self.where.items())


def has_variant(tag: str):
    """A ``where`` test of a Table 1 file's "derivatives_effect": a row with ``tag``
    (``+skip``, ``+boxqp``, ``+central``)."""
    return lambda effect: any(tag in row for row in effect or {})


#: the paper's Table 1 trials per task
TABLE1_TRIALS = {"clutter": 100, "soft": 20, "soft_rigid": 20}
#: trials per task of the Table 1 runs with the end-effector cost term
TABLE1_EE_TRIALS = {"clutter": 20, "soft": 10, "soft_rigid": 10}

#: what the papers report and the scripts that reproduce it (the README's headline rows)
CATALOGUE = (
    [Entry(KP, "Fig. 4, Sec. IV-C.1: key particles of each goal",
           "python experiments/key_particles.py --task all", "key_particles")]
    + [Entry(KP, f"Fig. 7 {panel}",
             f"python experiments/{'cloth_fold' if task == 'cloth' else 'rope'}.py "
             f"--goal {goal}", "fig7", {"task": task, "goal": goal})
       for (task, goal), panel in FIG7_PANELS.items()]
    + [Entry(KP, "Sec. IV-D: a Panda executes the diagonal and side plans",
             "python experiments/panda_execute.py --seeds 3 --out docs/results/runs/panda "
             "--record docs/results/panda-execute.json", "panda_execute")]
    + [Entry(SVR, f"Table 1: {task}", f"python experiments/mpc.py --task {task} --preset paper "
             f"--trials {n} --workers 2 --no-render --out docs/results/runs/table1-{task} "
             f"--record docs/results/table1-{task}.json", "table1",
             {"task": task, "derivatives_effect": None, "cost": lambda c: c != "ee"})
       for task, n in TABLE1_TRIALS.items()]
    + [Entry(SVR, f"Table 1 with the end-effector term (ours), {task}",
             f"python experiments/mpc.py --task {task} --preset paper --cost ee --trials {n} "
             f"--workers 2 --no-render --out docs/results/runs/table1-{task}-ee "
             f"--record docs/results/table1-{task}-ee.json", "table1",
             {"task": task, "derivatives_effect": None, "cost": "ee"})
       for task, n in TABLE1_EE_TRIALS.items()]
    + [Entry(SVR, f"Beyond the paper: FD at every K-th timestep on sum-t10-r1, {task}",
             f"python experiments/mpc.py --task {task} --preset paper --rows "
             f"baseline,sum-t10-r1,sum-t10-r1+skip5,sum-t10-r1+skip10 --trials {n} --workers 2 "
             f"--no-render --out docs/results/runs/keypoints-{task} "
             f"--record docs/results/keypoints-{task}.json", "table1",
             {"task": task, "derivatives_effect": has_variant("+skip")})
       for task, n in TABLE1_TRIALS.items()]
    + [Entry(SVR, f"Beyond the paper: control limits in iLQR's backward pass (box QP), {task}",
             f"python experiments/mpc.py --task {task} --preset paper --rows "
             f"baseline,sum-t10-r1,sum-t10-r1+boxqp --trials 10 --workers 2 --no-render "
             f"--out docs/results/runs/boxqp-{task} --record docs/results/boxqp-{task}.json",
             "table1", {"task": task, "derivatives_effect": has_variant("+boxqp")})
       for task in TABLE1_TRIALS]
    + [Entry(SVR, "Finite differences: the authors' central (eps 1e-6) against our forward "
                  "(eps 1e-3), clutter",
             "python experiments/mpc.py --task clutter --preset paper --rows "
             "baseline,sum-t10-r1,sum-t10-r1+central --trials 20 --workers 2 --no-render "
             "--out docs/results/runs/fd-central-clutter "
             "--record docs/results/fd-central-clutter.json", "table1",
             {"task": "clutter", "derivatives_effect": has_variant("+central")})]
    + [Entry(SVR, "Table 1's virtual clock against the real clock",
             "python experiments/clock_check.py --task clutter --preset paper --rows "
             "baseline,rand-t5,sum-t10-r1 --trials 10 --out docs/results/runs/clock-check-clutter "
             "--record docs/results/clock-check-clutter.json", "clock_check",
             {"nominal_threads": 2.0})]
    + [Entry(SVR, "The virtual clock at 1.3 nominal threads (the first check's speed-up), "
                  "on a second machine",
             "python experiments/clock_check.py --task clutter --preset paper --rows "
             "baseline,rand-t5,sum-t10-r1 --seed 10 --trials 10 --nominal-threads 1.3 "
             "--out docs/results/runs/clock-check-clutter "
             "--record docs/results/clock-check-clutter-1.3.json", "clock_check",
             {"nominal_threads": 1.3})]
    + [Entry(SVR, "Fig. 4: rho, theta sweep",
             "python experiments/rho_sweep.py --task clutter --preset paper --rhos "
             "0,0.1,0.5,1,5,10,20,50,100,500,1e6 --thetas 0,5,10 --trials 20 --workers 2 "
             "--paper-reference docs/results/paper-svr.json --out docs/results/runs/fig4-clutter "
             "--record docs/results/fig4-clutter.json", "fig4")])


# ------------------------------------------------------------------------------ loading
@dataclass(frozen=True)
class Result:
    """A result file: its path, its "experiment" kind and its contents."""

    path: Path
    data: dict

    @property
    def kind(self) -> str:
        if "experiment" not in self.data and self.data.get("bench") in BENCH_KINDS:
            return BENCH_KINDS[self.data["bench"]]
        return str(self.data.get("experiment", "(none)"))

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def provenance(self) -> dict:
        p = self.data.get("provenance")
        return p if isinstance(p, dict) else {}

    @property
    def command(self) -> str:
        return str(self.provenance.get("command") or "(no provenance: command unknown)")

    @property
    def commit(self) -> str:
        """The short commit ("-dirty" kept: the run had uncommitted changes)."""
        c = self.provenance.get("git_commit")
        if not c:
            return "unknown commit"
        head, dirty = (c[:-6], "-dirty") if c.endswith("-dirty") else (c, "")
        return head[:8] + dirty

    @property
    def date(self) -> str:
        return str(self.provenance.get("date") or "unknown date")

    @property
    def quick(self) -> bool:
        """A smoke-sized run (--quick): its numbers are not the paper's settings."""
        return bool(self.data.get("quick")) or "--quick" in self.command.split()


def provenance_gaps(r: Result) -> list[str]:
    """What the result's provenance lacks of the command, the git commit and the versions of
    dopt, mujoco and torch (empty when complete)."""
    p = r.provenance
    gaps = [k for k in PROVENANCE_FIELDS if not p.get(k)]
    versions = p.get("versions") if isinstance(p.get("versions"), dict) else {}
    gaps += [f"versions.{k}" for k in PROVENANCE_VERSIONS if not versions.get(k)]
    return gaps


class ReportError(Exception):
    """A result file that cannot be read or rendered."""


def load_results(results_dir: Path) -> list[Result]:
    """Every ``*.json`` under ``results_dir`` (not recursive), sorted by name; a missing folder
    is no results."""
    out = []
    for path in sorted(Path(results_dir).glob("*.json")):
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError) as e:
            raise ReportError(f"{path}: not a readable JSON file ({e})") from e
        if not isinstance(data, dict):
            raise ReportError(f"{path}: expected a JSON object, got {type(data).__name__}")
        out.append(Result(path, data))
    return out


# ---------------------------------------------------------------------------- formatting
def _finite(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def num(x, digits: int = 2, scale: float = 1.0) -> str:
    """x * scale with ``digits`` decimals; "n/a" for None, NaN or a non-number."""
    return f"{x * scale:.{digits}f}" if _finite(x) else "n/a"


def sci(x) -> str:
    """x in scientific notation with two significant digits; "-" for None."""
    return "-" if x is None else (f"{x:.1e}" if _finite(x) else "n/a")


def clip(text: str, n: int) -> str:
    """``text`` cut to its first ``n`` characters, "..." marking a cut."""
    return text[:n] + ("..." if len(text) > n else "")


def mm(x, digits: int = 1) -> str:
    """Metres as millimetres, one decimal."""
    return num(x, digits, 1e3)


def pm(mean: str, ci: str) -> str:
    """"mean ± ci", or the mean alone when there is no interval."""
    return mean if ci == "n/a" or mean == "n/a" else f"{mean} ± {ci}"


def span(interval) -> str:
    """An interval [lo, hi] as "lo-hi" (empty for none)."""
    return "-".join(num(x) for x in interval or [])


def cell(text) -> str:
    """Text safe inside a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def table(header: list[str], rows: list[list]) -> list[str]:
    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]


def link(r: Result, page: Path) -> str:
    """A Markdown link to the result file, relative to the page that shows it."""
    rel = Path(os.path.relpath(r.path, Path(page).parent)).as_posix()
    return f"[{r.name}]({rel})"


def source(r: Result, page: Path) -> str:
    """'file (commit)' of a result, as the tables cite it."""
    return f"{link(r, page)} ({r.commit})"


def source_lines(results: list[Result], page: Path) -> list[str]:
    """The source files of a table, each with its commit, date and command line."""
    lines = []
    for r in results:
        lines.append(f"Source: {link(r, page)}, commit `{r.commit}`, {r.date}"
                     + (", **quick (smoke-sized) run**" if r.quick else "") + ":  ")
        lines.append(f"`{r.command}`")
    return lines


def failed_lines(r: Result) -> list[str]:
    failed = r.data.get("failed") or {}
    if not failed:
        return []
    return ["", f"**{len(failed)} failed trial(s)** (not in the numbers above):", ""] + [
        f"- `{k}`: {cell(v)}" for k, v in sorted(failed.items())]


def section(title: str, intro: str | None, results: list[Result], page: Path, body,
            key=lambda r: (str(r.data.get("task")), r.name)) -> list[str]:
    """A page section: "## title", its intro, then per result file (in ``key`` order) the
    lines ``body(r)`` gives (its heading, settings and tables), its source and failed trials."""
    lines = [f"## {title}", ""] + ([intro, ""] if intro else [])
    for r in sorted(results, key=key):
        lines += [*body(r), "", *source_lines([r], page), *failed_lines(r), ""]
    return lines[:-1]


def _label(method: str) -> str:
    return FIG7_LABELS.get(method, method)


def _in_label_order(methods) -> list[str]:
    """The distinct ``methods`` in the figures' order (``FIG7_LABELS``), unknown ones after,
    sorted."""
    seen = set(methods)
    known = [m for m in FIG7_LABELS if m in seen]
    return known + sorted(seen - set(known))


def _methods_in_order(results: list[Result]) -> list[str]:
    return _in_label_order(m for r in results for m in r.data["methods"])


def _panel_of(task, goal) -> str:
    return FIG7_PANELS.get((task, goal), f"{task} {goal}")


def _panel_rank(task, goal) -> int:
    """The place of (task, goal) in the paper's Fig. 7 (``FIG7_PANELS``); unknown ones last."""
    order = list(FIG7_PANELS)
    return order.index((task, goal)) if (task, goal) in order else len(order)


def _panel(r: Result) -> str:
    return _panel_of(r.data.get("task"), r.data.get("goal"))


# --------------------------------------------------------------------------- fig7 (KP)
def fig7_cell(e: dict | None) -> str:
    if not e:
        return "-"
    return pm(mm(e.get("final_cost_mean")), mm(e.get("final_cost_ci95")))


def fig7_section(results: list[Result], page: Path) -> list[str]:
    results = sorted(results, key=lambda r: (_panel_rank(r.data.get("task"),
                                                         r.data.get("goal")), r.name))
    methods = _methods_in_order(results)
    lines = ["## Key particles, Fig. 7: final cost of pick-and-place", "",
             "Mean particle distance to the goal after the whole plan (Eq. 2), in mm: mean ± "
             "95 % CI half-width over the seeds (no interval with one seed). Candidates: the "
             "particles each planner may pick (last stage).", ""]
    header = ["Fig. 7", *[_label(m) for m in methods], "seeds", "candidates", "source"]
    # seeds and candidates: one per method present, in the columns' order
    rows = []
    for r in results:
        ms = r.data["methods"]
        seeds = [str(ms[m].get("n", "?")) for m in methods if m in ms]
        rows.append([f"{_panel(r)} ({fig7_setup(r)})" + (" (quick)" if r.quick else ""),
                     *[fig7_cell(ms.get(m)) for m in methods],
                     seeds[0] if len(set(seeds)) == 1 else " / ".join(seeds),
                     " / ".join(str(ms[m].get("n_candidates", "?")) for m in methods
                                if m in ms),
                     source(r, page)])
    lines += table(header, rows)
    claims = fig7_claims_lines(results, page)
    if claims:
        lines += ["", "The paper's claims on these files (Simple's 95 % interval wholly below "
                      "the other's: separate; difference: the other's mean minus Simple's ± "
                      "its Welch 95 % interval, which excludes zero where the half-width is "
                      "smaller; the gaps likewise):", "", *claims]
    for r in results:
        lines += ["", *fig7_detail(r, page, results)]
    return lines


def _fig7_physics(d: dict) -> str:
    """The preset name and, where the summary records it, what it meant (a preset's fields
    change between commits: a summary without them names its commit)."""
    name = (d.get("settings") or {}).get("physics", "default")
    scene = (d.get("physics") or {}).get("scene")
    if not scene:
        commit = str((d.get("provenance") or {}).get("git_commit") or "?")[:8]
        return f"preset {name} as defined at {commit}"
    what = [f"dt {scene['timestep'] * 1000:g} ms"]
    if "young" in scene:
        what.insert(0, f"{scene['young']:.2g} Pa")
    if "triangulation" in scene:
        what.append(f"{scene['triangulation']} triangles")
    energy = ((d.get("physics") or {}).get("stability") or {}).get("max_energy_gain")
    what.append(f"energy bound {energy:g} J/kg" if energy is not None
                else "no energy bound in the verdict")
    return f"preset {name} ({', '.join(what)})"


def fig7_detail(r: Result, page: Path, results: list[Result]) -> list[str]:
    d = r.data
    s = d.get("settings") or {}
    cem = s.get("cem") or {}
    lines = [f"### Fig. 7 {_panel(r)}, {fig7_setup(r)}: `{r.name}`", ""]
    if s:
        lines += [f"Settings: {s.get('task')} {s.get('goal')}, n {s.get('n')}, bound "
                  f"{s.get('bound')} m, self-collision {'on' if s.get('selfcollide') else 'off'}, "
                  f"physics {_fig7_physics(d)}"
                  + "".join(f", {label} {s[k]}" for k, label in (
                      ("planning_physics", "CEM plans on preset"),
                      ("picker_speed", "picker speed (m/s)"),
                      ("max_stretch", "stretch limit")) if s.get(k) is not None)
                  + f"; CEM population {cem.get('population')}, elites {cem.get('elites')}, "
                  f"{cem.get('iterations')} iterations per stage, horizon {cem.get('horizon')}."
                  + (f" Trials' wall time {num(d['trials_wall_s'], 0)} s in total."
                     if "trials_wall_s" in d else
                     f" Wall time {num(d.get('wall_s'), 0)} s." if "wall_s" in d else ""), ""]
    rope_ratio = any("end_to_end_ratio_mean" in e for e in d["methods"].values())
    # the paper's rope metrics (m in the file): name in the summary -> column
    extra = {k: c for k, c in (("straighten_error", "|end-to-end - length| (mm)"),
                               ("matching_distance", "matching distance (mm)"))
             if any(f"{k}_mean" in e for e in d["methods"].values())}
    infeasible = any(e.get("n_infeasible_rollouts") for e in d["methods"].values())
    last = any(e.get("last_improvements") for e in d["methods"].values())
    header = ["method", "final cost (mm)", "per seed (mm)", "seeds", "candidates",
              "s / CEM iteration", "unstable trials", "unstable rollouts"] + (
        [f"last improvement (iteration of {cem.get('iterations')})"] if last else []) + (
        ["infeasible rollouts (stretch)"] if infeasible else []) + (
        ["end-to-end / length"] if rope_ratio else []) + list(extra.values())
    rows = []
    for m, e in d["methods"].items():
        row = [_label(m), fig7_cell(e),
               ", ".join(mm(c) for c in e.get("final_costs", [])),
               ", ".join(str(x) for x in e.get("seeds", [])) + f" (n = {e.get('n')})",
               str(e.get("n_candidates", "?")), num(e.get("s_per_iteration"), 2),
               _unstable_trials(e),
               f"{e['n_unstable_rollouts']} / {e['n_rollouts']}" if "n_rollouts" in e
               else "not judged"]
        if last:
            row.append(_last_improvement(e))
        if infeasible:
            row.append(f"{e.get('n_infeasible_rollouts', 0)} / {e.get('n_rollouts', '?')}")
        if rope_ratio:
            row.append(pm(num(e.get("end_to_end_ratio_mean")),
                          num(e.get("end_to_end_ratio_ci95"))))
        for k in extra:
            mean, ci = e.get(f"{k}_mean"), e.get(f"{k}_ci95")
            row.append(pm(num(None if mean is None else 1e3 * mean, 1),
                          num(None if ci is None else 1e3 * ci, 1)))
        rows.append(row)
    lines += table(header, rows)
    lines += fig7_against_protocol(r, results, page)
    return lines + [""] + source_lines([r], page) + failed_lines(r)


def _last_improvement(e: dict) -> str:
    """The CEM iteration after which the last stage's best cost last fell: its range and
    median over the seeds ("-" for the scripted policy)."""
    its = [i for i in e.get("last_improvements") or [] if i is not None]
    if not its:
        return "-"
    return f"{min(its)}-{max(its)} (median {statistics.median(its):g})"


def fig7_against_protocol(r: Result, results: list[Result], page: Path) -> list[str]:
    """For a file with departures from its protocol: each method's score on the panel's paper
    metric (``PAPER_METRICS``; else the mean particle distance) against the file of the same
    panel and protocol without departures, seed by seed (lower on k of the n seeds both ran);
    empty otherwise."""
    if not fig7_departures(r):
        return []
    def key(f: Result) -> tuple:
        return f.data.get("task"), f.data.get("goal"), f.data.get("protocol", "ours")

    base = [b for b in results if b.kind == "fig7" and not b.quick and not fig7_departures(b)
            and key(b) == key(r)]
    if not base:
        return []
    b = base[0]
    out = []
    for m, e in r.data["methods"].items():
        other = b.data["methods"].get(m)
        if not other:
            continue
        # the panel's paper metric where both files hold it per seed
        metric = paper_metric(r, "s", e, other)
        mine = dict(zip(e.get("seeds", []), e.get(f"{metric}s", []), strict=False))
        theirs = dict(zip(other.get("seeds", []), other.get(f"{metric}s", []), strict=False))
        shared = sorted(set(mine) & set(theirs))
        if shared:
            lower = sum(mine[k] < theirs[k] for k in shared)
            secs = ((e.get("s_per_iteration"), other.get("s_per_iteration"))
                    if _finite(e.get("s_per_iteration"))
                    and _finite(other.get("s_per_iteration")) else None)
            out.append(f"{_label(m)} at {fig7_departures(r)}: {METRIC_NAMES[metric]} lower "
                       f"than under preset {r.data.get('protocol', 'ours')} as it stands "
                       f"({link(b, page)}) on {lower} of the {len(shared)} seeds both "
                       f"ran" + (f"; {num(secs[0], 1)} s per CEM iteration against "
                                 f"{num(secs[1], 1)} ({num(secs[0] / secs[1])} times)"
                                 if secs else "") + ".")
    return ["", *out] if out else []


def _unstable_trials(e: dict) -> str:
    """Unstable executed plans of a Fig. 7 method (left out of the mean), or "not judged" for
    a file written before the stability verdict existed."""
    if "n_unstable_trials" not in e:
        return "not judged"
    n = e["n_unstable_trials"]
    return f"{n} (seeds {', '.join(map(str, e['unstable_seeds']))})" if n else "0"


# ------------------------------------------------------------------------ physics presets
def physics_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        goals = list((d["rows"][0].get("scripted") or {}).keys()) if d["rows"] else []
        header = ["setting", "n", "ms / step", "steps / action", "unstable / 1000 actions",
                  "why", "strain p50 / p90 / max", "energy gain max (J/kg)",
                  *[f"scripted {g}" for g in goals]]
        rows = []
        for row in d["rows"]:
            sc = row.get("scripted") or {}
            setting = f"`{row['setting']}`"
            if row["setting"].startswith("preset:") and row.get("fields") is not None:
                setting += " (" + (", ".join(f"{k} {v:g}" if isinstance(v, float) else
                                             f"{k} {v}" for k, v in row["fields"].items())
                                   or "the config's defaults") + ")"
            if "picker_speed" in row:
                setting += f", picker {row['picker_speed']:g} m/s"
            rows.append([setting, str(row["n"]), num(row["cpu_ms_per_step"], 2),
                         str(row["steps_per_action"]),
                         num(row["unstable_per_1000_actions"], 0),
                         ", ".join(f"{k} {v}" for k, v in sorted(row["reasons"].items()))
                         or "-",
                         " / ".join(num(row[k], 2) for k in ("strain_p50", "strain_p90",
                                                              "strain_max")),
                         num(row["energy_gain_max"], 3) if "energy_gain_max" in row else "-",
                         *[mm(sc[g]["error_mm"] / 1e3) + (" !" if sc[g]["unstable"] else "")
                           for g in goals]])
        sizes = " and ".join(f"{n} x {n}" if d.get("bench") == "cloth" else str(n)
                             for n in d.get("sizes", []))
        seed = f", seed {d['seed']}" if "seed" in d else ""
        return [f"### {d.get('bench')} ({sizes}): {d.get('actions_per_setting')} random "
                f"actions per setting{seed}", "", *table(header, rows)]

    return section("Physics presets: `python -m planners.bench cloth|rope`",
                   "Per setting and size: CPU ms per simulated step (wall x threads / steps of "
                   "the random-action batch), steps per pick-and-place action, rollouts the "
                   "stability verdict flags per 1000 random actions (uniform displacements "
                   "within the picker bound, random particles, half from the flat start and "
                   "half after a fold) and why, the edge strain those actions reach (median / "
                   "90th percentile / max), the largest energy gain while nothing held the object "
                   "(the verdict's energy bound; `-` where the file does not record it), and the "
                   "scripted policy's error on each goal (mm; "
                   "`!` marks an executed plan the verdict flagged). Presets: the `preset:` "
                   "rows.", results, page, body,
                   key=lambda r: (r.data.get("bench", ""), r.data.get("sizes", [])))



def fig7_headline(r: Result) -> str:
    ms = r.data["methods"]
    parts = []
    for i, m in enumerate(_methods_in_order([r])):
        e = ms[m]
        text = (f"{_label(m)} {fig7_cell(e)} mm" if i == 0
                else f"{_label(m).replace('CEM(', '').rstrip(')')} {mm(e.get('final_cost_mean'))}")
        if "end_to_end_ratio_mean" in e and i == 0:
            text += f", end-to-end {num(e['end_to_end_ratio_mean'])} L"
        parts.append(text)
    seeds = max((e.get("n") or 0) for e in ms.values()) if ms else 0
    return ", ".join(parts) + f" ({seeds} seed{'s' if seeds != 1 else ''})"


#: the paper's order of the cloth folds by difficulty (Sec. IV-C.2)
CLOTH_DIFFICULTY = ("diagonal", "side", "reflective", "underneath")


#: the paper's score of each Fig. 7 panel (Sec. IV-B), where it is not the mean particle
#: distance ("final_cost"): rope straightening |end-to-end distance - length|, rope folding
#: the bipartite-matching distance; and how a claim line names it
PAPER_METRICS = {("rope", "straighten"): "straighten_error",
                 ("rope", "fold"): "matching_distance"}
METRIC_NAMES = {"final_cost": "mean particle distance",
                "straighten_error": "|end-to-end - length|",
                "matching_distance": "matching distance"}


def paper_metric(r: Result, field: str, *entries: dict | None) -> str:
    """The paper's metric of a Fig. 7 file's panel (``PAPER_METRICS``) where every method entry
    to compare holds it as ``<metric><field>`` ("_mean", or "s": per seed); otherwise the
    mean particle distance."""
    metric = PAPER_METRICS.get((r.data.get("task"), r.data.get("goal")), "final_cost")
    return metric if all(e and f"{metric}{field}" in e for e in entries) else "final_cost"


def comparison(a: dict | None, b: dict | None, metric: str = "final_cost") -> str:
    """Whether method a's ``metric`` (its ``<metric>_mean`` and ``_ci95``) is below b's:
    "yes (separate)" when a's 95 % interval lies wholly below b's, "yes (overlap)",
    "no (overlap)", "no (separate)"; "n/a" without both means."""
    if not a or not b or not (_finite(a.get(f"{metric}_mean"))
                              and _finite(b.get(f"{metric}_mean"))):
        return "n/a"
    ma, mb = a[f"{metric}_mean"], b[f"{metric}_mean"]
    ca, cb = a.get(f"{metric}_ci95"), b.get(f"{metric}_ci95")
    separate = _finite(ca) and _finite(cb) and abs(ma - mb) > ca + cb
    return f"{'yes' if ma < mb else 'no'} ({'separate' if separate else 'overlap'})"


def difference(a: dict | None, b: dict | None, metric: str = "final_cost") -> float | None:
    """The half-width of the Welch 95 % interval of b's ``metric`` mean minus a's, as b's
    entry records it against CEM(Simple) (``<metric>_minus_simple_ci95``, ``a`` being Simple's
    entry); None where the file has none. Around the means' difference it says whether the
    two methods differ where their own intervals (``comparison``) overlap."""
    half = (b or {}).get(f"{metric}_minus_simple_ci95") if a else None
    return half if _finite(half) else None


def _claim(a: dict | None, b: dict | None, metric: str) -> str:
    """``comparison`` with the difference b - a and its Welch interval, where recorded:
    "yes (overlap; difference 12.9 ± 11.7 mm)"."""
    c = comparison(a, b, metric)
    half = difference(a, b, metric) if c != "n/a" else None
    if half is None:
        return c
    diff = b[f"{metric}_mean"] - a[f"{metric}_mean"]
    return f"{c[:-1]}; difference {mm(diff)} ± {mm(half)} mm)"


def fig7_departures(r: Result) -> str:
    """The settings a Fig. 7 file changed from its protocol's preset (its "departures",
    ``PickPlaceSettings.departures``), e.g. "population 200, elites 20"; "" when none (or a
    file from before the field was recorded: its command names any flags)."""
    return ", ".join(f"{k.rsplit('.', 1)[-1].replace('_', ' ')} {v}"
                     for k, v in (r.data.get("departures") or {}).items())


def _departs(r: Result) -> bool:
    """A Fig. 7 file whose flags changed its protocol's settings."""
    return r.kind == "fig7" and bool(fig7_departures(r))


def fig7_setup(r: Result) -> str:
    """The protocol a Fig. 7 file ran ("preset paper", "preset ours") and its
    departures: files of one setup are one experiment, judged together."""
    dep = fig7_departures(r)
    return f"preset {r.data.get('protocol', 'ours')}" + (f", {dep}" if dep else "")


def fig7_claims(results: list[Result]) -> dict:
    """The paper's Fig. 7 claims checked on the recorded files (not quick), per setup
    (``fig7_setup``: protocol and departures; one panel may be run under several).

    "panels": {"<panel>, <setup>": whether Simple < Original and Simple < Random
    (``comparison``) on the panel's paper metric (``PAPER_METRICS``; a file without it: the
    mean particle distance), the gap Original - Simple of the mean particle distance (m), the
    seeds and the size}; "cloth": per setup with cloth folds, the gaps in the paper's order of
    difficulty, each fold's cloth size and whether the gap grows (None: not judged; a gap at
    another cloth size, another N_O, is another experiment: judged only when all four folds
    share one size)."""
    panels, gaps = {}, {}
    for r in sorted(results, key=lambda r: _panel_rank(r.data.get("task"), r.data.get("goal"))):
        if r.kind != "fig7" or r.quick:
            continue
        ms = r.data["methods"]
        n = (r.data.get("settings") or {}).get("n")
        s, o = ms.get("simple"), ms.get("original")
        gap = (o["final_cost_mean"] - s["final_cost_mean"]
               if s and o and _finite(s.get("final_cost_mean"))
               and _finite(o.get("final_cost_mean")) else None)
        metric = paper_metric(r, "_mean", s)
        setup = fig7_setup(r)
        panels[f"{_panel(r)}, {setup}"] = {
            "file": r, "metric": metric, "setup": setup,
            "simple_vs_original": _claim(s, o, metric),
            "simple_vs_random": _claim(s, ms.get("random"), metric),
            "gap": gap, "seeds": max((e.get("n") or 0) for e in ms.values()),
            "size": (f"{n} x {n} particles" if r.data.get("task") == "cloth"
                     else f"{n} particles") if n else "size ?"}
        if r.data.get("task") == "cloth" and r.data.get("goal") in CLOTH_DIFFICULTY:
            gaps.setdefault(setup, []).append(
                (CLOTH_DIFFICULTY.index(r.data["goal"]), r.data["goal"], gap, n,
                 difference(s, o) if gap is not None else None, r.data.get("trials_wall_s")))
    cloth = []
    for setup, folds in gaps.items():
        folds.sort()
        values = [g for _, _, g, _, _, _ in folds]
        sizes = {n for _, _, _, n, _, _ in folds}
        walls = [w for *_, w in folds]
        grows = (None if len(values) < len(CLOTH_DIFFICULTY) or len(sizes) != 1
                 or any(g is None for g in values)
                 else all(b > a for a, b in zip(values, values[1:], strict=False)))
        halves = [h for *_, h, _ in folds]
        # pairs of folds whose gaps' 95 % intervals are separate; None where a gap or its
        # interval is unknown
        separate = (None if any(g is None or h is None
                                for g, h in zip(values, halves, strict=True))
                    else [(folds[i][1], folds[j][1]) for i in range(len(folds))
                          for j in range(i + 1, len(folds))
                          if abs(values[j] - values[i]) > halves[i] + halves[j]])
        cloth.append({"setup": setup, "gaps": [(goal, g) for _, goal, g, _, _, _ in folds],
                      "gap_ci95": [(goal, h) for _, goal, _, _, h, _ in folds],
                      "separate": separate,
                      "sizes": [(goal, n) for _, goal, _, n, _, _ in folds], "grows": grows,
                      # the folds' trials in seconds of one core, where every file says
                      "trials_wall_s": (sum(walls) if all(_finite(w) for w in walls)
                                        else None)})
    return {"panels": panels, "cloth": cloth}


def _and(words: list[str]) -> str:
    """"a", "a and b", "a, b and c"."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def fig7_claims_lines(results: list[Result], page: Path) -> list[str]:
    """The claims as a bulleted list (empty without Fig. 7 files)."""
    c = fig7_claims(results)
    if not c["panels"]:
        return []
    # a file without Original or Random (a run of Simple alone) claims nothing here
    lines = [f"- {panel} ({p['size']}, {p['seeds']} seeds, {METRIC_NAMES[p['metric']]}): "
             f"Simple < Original "
             f"{p['simple_vs_original']}, Simple < Random {p['simple_vs_random']}; "
             f"{source(p['file'], page)}" for panel, p in c["panels"].items()
             if {p["simple_vs_original"], p["simple_vs_random"]} != {"n/a"}]
    for g in c["cloth"]:
        if all(gap is None for _, gap in g["gaps"]):   # no Original in this setup
            continue
        size, half = dict(g["sizes"]), dict(g["gap_ci95"])
        mixed = len(set(size.values())) > 1
        gaps = ", ".join(f"{goal} {mm(gap)}"
                         + (f" ± {mm(half[goal])}" if half[goal] is not None else "")
                         + (f" at {size[goal]} x {size[goal]}" if mixed else "")
                         for goal, gap in g["gaps"])
        missing = [goal for goal in CLOTH_DIFFICULTY if goal not in size]
        if mixed:
            verdict = "whether it grows cannot be judged until all folds are run at one size"
        elif missing:
            verdict = (f"whether it grows cannot be judged until {_and(missing)} "
                       f"{'is' if len(missing) == 1 else 'are'} run")
        else:
            verdict = {True: "it grows with difficulty",
                       False: "it does not grow with difficulty",
                       None: "whether it grows cannot be judged"}[g["grows"]]
            if g["separate"] == []:
                verdict += ("; no two folds' gap intervals are separate, so these seeds "
                            "cannot order the folds by their gap")
            elif g["separate"]:
                verdict += ("; gap intervals separate only for " + _and(
                    [f"{a} vs {b}" for a, b in g["separate"]]))
        lines.append(f"- {g['setup']}: the gap Original - Simple (mm) over the cloth folds in "
                     f"the paper's order of difficulty: {gaps}; {verdict} (the paper: it "
                     f"grows).")
        if not missing and g["trials_wall_s"] is not None:
            lines.append(f"- {g['setup']}: the four cloth folds' trials took "
                         f"{g['trials_wall_s'] / 3600:.1f} h of one core.")
    return lines


# ------------------------------------------------------------------------- table1 (SVR)
MPC_HEADER = ["MPC cost / baseline (mean ± CI90)", "median (all)", "opt. time (ms)", "DoFs",
              "lag (steps)", "success", "goal distance (m, median)", "outliers", "unstable",
              "trials"]


def mpc_cells(m: dict) -> list[str]:
    return [pm(num(m.get("mpc_cost_normalised_mean")), num(m.get("mpc_cost_normalised_ci90"))),
            num(m.get("mpc_cost_normalised_median")), num(m.get("opt_ms_mean"), 0),
            num(m.get("n_dofs_mean", m.get("dofs_mean")), 1), num(m.get("lag_steps_mean"), 1),
            num(m.get("success_rate")), num(m.get("goal_distance_end_median"), 3),
            str(m.get("outliers", "?")), str(m.get("n_unstable_trials", "-")),
            str(m.get("n_trials", m.get("trials", "?")))]


def table1_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        lines = [f"### Table 1, {d.get('task')}: `{r.name}`" + (" (quick)" if r.quick else ""),
                 "", protocol_line(d), ""]
        if "row_settings" not in d:
            theta = d.get("theta")
            theta_text = (", ".join(f"{k} {v}" for k, v in theta.items())
                          if isinstance(theta, dict) else str(theta))
            lines[-2] += f" rho {d.get('rho')}; theta: {theta_text}; slowdown {d.get('slowdown')}."
        lines += table(["method", *MPC_HEADER],
                       [[name, *mpc_cells(m)] for name, m in d["methods"].items()])
        pairs = [(m.get("lag_steps_mean"), m.get("mpc_cost_normalised_mean"))
                 for m in d["methods"].values()]
        if len(pairs) >= 5 and all(None not in p for p in pairs):
            tau = kendall_tau_b([p[0] for p in pairs], [p[1] for p in pairs])
            lines += ["", f"Kendall tau of the rows' mean lag and mean normalised cost: "
                          f"{num(tau)} (1: the less a row lags, the less it costs)."]
        fb = d.get("feedback_effect")
        if fb:
            lines += ["", "Feedback vs open loop, paired by seed (MPC cost ratio: geometric mean "
                      "and 90 % CI; pairs where feedback cost less; successes open loop -> "
                      "feedback):", ""]
            lines += table(["method", "cost ratio", "CI90", "feedback better", "successes"],
                           [[name, num(f.get("ratio_geomean")),
                             span(f.get("ratio_ci90")),
                             f"{f.get('better')}/{f.get('pairs')}",
                             f"{f.get('success_open_loop')} -> {f.get('success_feedback')}"]
                            for name, f in fb.items()])
        variants = d.get("derivatives_effect")
        if variants:
            lines += ["", "Derivative variants against the same row with finite differences at "
                      "every timestep, paired by seed (MPC cost ratio: geometric mean and 90 % "
                      "CI; pairs where the variant cost less; agent steps per optimisation and "
                      "optimisation time on the episode's clock, variant / plain):", ""]
            lines += table(["row", "versus", "cost ratio", "CI90", "variant better",
                            "lag (steps)", "opt. time (ms)"],
                           [[name, f["versus"], num(f["ratio_geomean"]),
                             span(f["ratio_ci90"]),
                             f"{f['better']}/{f['pairs']}",
                             f"{num(f['lag_steps_mean'], 1)} / "
                             f"{num(f['versus_lag_steps_mean'], 1)}",
                             f"{num(f['opt_ms_mean'], 0)} / {num(f['versus_opt_ms_mean'], 0)}"]
                            for name, f in variants.items()])
        return lines

    return section("State-vector reduction, Table 1: iLQR-SVR in asynchronous MPC",
                   "MPC cost normalised by the baseline's on the same task instance; mean and "
                   "90 % CI over the trials that are neither outliers (goal object too far from "
                   "the goal at the end) nor unstable (the executed episode broke a stability "
                   "bound; counted in its own column), median over all.", results, page, body)


def protocol_line(d: dict) -> str:
    """How a Table 1 file's trials ran (files without a "preset" ran ours, the only one then)."""
    if "preset" not in d:
        return ("Protocol `ours`: cost with the end-effector term, zero initial plan, real "
                "clock, no control noise.")
    return (f"Protocol `{d['preset']}`: cost `{d.get('cost')}`"
            + (", the authors' set-up motion and push plan" if d.get("warm_start")
               else ", zero initial plan")
            + f", {d.get('clock')} clock"
            + (f" ({d.get('nominal_threads'):g} nominal threads)"
               if d.get("clock") == "virtual" else "")
            + f", control noise {d.get('control_noise')}, {d.get('fd')} differences, "
              f"slowdown {d.get('slowdown')}.")


def table1_headline(r: Result) -> str:
    if r.data.get("derivatives_effect"):
        return "; ".join(
            f"{name} / {f['versus']}: MPC cost {num(f['ratio_geomean'])} "
            f"({span(f['ratio_ci90'])}), lag {num(f['lag_steps_mean'], 1)} "
            f"/ {num(f['versus_lag_steps_mean'], 1)} steps, opt. time "
            f"{num(f['opt_ms_mean'], 0)} / {num(f['versus_opt_ms_mean'], 0)} ms "
            f"({f['pairs']} seeds)" for name, f in r.data["derivatives_effect"].items())
    parts = []
    trials = 0
    for name, m in r.data["methods"].items():
        trials = max(trials, m.get("n_trials", m.get("trials")) or 0)
        cost = pm(num(m.get("mpc_cost_normalised_mean")), num(m.get("mpc_cost_normalised_ci90")))
        parts.append(f"{name} {cost} ({num(m.get('opt_ms_mean'), 0)} ms, "
                     f"{num(m.get('n_dofs_mean', m.get('dofs_mean')), 1)} DoFs)")
    cost_used = f", cost `{r.data['cost']}`" if r.data.get("cost") else ""
    return (f"protocol `{r.data.get('preset', 'ours')}`{cost_used}; MPC cost / baseline "
            f"(opt. time, DoFs): " + "; ".join(parts)
            + f" ({trials} trial{'s' if trials != 1 else ''} each)")


# ------------------------------------------------------------ cloth step cost by size (KP)
def cloth_steps_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        def setting(row: dict) -> str:
            return row["preset"] + (f" + {row['variant']}" if row.get("variant") else "")

        rows = []
        for name in dict.fromkeys(setting(row) for row in r.data["rows"]):
            mine = [row for row in r.data["rows"] if setting(row) == name]
            small = min(mine, key=lambda row: row["n"])["ms_per_step"]["step"]
            for row in mine:
                ms = row["ms_per_step"]
                warned = {**row.get("warnings", {}),
                          **{clip(k, 60): v
                             for k, v in row.get("messages", {}).items()}}
                rows.append([name, f"{row['n']} x {row['n']}", num(ms["step"], 2),
                             num(ms["step"] / small if small else None, 1),
                             num(ms["collision"], 2), num(ms["constraint_solve"], 2),
                             num(ms["other"], 2), str(row["steps_per_action"]),
                             num(row["ms_per_action"], 0),
                             sci(row["flex_solve_residual_max"])
                             if "flex_solve_residual_max" in row else "not recorded",
                             "; ".join(f"{k} ({v})" for k, v in warned.items()) or "-"])
        return [f"### `{r.name}`", "",
                *table(["setting", "cloth", "ms / step", "vs smallest", "collision ms",
                        "constraint solve ms", "other ms (implicit solve)", "steps / action",
                        "ms / action", "flex solve residual (unconverged)",
                        "warnings (count)"], rows)]

    return section("Key particles: what a cloth step costs by resolution",
                   "`python -m dopt.bench cloth-steps`: one pick-and-place action per preset "
                   "and size, MuJoCo's own timers per step (collision, constraint solve, and the "
                   "rest of the step, which holds the discrete integrator's implicit solve), "
                   "the step against the smallest size's, the largest relative residual at "
                   "which the discrete integrator's flex solve (M + K) ran out of iterations, "
                   "among the messages MuJoCo printed (it prints a warning's text the first "
                   "times only; \"-\": none printed), and every warning MuJoCo raised "
                   "while the scene was built, settled and stepped. Variant rows change the "
                   "named fields of the preset (`dopt.bench.cloth_steps.VARIANTS`).",
                   results, page, body)


# ------------------------------------------------------ cloth step on MuJoCo Warp (KP)
def cloth_warp_section(results: list[Result], page: Path) -> list[str]:
    def warned(row: dict) -> str:
        """MuJoCo's warning counters over the CPU run of the action (its forward and steps)."""
        return "; ".join(f"{k} ({v})" for k, v in row["cpu"].get("warnings", {}).items()) \
            or "none"

    def body(r: Result) -> list[str]:
        rows, machines = [], {}
        for row in r.data["rows"]:
            mach = row["machine"]
            machines[f"{mach.get('warp_device')}, CPU {mach.get('cpu')}"] = mach
            cpu_ms = row["cpu"]["ms_per_step"]["step"]
            cpu_warned = warned(row)
            for w in row["warp"]:
                per_world = w.get("ms_per_world_step")
                failed = w.get("error", "")
                rows.append([
                    f"{row['n']} x {row['n']}", num(cpu_ms, 2), cpu_warned, str(w["nworld"]),
                    "yes" if w.get("cuda_graph") else ("no" if "cuda_graph" in w else "-"),
                    num(w.get("ms_per_step"), 2), num(per_world, 3),
                    num(cpu_ms / per_world if _finite(per_world) and per_world else None, 1),
                    num(w.get("first_step_s"), 1),
                    ", ".join(w.get("overflow_flags", [])) or ("none" if "overflow_flags" in w
                                                               else "-"),
                    f"{mm(w.get('gap_to_cpu_mean_m'), 2)} / {mm(w.get('gap_to_cpu_max_m'), 2)}",
                    f"{w.get('phase')}: {clip(failed, 90)}"
                    if failed else "-"])
        cpu_only = {row["n"]: (row["cpu"]["ms_per_step"]["step"], warned(row))
                    for row in r.data["rows"] if not row["warp"]}
        notes = [f"Machine: {name}" + (f"; every kernel module MuJoCo Warp registers compiled "
                                        f"on {m['preload_workers']} threads first in "
                                        f"{num(m['preload_s'], 1)} s" if "preload_s" in m
                                        else "") + "." for name, m in machines.items()]
        if cpu_only:
            notes.append("CPU step only (the run stopped before MuJoCo Warp stepped it): "
                         + ", ".join(f"{n} x {n} ({num(ms, 2)} ms / step, warnings: {w})"
                                     for n, (ms, w) in sorted(cpu_only.items())) + ".")
        return [f"### `{r.name}`", "", *notes, "",
                *table(["cloth", "CPU ms / step (one thread)", "CPU warnings (count)",
                        "worlds W", "CUDA graph",
                        "GPU ms / batched step", "GPU ms / world-step",
                        "world-steps per CPU step", "first step s (kernels compiled or loaded)",
                        "overflow flags", "world 0 vs CPU, mean / max (mm)", "failed"], rows)]

    return section("Key particles: a cloth step on MuJoCo Warp beside MuJoCo's CPU step",
                   "`python -m dopt.bench cloth-warp`: the action of `cloth-steps` stepped by "
                   "`mj_step` on one CPU thread and by MuJoCo Warp on W worlds in lockstep on "
                   "the same machine's GPU; world-steps per CPU step is the CPU step's time "
                   "over the GPU's time per world-step (what W worlds on the GPU give against "
                   "one core), the first step includes compiling the kernels it needs (or loading "
                   "them from warp's kernel cache), "
                   "overflow flags are MuJoCo Warp's (ITERATIONS: its solver stopped at its "
                   "iteration limit), and the last column the particle distance between "
                   "world 0 (float32) and the CPU run (float64) after the action.",
                   results, page, body)


# ------------------------------------------------------------------- Panda execution (KP)
def panda_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        rows = [[goal, str(e["n"]), pm(mm(e["picker_final_cost_mean"]),
                                        mm(e["picker_final_cost_ci95"])),
                 pm(mm(e["panda_final_cost_mean"]), mm(e["panda_final_cost_ci95"])),
                 pm(mm(e["difference_mean"]), mm(e["difference_ci95"])),
                 pm(mm(e["picker_vs_panda_mean"]), mm(e["picker_vs_panda_ci95"])),
                 mm(e["grasp_distance_max"]), mm(e["carry_error_max"]),
                 f"{e.get('missed_actions', 0)} / {e.get('n_actions', '?')}",
                 ("not judged" if "panda_unstable_seeds" not in e else
                  ", ".join(map(str, e["panda_unstable_seeds"])) or "none")]
                for goal, e in r.data["goals"].items()]
        return [f"### `{r.name}`" + (" (quick)" if r.quick else ""), "",
                *table(["goal", "seeds", "picker final cost (mm)", "Panda final cost (mm)",
                        "Panda - picker (mm)", "final cloths apart (mm)",
                        "worst grasp distance (mm)", "worst carry error (mm)",
                        "actions skipped (out of reach)", "unstable replays (seeds)"], rows)]

    return section("Key particles, Sec. IV-D: a Panda executes the plans",
                   "CEM(Simple) plans on the floating picker (the goal's preset), replayed "
                   "open-loop by a Franka Panda with a parallel gripper through inverse "
                   "kinematics and computed-torque control (`experiments/panda_execute.py`). "
                   "Final cost: mean particle distance to the goal, mean ± 95 % CI over the "
                   "seeds; the paired difference; the mean particle distance between the two "
                   "final cloths; the worst pinch-to-particle distance at a grasp and the worst "
                   "tracking error of the pinch while carrying; the actions the arm skipped "
                   "because its pinch did not reach the particle.", results, page, body)


def panda_headline(r: Result) -> str:
    return "; ".join(f"{goal}: picker {mm(e['picker_final_cost_mean'])} mm, Panda "
                     f"{mm(e['panda_final_cost_mean'])} mm, final cloths "
                     f"{mm(e['picker_vs_panda_mean'])} mm apart ({e['n']} seeds)"
                     for goal, e in r.data["goals"].items())


# ------------------------------------------------------------- table1 beside the paper
def paper_table1(results: list[Result]) -> tuple[Result | None, dict]:
    """The authors' reference file with the paper's published Table 1 (the newest), and that
    table ({task: {row: {"mpc_cost", "mpc_cost_ci90", ...}}}); (None, {}) without one."""
    refs = [r for r in results if r.kind == "paper_svr" and r.data.get("published")]
    return (refs[-1], refs[-1].data["published"]) if refs else (None, {})


def paper_preset_table1(results: list[Result], task: str) -> Result | None:
    """The Table 1 file of ``task`` run under the authors' protocol (not quick), if any."""
    chosen = [r for r in results if r.kind == "table1" and r.data.get("task") == task
              and r.data.get("preset") == "paper" and not r.quick
              and not r.data.get("derivatives_effect")]
    return chosen[-1] if chosen else None


def orderings(paper: dict, ours: dict) -> dict:
    """How two Table 1 columns order the same rows by MPC cost. ``paper``, ``ours``: {row:
    (mean, CI90 half-width)} (rows without both left out). Returns {"rows": the common rows,
    "paper_order", "our_order" (cheapest first), "kendall_tau", "reversed": [(a, b)] pairs the
    paper puts a below b and we put b below a, "reversed_separate": those of them whose
    intervals are separate in both columns}."""
    rows = [k for k in paper if k in ours and _finite(paper[k][0]) and _finite(ours[k][0])]
    rev, sep = [], []
    for i, a in enumerate(rows):
        for b in rows[i + 1:]:
            (pa, pca), (pb, pcb) = paper[a], paper[b]
            (oa, oca), (ob, ocb) = ours[a], ours[b]
            if (pa - pb) * (oa - ob) < 0:
                lo, hi = (a, b) if pa < pb else (b, a)
                rev.append((lo, hi))
                if (abs(pa - pb) > (pca or 0) + (pcb or 0)
                        and abs(oa - ob) > (oca or 0) + (ocb or 0)):
                    sep.append((lo, hi))
    tau = kendall_tau_b([paper[k][0] for k in rows], [ours[k][0] for k in rows])
    return {"rows": rows, "paper_order": sorted(rows, key=lambda k: paper[k][0]),
            "our_order": sorted(rows, key=lambda k: ours[k][0]), "kendall_tau": tau,
            "reversed": rev, "reversed_separate": sep}


def kendall_tau_b(x: list[float], y: list[float]) -> float | None:
    """Kendall's tau-b rank correlation of two equally long lists (ties in either count as
    neither concordant nor discordant); None with fewer than two values or all tied."""
    n = len(x)
    c = d = tx = ty = 0
    for i in range(n):
        for j in range(i + 1, n):
            sx, sy = (x[i] > x[j]) - (x[i] < x[j]), (y[i] > y[j]) - (y[i] < y[j])
            if sx == 0 or sy == 0:
                tx, ty = tx + (sx == 0), ty + (sy == 0)
            elif sx == sy:
                c += 1
            else:
                d += 1
    pairs = n * (n - 1) // 2
    denom = math.sqrt((pairs - tx) * (pairs - ty))
    return (c - d) / denom if denom else None


def _table1_columns(pub: dict, d: dict) -> tuple[dict, dict]:
    paper = {row: (v["mpc_cost"], v.get("mpc_cost_ci90")) for row, v in pub.items()}
    ours = {row: (m.get("mpc_cost_normalised_mean"), m.get("mpc_cost_normalised_ci90"))
            for row, m in d["methods"].items()}
    return paper, ours


def ordering_sentence(o: dict) -> str:
    """One line on how our rows order against the paper's."""
    sep = "; ".join(f"{a} < {b}" for a, b in o["reversed_separate"]) or "none"
    return (f"Kendall tau {num(o['kendall_tau'])} over {len(o['rows'])} rows; "
            f"{len(o['reversed'])} of {len(o['rows']) * (len(o['rows']) - 1) // 2} pairs in "
            f"the opposite order, {len(o['reversed_separate'])} of them with separate 90 % "
            f"intervals in both (paper's order: {sep})")


def table1_vs_paper_section(results: list[Result], page: Path) -> list[str]:
    """Each task's Table 1 under the authors' protocol beside the paper's printed Table 1 and
    the authors' data, with the orderings compared (empty without both files)."""
    ref, published = paper_table1(results)
    ours = {t: paper_preset_table1(results, t) for t in published}
    if ref is None or not any(ours.values()):
        return []
    lines = ["## State-vector reduction, Table 1 beside the paper", "",
             "Per row: the paper's printed MPC cost (normalised by its baseline's; mean ± 90 % "
             "CI, clutter without outliers), ours under `--preset paper` (mean ± 90 % CI of the "
             "per-seed cost / baseline, outliers left out; the median of the per-seed ratios; "
             "the geometric mean of the per-seed ratios with its 90 % CI), the authors' data's "
             "median final cost over baseline's (absent for rand and naive), DoFs and "
             "optimisation time. Paired ratios and medians are ours only: the paper prints "
             "means.", ""]
    for task, r in ours.items():
        if r is None:
            continue
        d = r.data
        pub, data_rows = published[task], ref.data["tasks"].get(task, {}).get("rows", {})
        paired_ = d.get("paired") or {}
        rows = []
        for row, p in pub.items():
            m = d["methods"].get(row, {})
            pr = paired_.get(row) or {}
            ci = pr.get("ratio_ci90") or []
            rows.append([row, pm(num(p["mpc_cost"]), num(p.get("mpc_cost_ci90"), 3)),
                         pm(num(m.get("mpc_cost_normalised_mean")),
                            num(m.get("mpc_cost_normalised_ci90"))),
                         num(m.get("mpc_cost_median_ratio")),
                         num(pr.get("ratio_geomean")) + (f" [{num(ci[0])}, {num(ci[1])}]"
                                                         if len(ci) == 2 else ""),
                         num((data_rows.get(row) or {}).get("median_ratio")),
                         f"{num(p.get('n_dofs'), 1)} / "
                         f"{num(m.get('n_dofs_mean', m.get('dofs_mean')), 1)}",
                         f"{num(p.get('opt_ms'), 0)} / {num(m.get('opt_ms_mean'), 0)}"])
        o = orderings(*_table1_columns(pub, d))
        lines += [f"### {task}: `{r.name}` beside the paper", "",
                  *table(["row", "paper MPC cost", "ours mean", "ours median ratio",
                          "ours paired geomean [CI90]", "authors' data median ratio",
                          "DoFs paper / ours", "opt. ms paper / ours"], rows), "",
                  f"Cheapest first, paper: {', '.join(o['paper_order'])}; ours: "
                  f"{', '.join(o['our_order'])}.", "", ordering_sentence(o) + ".", "",
                  *source_lines([r, ref], page), ""]
    return lines[:-1]


# --------------------------------------------------------------------------- fig4 (SVR)
def fig4_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        points = sorted(d.get("points") or [], key=lambda p: (p.get("theta"), p.get("rho")))
        lines = [f"### Fig. 4, {d.get('task')}, {d.get('method')}: `{r.name}`"
                 + (" (quick)" if r.quick else ""), ""]
        if not points:
            return lines + ["No points (every trial failed?)."]
        image = page.parent / "images" / f"fig4-{d.get('task')}.png"
        if image.exists():     # the experiment's rho_sweep.png, copied beside the docs
            lines += [f"![Fig. 4, {d.get('task')}: MPC cost / baseline and mean |C| against rho, "
                      f"ours (solid, 90 % CI bands) and the authors' (dashed)]"
                      f"(images/{image.name})", ""]
        return lines + table(["rho", "theta", *MPC_HEADER],
                             [[str(p.get("rho")), str(p.get("theta")), *mpc_cells(p)]
                              for p in points])

    return section("State-vector reduction, Fig. 4: importance threshold rho and random DoFs "
                   "theta", None, results, page, body)


def fig4_headline(r: Result) -> str:
    points = [p for p in r.data.get("points") or []
              if _finite(p.get("mpc_cost_normalised_mean"))]
    if not points:
        return f"{r.data.get('method')}: no finite point"
    best = min(points, key=lambda p: p["mpc_cost_normalised_mean"])
    trials = sum(p.get("n_trials") or 0 for p in r.data.get("points") or [])
    cost = pm(num(best["mpc_cost_normalised_mean"]), num(best.get("mpc_cost_normalised_ci90")))
    return (f"{r.data.get('method')}, {len(r.data.get('points'))} (rho, theta) points, "
            f"{trials} trials; lowest MPC cost / baseline {cost} at rho {best.get('rho')}, "
            f"theta {best.get('theta')} ({num(best.get('n_dofs_mean'), 1)} DoFs)")


# ---------------------------------------------------------------------- key particles
def _short_task(task: str) -> str:
    return task.replace("_", " ")


def kp_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        paper = d.get("paper") or {}
        lines = [f"### Key particles: `{r.name}`" + (" (quick)" if r.quick else ""), "",
                 f"Cloth {d.get('cloth_particles_per_side')} x "
                 f"{d.get('cloth_particles_per_side')} particles; seed {d.get('seed')}.", ""]
        rows = []
        for task, e in (d.get("tasks") or {}).items():
            p = paper.get(task, {})
            inter = "; ".join(f"{_short_task(g.get('goal', '?'))}: {g.get('n_keys')} keys, "
                              f"{g.get('n_elements')} el." for g in e.get("intermediate_goals", []))
            rows.append([_short_task(task), str(e.get("particles", "?")), str(e.get("n_keys")),
                         str(p.get("keys", "-")), str(e.get("n_elements")),
                         str(p.get("triangles", "-")),
                         f"{mm(e.get('error'))} / {mm(e.get('threshold'))}",
                         num(e.get("seconds"), 2), " ".join(str(i) for i in e.get("indices", [])),
                         inter or "-"])
        lines += table(["goal", "particles", "key particles", "paper", "elements",
                        "paper triangles", "error / threshold (mm)", "s", "indices",
                        "intermediate goals"], rows)
        rob = d.get("robustness") or {}
        if rob.get("cloth_grid"):
            lines += ["", *kp_grid(rob["cloth_grid"])]
        if rob.get("noise"):
            lines += ["", *kp_noise(rob["noise"])]
        if rob.get("simulated"):
            lines += ["", *kp_simulated(rob["simulated"])]
        return lines

    return section("Key particles, Fig. 4 and Sec. IV-C.1: key particles of each goal",
                   "Alg. 1 on each goal: the simplified model's elements (rope: segments; cloth: "
                   "triangles), its key particles, its error and threshold (cloth: in the "
                   "z-stretched space) and the wall time; paper: the counts the paper reports.",
                   results, page, body)


def kp_grid(rows: list[dict]) -> list[str]:
    """Key counts of the noise-free cloth goals: goal x resolution, one count per
    triangulation."""
    tris = list(dict.fromkeys(r.get("triangulation") for r in rows))
    cells: dict = {}
    for r in rows:
        k = "fail" if r.get("n_keys") is None else str(r["n_keys"])
        cells.setdefault((r.get("task"), r.get("n")), {})[r.get("triangulation")] = k
    out = ["Cloth key counts by resolution (particles per side), one per triangulation ("
           + " / ".join(map(str, tris)) + "):", ""]
    ns = sorted({r.get("n") for r in rows}, key=lambda n: (n is None, n))
    tasks = list(dict.fromkeys(r.get("task") for r in rows))
    return out + table(["goal", *[str(n) for n in ns]],
                       [[_short_task(t), *[" / ".join(cells.get((t, n), {}).get(x, "-")
                                                      for x in tris) for n in ns]]
                        for t in tasks])


def kp_noise(noise: dict) -> list[str]:
    """Goals whose key count equals the noise-free one, per kind and noise level."""
    sigmas = list(dict.fromkeys(s for cells in noise.values() for s in cells))
    return (["Goals whose key count held under Gaussian goal noise (sigma):", ""]
            + table(["goals", *sigmas],
                    [[kind, *[cells.get(s, "-") for s in sigmas]]
                     for kind, cells in noise.items()]))


def kp_simulated(rows: list[dict]) -> list[str]:
    """Key counts of the goals the simulator made (each fold by a line grasp, settled)."""
    out = ["Goals made by the simulator: each fold made on the MuJoCo cloth (physics preset as "
           "given, self-collision on) by a line grasp of the moving part's far edge turned over "
           "its crease (`dopt.tasks.pick.fold_goals`; the underneath fold as the accordion of "
           "three folds on top that makes the same stack), settled; the reduction gets the "
           "settled positions, the flex's triangles and the settled flat start as rest sheet. "
           "Fold error: mean / largest particle distance to the rigid fold with sharp creases "
           "(`ideal_folds`); `!` marks a folding the stability verdict flagged. Keys and faces "
           "under the default panel projection and under `ClothConfig(panels=\"fold\")` "
           "(every particle onto its panel); `*`: no model up to 40 faces reached the "
           "threshold.", ""]
    body = []
    for r in rows:
        if "error" in r:
            body.append([_short_task(r["task"]), str(r["n"]), r.get("physics", "-"), "-", "-",
                         str(r["reference_keys"]), "failed: " + cell(r["error"]), "-", "-", "-"])
            continue

        def keys(k: dict) -> str:
            return f"{k['n_keys']}{'' if k['reached_threshold'] else '*'}"

        fold = r["fold"]
        body.append([_short_task(r["task"]), str(r["n"]), r["physics"],
                     f"{num(r['fold_error_mm'], 1)} / {num(r['fold_error_max_mm'], 1)}"
                     + (" !" if r["unstable"] else ""),
                     "none found" if r["layer_gap_mm"] is None else num(r["layer_gap_mm"], 2),
                     str(r["reference_keys"]), keys(r), keys(fold),
                     f"{r['n_elements']} / {fold['n_elements']}",
                     " / ".join(str(k) for k in fold["n_keys_by_merge_deg"].values())])
    angles = next((" / ".join(r["fold"]["n_keys_by_merge_deg"]) for r in rows
                   if "fold" in r), "")
    return out + table(["goal", "n", "physics", "fold error (mm)", "layer gap (mm)",
                        "reference keys", "keys", "keys (fold)", "faces (default / fold)",
                        f"keys (fold), merge angle {angles} deg"], body)


def kp_headline(r: Result) -> str:
    tasks = r.data.get("tasks") or {}
    paper = r.data.get("paper") or {}
    parts = []
    for task, e in tasks.items():
        p = paper.get(task, {})
        cloth = task.startswith("cloth")
        text = f"{_short_task(task)} {e.get('n_keys')}" + (
            f" keys / {e.get('n_elements')} triangles" if cloth else "")
        ref = p.get("triangles") if cloth else p.get("keys")
        if ref is not None:
            text += f" (paper {ref}{' triangles' if cloth else ''})"
        parts.append(text)
    return "; ".join(parts)


def _histogram_text(counts: dict) -> str:
    """{value: goals} as "value (goals), ..." ("4 (all)" when one value)."""
    if len(counts) == 1:
        return f"{next(iter(counts))} (all)"
    return ", ".join(f"{k} ({v})" for k, v in counts.items())


def kp_compare_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for name, levels in d["summary"].items():
            for level, folds in levels.items():
                sigma = float(level.removeprefix("noise_"))
                for task, c in folds.items():
                    rows.append([name, _short_task(task), f"{sigma * 1e3:g}",
                                 f"{c['keys_held']} / {c['goals']}",
                                 f"{c['reached_threshold']} / {c['goals']}",
                                 _histogram_text(c["faces"]), _histogram_text(c["keys"]),
                                 num(c["median_seconds"], 2)])
        return [f"Resolutions {', '.join(map(str, d['resolutions']))} per side; triangulations "
                f"{', '.join(d['triangulations'])}; noise 0 and {d['noise_m'] * 1e3:g} mm.", "",
                *table(["pipeline", "fold", "noise (mm)", "reference keys", "threshold reached",
                        "faces (goals)", "keys (goals)", "median s"], rows)]

    return section("Key particles: the paper's pipeline against the default",
                   "`python -m deformables.bench compare`: the same cloth goals (four folds x "
                   "resolutions x four triangulations, exact and with Gaussian noise) reduced by "
                   "`ClothConfig()` and by `ClothConfig.paper()` (one-sided Hausdorff distance in "
                   "metres, one decimation per size from the goal, no restarts, no panel "
                   "projection, no re-triangulation). Per fold and noise level: goals whose key "
                   "count is the reference (diagonal 4, side 6, reflective 8, underneath 10), "
                   "goals whose reduction reached its threshold, the face and key counts seen "
                   "(goals), and the median seconds per goal.", results, page, body)


def kp_paper_scale_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = [[_short_task(g["task"]), str(g["particles"]), f"{g['noise_m'] * 1e3:g}",
                 f"{g['n_keys']} ({g['reference_keys']})", str(g["n_elements"]),
                 "yes" if g["reached_threshold"] else "no", num(g["seconds"], 2)]
                for g in d["goals"]]
        return [f"{d['cloth_n']} x {d['cloth_n']} particles, {d['repeats']} timed run(s) "
                "per goal.", "",
                *table(["fold", "particles", "noise (mm)", "keys (reference)", "faces",
                        "threshold reached", "s"], rows), "",
                *table(["noise (mm)", "mean s over the folds", "paper s", "ratio",
                        "reference keys"],
                       [[f"{float(k.removeprefix('noise_')) * 1e3:g}",
                         num(v["mean_seconds"], 2), num(v["paper_seconds"], 2),
                         num(v["ratio_to_paper"], 2), f"{v['keys_held']} / 4"]
                        for k, v in d["summary"].items()])]

    return section("Key particles at the paper's resolution",
                   "`python -m deformables.bench paper-scale`: the four cloth folds at the "
                   "paper's cloth size, MuJoCo's triangulation, the default pipeline, without "
                   "noise and with Gaussian noise; seconds per reduction (median of the repeats) "
                   "against the paper's 0.73 s average.", results, page, body)


def svr_explain_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for name, row in d["rows"].items():
            share = row.get("importance_share") or {}
            n_dofs = [v for v in row["n_dofs"] if v is not None]
            rows.append([name, str(row["n_trials"]), num(sum(n_dofs) / len(n_dofs) if n_dofs
                                                         else None, 1),
                         num(row["goal_share_mean"]), num(share.get("zero")),
                         num(share.get("lt_1")), num(share.get("1_to_500")),
                         num(share.get("ge_500")), str(row["importance"]["n"])])
        return [f"### {d.get('task')}: `{r.name}`", "", protocol_line(d), "",
                *table(["row", "trials", "mean size of C", "goal DoFs in C", "importance = 0",
                        "< 1", "[1, 500)", ">= 500", "values"], rows)]

    return section("State-vector reduction: which DoFs each method holds, and what rho cuts",
                   "Per row: mean |C| and the share of the goal object's x, y DoFs in C per "
                   "optimisation (over the episode, then over seeds); for SVR, the importances "
                   "of the non-robot DoFs in C before the cut, pooled over optimisations and "
                   "seeds.", results, page, body)


def ilqr_bench_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        return [f"### {r.data.get('task')}: `{r.name}`", "",
                *table(["method", "derivatives", "box QP", "ms / iteration", "vs every",
                        "derivative share", "FD timesteps", "error (mean)", "error (median)",
                        "DoFs"],
                       [[row["method"], row["keypoints"], "yes" if row["box_qp"] else "no",
                         num(row["ms_per_iteration"], 0), num(row.get("vs_every")),
                         num(row["derivative_share"]),
                         f"{num(row['fd_steps'], 1)} / {row['horizon']}",
                         num(row["interp_error"], 4), num(row.get("interp_error_median"), 4),
                         num(row["n_dofs"], 1)]
                        for row in r.data["rows"]])]

    return section("iLQR iteration: derivatives over time and the box-QP backward pass",
                   "One iLQR(-SVR) iteration per method and derivative variant, same run: "
                   "finite differences at every timestep, every K-th (skipK) or at adaptive key "
                   "points, A and B linear between; `vs every`: time over the same method's at "
                   "every timestep; error: relative Frobenius error of the interpolated [A B] "
                   "against every-timestep differences on the last nominal, mean and median over t "
                   "(they differ where a few timesteps in contact, whose A and B change from "
                   "one step to the next, carry the whole error).",
                   results, page, body)


def paper_svr_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        lines: list[str] = []
        for task, t in r.data["tasks"].items():
            # plain iLQR runs record 0 DoFs in their data (not tracked): shown as "-"
            rows = [[name, str(v["n_runs"]), num(v["median_ratio"]),
                     num(v["final_dist_mean"], 3), num(v["avg_dofs"], 1) if v["avg_dofs"]
                     else "-", num(v["opt_ms"], 0)] for name, v in t["rows"].items()]
            rows += [["(unidentified iLQR run)", str(v["n_runs"]), num(v["median_ratio"]),
                      num(v["final_dist_mean"], 3), "-", num(v["opt_ms"], 0)]
                     for v in t.get("unidentified", [])]
            lines += [f"### {task}", "",
                      *table(["row", "runs", "median cost / baseline",
                              "final goal distance (m)", "DoFs", "opt. time (ms)"], rows), ""]
        return lines[:-1]

    return section("The state-vector-reduction authors' own data",
                   "Their run summaries (`experiments/paper_reference.py`): per Table 1 row the "
                   "runs, the median final cost over the baseline's (their Table 1's statistic), "
                   "mean final goal distance, mean DoFs and optimisation time. Rows their data "
                   "does not name (rand, naive) are absent; a second plain iLQR run per task is "
                   "not identified in it.", results, page, body)


def clock_check_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for name, row in d["rows"].items():
            real, virt = row.get("real", {}), row.get("virtual", {})
            rows.append([name, str(real.get("n_trials")), num(real.get("lag_steps_mean"), 1),
                         num(virt.get("lag_steps_mean"), 1), num(row.get("lag_ratio")),
                         num(row.get("opt_ms_ratio")), num(row.get("real_speedup")),
                         pm(num(real.get("mpc_cost_mean"), 0), num(real.get("mpc_cost_ci90"), 0)),
                         pm(num(virt.get("mpc_cost_mean"), 0), num(virt.get("mpc_cost_ci90"), 0)),
                         "yes" if row.get("lag_within_10_percent") else "no",
                         "yes" if row.get("cost_intervals_overlap") else "no"])
        seeds = d.get("seeds")
        return [f"### {d.get('task')}: `{r.name}`", "", protocol_line(d)
                + (f" Seeds {seeds[0]} to {seeds[-1]}." if seeds else ""), "",
                *table(["row", "trials", "lag real", "lag virtual", "lag ratio",
                        "opt. time ratio", "real speed-up", "cost real", "cost virtual",
                        "lag within 10 %", "costs overlap"], rows)]

    return section("The virtual clock against the real clock",
                   "The same trials under both clocks: real (alone, in real time, on the "
                   "machine's threads) and virtual (one thread, CPU time / nominal threads). "
                   "Ratios are virtual / real; the lag should be within 10 % and the MPC cost "
                   "intervals (90 %) should overlap. The real speed-up is one thread's CPU time "
                   "(nominal threads x the virtual optimisation time) over the real one: the "
                   "nominal thread count at which the two clocks agree.", results, page, body)


def clock_check_headline(r: Result) -> str:
    rows = r.data["rows"]
    overlap = sum(bool(v.get("cost_intervals_overlap")) for v in rows.values())
    nominal = r.data.get("nominal_threads")
    seeds = r.data.get("seeds")
    return (f"{r.data.get('task')}" + (f", {nominal:g} nominal threads" if nominal else "")
            + ": lag virtual / real "
            + ", ".join(f"{name} {num(v.get('lag_ratio'))}" for name, v in rows.items())
            + f"; MPC cost intervals overlap on {overlap} of {len(rows)} rows "
              f"({max((v.get('real') or {}).get('n_trials') or 0 for v in rows.values())} "
              f"seeds each" + (f", {seeds[0]}-{seeds[-1]}" if seeds else "") + ")")


def clock_model_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        return table(["task", "points (|C|: ms)", "a (ms)", "b (ms per DoF)", "R^2"],
                     [[task, ", ".join(f"{row['n_dofs']}: {row['ms']:.0f}"
                                       for row in d["rows"] if row["task"] == task),
                       num(f["a_ms"], 1), num(f["b_ms"], 2), num(f["r2"], 3)]
                      for task, f in d["fits"].items()])

    return section("The model clock: CPU time of an MPC optimisation against |C|",
                   "One optimisation of `rand` at theta random DoFs (|C| = 7 + theta) per point, "
                   "the paper's protocol, one simulation thread; ms = CPU time / nominal "
                   "threads. `planners.svr_mpc.CLOCK_MODEL_MS` holds the fits.",
                   results, page, body)



# ----------------------------------------------------------------- sweeps in progress
def unrecorded_sweeps(results_dir: Path, results: list[Result]) -> dict[str, list[dict]]:
    """{folder name: its trial records} of every ``runs/fig7-*`` folder under ``results_dir``
    with committed trials (``trials/*.json``, as ``dopt.sweep`` writes them) that its recorded
    summary ``<folder>.json`` among ``results`` (``load_results(results_dir)``) does not hold:
    all of them while no summary is recorded, else those whose method and seed the summary
    lacks (a sweep recorded for some methods or seeds, more committed since). Folders in name
    order, records in file-name order; a folder whose trials the summary holds all of is left
    out."""
    recorded = {r.path.stem: r.data for r in results}
    out = {}
    for folder in sorted(Path(results_dir).glob("runs/fig7-*")):
        files = sorted(folder.glob("trials/*.json"))
        held = {m: set(row.get("seeds") or ())
                for m, row in recorded.get(folder.name, {}).get("methods", {}).items()}
        records = []
        for path in files:
            try:
                data = json.loads(path.read_text())
                # dopt.sweep.RECORD_FIELDS (copied: this script needs no dopt)
                missing = [k for k in ("key", "params", "result") if k not in data]
                if missing:
                    raise KeyError(", ".join(missing))
                params, result = data["params"], data["result"]
                record = {"settings": params["settings"], "method": result["method"],
                          "seed": result["seed"], "result": result}
            except (OSError, ValueError, KeyError, TypeError) as e:
                raise ReportError(f"{path}: not a trial record of a Fig. 7 sweep "
                                  f"({type(e).__name__}: {e})") from e
            if record["seed"] not in held.get(record["method"], ()):
                records.append(record)
        if records:
            out[folder.name] = records
    return out


def checkpointed_trials(folder: Path) -> list[str]:
    """"<method label> seed <s>: <n> CEM iterations done, <t> s" per checkpoint under
    ``folder/trials/checkpoints/`` (``dopt.sweep.Checkpoint``: a trial stopped part-way that
    a rerun resumes), in file-name order."""
    out = []
    for path in sorted(Path(folder).glob("trials/checkpoints/*.json")):
        try:
            progress = json.loads(path.read_text())["progress"]
            trial, iterations = progress["trial"], iterations_done(progress)
            out.append(f"{_label(trial['method'])} seed {trial['seed']}: {iterations} CEM "
                       f"iterations done, {num(progress['wall_s'], 0)} s")
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise ReportError(f"{path}: not a checkpoint of a Fig. 7 trial "
                              f"({type(e).__name__}: {e})") from e
    return out


def _median(xs: list) -> float | None:
    xs = [x for x in xs if _finite(x)]
    return statistics.median(xs) if xs else None


def sweeps_in_progress_section(results_dir: Path, results: list[Result]) -> list[str]:
    """Per unrecorded Fig. 7 sweep (``unrecorded_sweeps``) and per settings key in it: each
    method's committed seeds with their final costs, and the measured cost of a trial. No
    means or claims: those wait for the recorded summary."""
    sweeps = unrecorded_sweeps(results_dir, results)
    if not sweeps:
        return []
    lines = ["## Fig. 7 sweeps in progress", "",
             "Trials committed under `docs/results/runs/<sweep>/trials/` that the sweep's "
             "summary (`docs/results/<sweep>.json`) does not hold yet (not recorded, or recorded "
             "for other methods or seeds): each seed's final cost (mean particle distance, mm) "
             "as its trial file holds it, and what a trial cost. Means, intervals and the "
             "paper's claims wait for the recorded summary; the command in the results table "
             "above (with these methods in `--methods` and enough `--seeds`) resumes the sweep "
             "where it stopped."]
    def panel_order(item) -> tuple:
        s = item[1][0]["settings"]
        return _panel_rank(s.get("task"), s.get("goal")), item[0]

    for name, records in sorted(sweeps.items(), key=panel_order):
        by_settings: dict[str, list[dict]] = {}
        for rec in records:
            by_settings.setdefault(json.dumps(rec["settings"], sort_keys=True), []).append(rec)
        for group in by_settings.values():
            s = group[0]["settings"]
            cem = s.get("cem") or {}
            size = (f"{s.get('n')} x {s.get('n')}" if s.get("task") == "cloth"
                    else str(s.get("n")))
            lines += ["", f"### `{name}`: Fig. 7 {_panel_of(s.get('task'), s.get('goal'))}", "",
                      f"{size} particles, self-collision "
                      f"{'on' if s.get('selfcollide') else 'off'}, physics {s.get('physics')}; "
                      f"CEM population {cem.get('population')}, elites {cem.get('elites')}, "
                      f"{cem.get('iterations')} iterations per stage, horizon "
                      f"{cem.get('horizon')}.", ""]
            rows = []
            for m in _in_label_order(r["method"] for r in group):
                runs = sorted((r for r in group if r["method"] == m), key=lambda r: r["seed"])
                res = [r["result"] for r in runs]
                flagged = [x.get("n_unstable_rollouts") for x in res]
                rollouts = [x.get("n_rollouts") for x in res]
                rows.append([_label(m), ", ".join(str(r["seed"]) for r in runs),
                             ", ".join(mm(x.get("final_cost")) for x in res),
                             num(_median([x.get("s_per_iteration") for x in res]), 1),
                             num(_median([x.get("wall_s") for x in res]), 0),
                             f"{sum(flagged)} / {sum(rollouts)}"
                             if all(_finite(x) for x in flagged + rollouts) else "not judged",
                             str(sum(bool(x.get("unstable")) for x in res))])
            lines += table(["method", "seeds", "final cost per seed (mm)",
                            "s / CEM iteration (median)", "s / trial (median)",
                            "planning rollouts flagged", "executed plans unstable"], rows)
            wall = sum(x for r in group if _finite(x := r["result"].get("wall_s")))
            n = len(group)
            lines += ["", f"{n} trial{'s' if n != 1 else ''}, {num(wall, 0)} s of trials "
                          f"({num(wall / 3600, 1)} h of one core)."]
        stopped = checkpointed_trials(Path(results_dir) / "runs" / name)
        if stopped:
            lines += ["", "Stopped part-way, their progress committed under "
                          "`trials/checkpoints/` (a rerun resumes each where it stopped): "
                      + "; ".join(stopped) + "."]
    return lines


# ----------------------------------------------------------------------------- pages
SECTIONS = {"key_particles": kp_section, "kp_compare": kp_compare_section,
            "kp_paper_scale": kp_paper_scale_section, "fig7": fig7_section,
            "table1": table1_section, "fig4": fig4_section, "physics": physics_section,
            "clock_model": clock_model_section, "svr_explain": svr_explain_section,
            "ilqr_bench": ilqr_bench_section, "clock_check": clock_check_section,
            "paper_svr": paper_svr_section, "panda_execute": panda_section,
            "cloth_steps": cloth_steps_section, "cloth_warp": cloth_warp_section}
HEADLINES = {"key_particles": kp_headline, "fig7": fig7_headline, "table1": table1_headline,
             "fig4": fig4_headline, "panda_execute": panda_headline,
             "clock_check": clock_check_headline}


def _display(path: Path) -> str:
    try:
        return Path(path).resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return Path(path).as_posix()


def _rendered(r: Result, fn, *args):
    try:
        return fn(*args)
    except (KeyError, TypeError, AttributeError, ValueError) as e:
        raise ReportError(f"{r.path}: malformed {r.kind!r} result ({type(e).__name__}: {e})") \
            from e


def results_md(results: list[Result], results_dir: Path, page: Path) -> str:
    """The text of RESULTS.md for ``results`` (from ``results_dir``), to be written at
    ``page`` (links are relative to it)."""
    where = _display(results_dir)
    lines = ["# Results", "",
             f"*Generated by `experiments/report.py` from `{where}/*.json`: do not edit by hand. "
             f"Regenerate with `{REGENERATE}` (`--check` tells whether this page is current).*",
             "",
             "Each number below is read from a result file that an experiment wrote itself "
             "(`--record PATH`); each table names its file, the git commit the run was made at "
             "(`-dirty`: with uncommitted changes) and its command line.", ""]
    if not results:
        return "\n".join(lines + [f"No results yet: `{where}/` holds no result file. Run an "
                                  "experiment with `--record "
                                  f"{where}/<name>.json`, then `{REGENERATE}`.", ""])
    lines += ["## Result files", ""]
    lines += table(["file", "experiment", "paper figure / table", "commit", "date"],
                   [[link(r, page), r.kind, _items(r), r.commit, r.date] for r in results])
    for kind, section in SECTIONS.items():
        chosen = [r for r in results if r.kind == kind]
        if chosen:
            for r in chosen:                # a malformed file: an error that names it
                _rendered(r, section, [r], page)
            lines += ["", *section(chosen, page)]
    beside = table1_vs_paper_section(results, page)
    if beside:
        lines += ["", *beside]
    in_progress = sweeps_in_progress_section(results_dir, results)
    if in_progress:
        lines += ["", *in_progress]
    other = [r for r in results if r.kind not in SECTIONS]
    if other:
        lines += ["", "## Other result files", "",
                  "Files of a kind this script does not render (field \"experiment\"):", ""]
        lines += [f"- {link(r, page)}: experiment `{r.kind}`, commit `{r.commit}`, "
                  f"`{r.command}`" for r in other]
    return "\n".join(lines) + "\n"


def _items(r: Result) -> str:
    names = [f"{e.paper}: {e.item}" for e in CATALOGUE if e.match(r)]
    return "; ".join(names) or "-"


def readme_block(results: list[Result], readme: Path, results_md_path: Path) -> str:
    """The README's headline table (between the markers, markers excluded)."""
    rows = []
    for e in CATALOGUE:
        # a Fig. 7 run that departs from its protocol is in RESULTS.md, beside the protocol's
        matched = [r for r in results if e.match(r) and not _departs(r)]
        if not matched:
            rows.append([e.paper, e.item, f"`{e.command}`", "not recorded yet"])
        for r in matched:
            headline = _rendered(r, HEADLINES[r.kind], r)
            rows.append([e.paper, e.item + (" (quick run)" if r.quick else ""),
                         f"`{r.command}`", f"{headline}; {source(r, readme)}"])
    for r in results:                  # a known kind the catalogue has no row for
        if r.kind in HEADLINES and not _departs(r) and not any(e.match(r) for e in CATALOGUE):
            rows.append(["-", f"{r.kind}: {r.data.get('task', '')} {r.data.get('goal', '')}"
                         .strip(), f"`{r.command}`",
                         f"{_rendered(r, HEADLINES[r.kind], r)}; {source(r, readme)}"])
    departing = "; ".join(sorted({fig7_departures(r) for r in results if _departs(r)}))
    claims = fig7_claims_lines(results, readme)
    ref, published = paper_table1(results)
    beside = [(t, r) for t in published if (r := paper_preset_table1(results, t))]
    rel = Path(os.path.relpath(results_md_path, Path(readme).parent)).as_posix()
    lines = [f"<!-- generated by experiments/report.py from the result files; edit those, "
             f"then run `{REGENERATE}` -->",
             *table(["paper", "figure / table", "command", "headline numbers (source file, "
                     "commit)"], rows), "",
             f"Every table, per-seed number and setting: [{rel}]({rel}), generated like this "
             f"table from the result files by `{REGENERATE}`."
             + (f" Fig. 7 runs that change a protocol's settings ({departing}) are there, "
                f"each beside its protocol's file." if departing else "")]
    if claims:
        lines += ["", "Fig. 7's claims on the recorded files (each panel on the paper's metric, "
                      "named; 95 % intervals separate or overlapping; difference: the other "
                      "method's mean minus Simple's ± its Welch 95 % interval):", "", *claims]
    if beside:
        lines += ["", f"Table 1 under `--preset paper` against the paper's printed Table 1 "
                      f"(MPC cost / baseline, means; [{rel}]({rel}) has the rows side by side):",
                  ""]
        lines += [f"- {task}: paper cheapest first {', '.join(o['paper_order'][:3])}; ours "
                  f"{', '.join(o['our_order'][:3])}. {ordering_sentence(o)}; {source(r, readme)}."
                  for task, r in beside
                  for o in [orderings(*_table1_columns(published[task], r.data))]]
    return "\n".join(lines)


def replace_block(text: str, block: str) -> str | None:
    """``text`` with the block between the markers replaced; None without both markers."""
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        return None
    return text[:start + len(BEGIN)] + "\n" + block + "\n" + text[end:]


# ------------------------------------------------------------------------------- main
def generate(results_dir: Path, results_md_path: Path, readme: Path) -> dict:
    """{"files": {path: wanted text} of both outputs (README only when it has the markers),
    "note": about a README without markers (or None), "results": the result files read}."""
    results = load_results(results_dir)
    out = {Path(results_md_path): results_md(results, results_dir, results_md_path)}
    note = None
    if Path(readme).exists():
        new = replace_block(Path(readme).read_text(),
                            readme_block(results, readme, results_md_path))
        if new is None:
            note = (f"{readme} has no {BEGIN} ... {END} markers: left alone (put them where "
                    "the headline table belongs)")
        else:
            out[Path(readme)] = new
    else:
        note = f"{readme} does not exist: left alone"
    return {"files": out, "note": note, "results": results}


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="report.py", description=__doc__, epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 if RESULTS.md or the README block differs "
                         "from what this script would generate")
    ap.add_argument("--results-dir", type=existing_dir, default=ROOT / "docs" / "results",
                    help="folder of the result files (default docs/results; given, it must "
                         "exist)")
    ap.add_argument("--results-md", type=Path, default=ROOT / "docs" / "RESULTS.md",
                    help="the generated page (default docs/RESULTS.md)")
    ap.add_argument("--readme", type=Path, default=ROOT / "README.md",
                    help="the README whose results block is rewritten (default README.md)")
    return ap


@guarded("report.py")
def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    if not args.check:
        for flag, path in (("--results-md", args.results_md), ("--readme", args.readme)):
            problem = file_problem(path) if flag == "--results-md" or path.exists() else None
            if problem:
                ap.error(f"argument {flag}: {problem}")
    try:
        gen = generate(args.results_dir, args.results_md, args.readme)
    except ReportError as e:
        print(f"report.py: error: {e}", file=sys.stderr)
        return 2
    for r in gen["results"]:
        gaps = provenance_gaps(r)
        if gaps:
            print(f"note: {_display(r.path)}: its provenance lacks {', '.join(gaps)} (rerun "
                  f"the experiment to record them)", file=sys.stderr)
    if gen["note"]:
        print(f"note: {gen['note']}", file=sys.stderr)
    stale = [p for p, text in gen["files"].items()
             if not p.exists() or p.read_text() != text]
    if args.check:
        for p in stale:
            print(f"{_display(p)} differs from what experiments/report.py generates from "
                  f"{_display(args.results_dir)}; run `{REGENERATE}`", file=sys.stderr)
        if not stale:
            print("up to date: " + ", ".join(_display(p) for p in gen["files"]))
        return 1 if stale else 0
    for p in stale:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(gen["files"][p])
    print("wrote " + (", ".join(_display(p) for p in stale) or "nothing (up to date)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
