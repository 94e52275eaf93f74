"""Rerun a sample of an MPC result's committed trials at today's code, and record whether each
gives its recorded outcome to the last bit.

A Table 1-protocol result is stale when a file that computes its trials changed since their
commit (``dopt.lab.report.stale.code_findings``), even where the change cannot alter them (a
new option off by default). A deterministic clock (``model``, ``authors``) makes a trial a pure
function of its params and the code, so rerunning some of them settles it: this script draws
``--sample`` of the result's trials (a seeded generator: the same draw every time), reruns each
with its stored params, and writes ``<results dir>/verified/<result>.json`` (``VERIFIED_DIR``):
the result, HEAD's commit, per trial its key, recorded and rerun MPC cost and whether the whole
record's outcome (cost, |C| per optimisation, steps held) is the same, and provenance. The
report then treats the result as current while no file that computes trials changed since that
commit and every rerun matched. Trials on a host-dependent clock (``real``, ``virtual``) cannot
be verified so: refused. Only from committed code (the file is a result).

    python experiments/verify_trials.py docs/results/table1-clutter-authors-executor.json \\
        --sample 10

Exits 1 when a rerun differs (the file says which), 2 on a bad flag.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

from dopt.lab.cli import EPILOG, ArgumentParser, guarded, positive_int
from dopt.lab.record import write_summary
from dopt.lab.report.base import Result
from dopt.lab.report.trials import summary_trials
from planners.svr_mpc import run_trial

#: where the verifications lie under the results folder
VERIFIED_DIR = "verified"
#: the clocks whose trials are a function of their params and the code alone
DETERMINISTIC_CLOCKS = ("model", "authors")
#: the outcome fields a rerun must reproduce
OUTCOME = ("mpc_cost", "n_dofs", "held_steps", "steps")


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="verify_trials.py", description=__doc__, epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("result", type=Path, help="a result file under docs/results (an MPC "
                    "experiment's summary whose trials are committed)")
    ap.add_argument("--sample", type=positive_int, default=10,
                    help="trials to rerun (default %(default)s; all when fewer)")
    ap.add_argument("--seed", type=int, default=0, help="the draw's seed (default 0)")
    return ap


def sample_trials(files: list, n: int, seed: int) -> list[dict]:
    """``n`` of the trial records in ``files`` (loose or packed, ``dopt.lab.trialpack``; sorted by
    key first, so the draw does not depend on the file system), drawn without replacement by a
    seeded generator."""
    records = sorted((json.loads(p.read_text()) for p in files), key=lambda r: r["key"])
    pick = np.random.default_rng(seed).choice(len(records), size=min(n, len(records)),
                                              replace=False)
    return [records[i] for i in sorted(pick)]


def verify(record: dict) -> dict:
    """Rerun one stored trial: {"key", "recorded_cost", "rerun_cost", "equal"}."""
    got = run_trial(record["params"])
    want = record["result"]
    equal = all(got.get(f) == want.get(f) for f in OUTCOME if f in want)
    return {"key": record["key"], "recorded_cost": want["mpc_cost"],
            "rerun_cost": got["mpc_cost"], "equal": bool(equal)}


@guarded("verify_trials.py")
def main(argv=None) -> int:
    ap = parser()
    args = ap.parse_args(argv)
    path = args.result
    if not path.is_file():
        ap.error(f"no result file {path}")
    r = Result(path, json.loads(path.read_text()))
    info = summary_trials(path.parent, r)
    if info is None:
        ap.error(f"{path.name}: no committed trials found for it")
    chosen = sample_trials(list(info.files), args.sample, args.seed)
    clocks = {t["params"].get("clock") for t in chosen}
    if not clocks <= set(DETERMINISTIC_CLOCKS):
        ap.error(f"{path.name}: trials on the {', '.join(sorted(clocks))} clock depend on the "
                 f"host; only {', '.join(DETERMINISTIC_CLOCKS)} trials can be verified")
    rows = []
    for t in chosen:
        rows.append(verify(t))
        print(f"{'same' if rows[-1]['equal'] else 'DIFFERS'} {t['key']}", flush=True)
    out = path.parent / VERIFIED_DIR / path.name
    out.parent.mkdir(exist_ok=True)
    summary = {"experiment": "verify_trials", "result": path.name, "sample": len(rows),
               "seed": args.seed, "trials": rows, "all_equal": all(x["equal"] for x in rows)}
    with tempfile.TemporaryDirectory() as scratch:        # write_summary's OUT/summary.json
        write_summary(summary, Path(scratch), out, "experiments/verify_trials.py", argv)
    print(f"{sum(x['equal'] for x in rows)} of {len(rows)} reruns give the recorded outcome; "
          f"wrote {out}")
    return 0 if summary["all_equal"] else 1
