"""Rebuild every summary under docs/results that has committed trials, from those trials alone
(no simulation), with the summarize functions the experiments use, and say where a committed
summary does not match its trials.

For each summary whose trials are committed under ``docs/results/runs/<sweep>/``
(``dopt.lab.report.trials``: the folder of its command's ``--out``, the summary's own trials
in it), the fields its experiment computes from its trials (``Experiment.trial_fields``) are
computed again by its ``rebuild`` hook (``dopt.lab.experiment``: Fig. 7 by
``planners.pick_place.summarize``, Table 1 and Fig. 4 by ``planners.svr_mpc``'s fields, the
clock check, the SVR explanation and the Panda by their scripts' summaries), and
"trial_commits" from the trial files. Every other field (the settings, the protocol, the
departures, the resolved physics) is the committed summary's. The comparison covers every
field of the committed summary among those: a number that differs beyond rounding (relative
1e-9), a field the rebuild lacks (a summary of an older format), other values that differ.

    python experiments/resummarize.py --out results/resummarized     # rebuild, compare, write
    python experiments/resummarize.py --check     # exit 1 on a mismatch or a failed rebuild
    python experiments/resummarize.py --in-place [--only A.json,B.json]

``--in-place`` writes the rebuilt summary over the committed one, with this run's provenance
(and the original run's under "resummarized_from"), only for a summary whose trials are all
from committed code and whose numbers its trials give, and which was written from uncommitted
code or lacks a field its trials give (an older format, e.g. a Table 1 summary written before
``versus``): that is what makes such a summary pass the docs/results test, or show what the
summaries compute today, without rerunning anything. It is refused, like ``--record``, from a
tree with uncommitted changes. Trial files are only read.
"""

from __future__ import annotations

import argparse
import copy
import math
import sys
from collections import Counter
from pathlib import Path

from dopt import atomic
from dopt.lab import jsonio
from dopt.lab.cli import EPILOG, ArgumentParser, existing_dir, guarded, output_dir
from dopt.lab.experiment import experiment_of
from dopt.lab.report.base import ROOT, Result, load_results
from dopt.lab.report.trials import TrialInfo, summary_trials, uncommitted

REL_TOL, ABS_TOL = 1e-9, 1e-12


def records_of(info: TrialInfo) -> list[dict]:
    """The trial records ({"key", "params", "result", "code"}), in file-name order (a NaN
    written null with its note read back as NaN: ``dopt.lab.jsonio``)."""
    return [jsonio.loads(p.read_text(), strict_numbers=False)
            for p in sorted(info.files, key=lambda p: p.name)]


def commits_of(records: list[dict]) -> dict:
    return dict(Counter(str((r.get("code") or {}).get("commit") or "unknown") for r in records))


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def compare(committed, rebuilt, path: str = "") -> dict:
    """Where ``committed`` (a committed summary's value) and ``rebuilt`` disagree: {"differs":
    [paths], "missing": [paths the rebuild lacks], "new": [paths only the rebuild has]};
    numbers equal to REL_TOL / ABS_TOL, None and NaN alike (no value); a list of Fig. 4
    points matched by (rho, theta)."""
    out: dict = {"differs": [], "missing": [], "new": []}

    def walk(a, b, where):
        if isinstance(a, dict) and isinstance(b, dict):
            for k in a:
                if k not in b:
                    out["missing"].append(f"{where}.{k}".lstrip("."))
                else:
                    walk(a[k], b[k], f"{where}.{k}")
            out["new"] += [f"{where}.{k}".lstrip(".") for k in b if k not in a]
        elif isinstance(a, list) and isinstance(b, list):
            if a and all(isinstance(x, dict) and {"rho", "theta"} <= set(x) for x in a + b):
                a = sorted(a, key=lambda x: (x["theta"], x["rho"]))
                b = sorted(b, key=lambda x: (x["theta"], x["rho"]))
            if len(a) != len(b):
                out["differs"].append(f"{where} (length {len(a)} vs {len(b)})".lstrip("."))
                return
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                walk(x, y, f"{where}[{i}]")
        elif _number(a) and _number(b):
            if not (math.isnan(a) and math.isnan(b)) and not math.isclose(
                    a, b, rel_tol=REL_TOL, abs_tol=ABS_TOL):
                out["differs"].append(where.lstrip("."))
        elif (a is None or (_number(a) and math.isnan(a))) and \
                (b is None or (_number(b) and math.isnan(b))):
            return
        elif a != b:
            out["differs"].append(where.lstrip("."))

    walk(committed, rebuilt, path)
    return out


def rebuild(results_dir: Path, r: Result) -> dict | None:
    """{"info", "fields": the rebuilt fields, "diff": ``compare`` over the committed
    summary's trial fields, "error"} of a summary with committed trials (None without)."""
    experiment = experiment_of(r)
    if experiment is None or not experiment.trial_fields:
        return None
    info = summary_trials(results_dir, r)
    if info is None:
        return None
    try:
        fields = experiment.rebuild(r.data, records_of(info), info)
    except Exception as e:  # named in the report, the others go on
        return {"info": info, "fields": None, "diff": None,
                "error": f"{type(e).__name__}: {' '.join(str(e).split())}"}
    return {"info": info, "fields": fields, "diff": compare(committed_fields(r), fields),
            "error": None}


def committed_fields(r: Result) -> dict:
    """The trial fields of a committed summary, each value the writer meant: a non-finite
    number written as null with its note (``dopt.lab.jsonio``) is that number again and the note
    is gone, as the rebuild holds them."""
    return jsonio.restore(copy.deepcopy({k: r.data[k] for k in experiment_of(r).trial_fields
                                         if k in r.data}))


def matches(found: dict) -> bool:
    return found["error"] is None and not found["diff"]["differs"] \
        and not found["diff"]["missing"]


def eligible(r: Result, found: dict) -> str | None:
    """Why ``--in-place`` leaves a summary alone (None: it is re-summarised): one from
    committed code that holds every field its trials give is left alone."""
    if (not str(r.provenance.get("git_commit") or "").endswith("-dirty")
            and not found["diff"]["new"]):
        return "its summary is from committed code and holds every field its trials give"
    bad = sum(n for c, n in found["info"].commits.items() if uncommitted(c))
    if bad:
        return f"{bad} of {found['info'].n} trials from uncommitted code: rerun them"
    if not matches(found):
        return "its trials do not give its numbers"
    return None


def resummarized(r: Result, found: dict) -> dict:
    """The rebuilt summary (without its provenance): the committed one with the trial fields
    rebuilt and the original run's provenance under "resummarized_from"."""
    out = copy.deepcopy(r.data)
    out.update(found["fields"])
    out["resummarized_from"] = r.origin
    out.pop("provenance", None)
    return out


def describe(name: str, found: dict) -> str:
    if found["error"]:
        return f"{name}: cannot be rebuilt from its trials ({found['error']})"
    d, n = found["diff"], found["info"].n
    if matches(found):
        return f"{name}: matches its {n} trials" + (
            f" (the rebuild adds {', '.join(d['new'])})" if d["new"] else "")
    parts = []
    for what, paths in (("differs", d["differs"]), ("not in the rebuild", d["missing"])):
        if paths:
            parts.append(f"{what}: {', '.join(paths[:6])}"
                         + (f" and {len(paths) - 6} more" if len(paths) > 6 else ""))
    return f"{name}: DOES NOT MATCH its {n} trials; " + "; ".join(parts)


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="resummarize.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results-dir", type=existing_dir, default=ROOT / "docs" / "results",
                    help="folder of the result files (default docs/results)")
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--out", type=output_dir, default=None,
                       help="write every rebuilt summary to OUT/<name>.json")
    where.add_argument("--in-place", action="store_true",
                       help="write over the committed summaries that are from uncommitted code "
                            "or lack a field their trials give, while their trials are from "
                            "committed code (refused from a dirty tree)")
    ap.add_argument("--only", default=None, metavar="NAMES",
                    help="comma-separated summary file names (default: all)")
    ap.add_argument("--check", action="store_true",
                    help="exit 1 when a committed summary does not match its trials or "
                         "cannot be rebuilt from them")
    return ap


@guarded("resummarize.py")
def main(argv=None) -> int:
    from dopt.lab.provenance import code_state, provenance

    args = parser().parse_args(argv)
    argv = sys.argv[1:] if argv is None else list(argv)
    only = set(args.only.split(",")) if args.only else None
    if args.in_place and (problem := code_state().record_problem()):
        print(f"resummarize.py: error: --in-place: {problem}", file=sys.stderr)
        return 1
    mismatched, unbuilt, written = [], [], []
    for r in load_results(args.results_dir):
        if only is not None and r.name not in only:
            continue
        found = rebuild(args.results_dir, r)
        if found is None:
            continue
        print(describe(r.name, found))
        if found["error"]:
            unbuilt.append(r.name)
        elif not matches(found):
            mismatched.append(r.name)
        if found["fields"] is None:
            continue
        if args.in_place and (why := eligible(r, found)) is not None:
            if only is not None:
                print(f"  left alone: {why}")
            continue
        if args.out or args.in_place:
            summary = resummarized(r, found)
            summary["provenance"] = provenance(["experiments/resummarize.py", *argv])
            target = r.path if args.in_place else Path(args.out) / r.name
            atomic.write_text(target, jsonio.dumps(summary, indent=2))
            written.append(str(target))
    print(f"{len(mismatched)} summaries do not match their trials"
          + (f": {', '.join(mismatched)}" if mismatched else "")
          + (f"; {len(unbuilt)} cannot be rebuilt from them: {', '.join(unbuilt)}"
             if unbuilt else "")
          + (f"; wrote {len(written)} file(s)" if written else ""))
    return 1 if args.check and (mismatched or unbuilt) else 0
