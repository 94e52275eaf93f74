"""MPC sweeps in progress (RESULTS.md): committed trials of Table 1's protocol that no recorded
summary holds yet (a sweep stopped part-way, or episodes committed for dopt-view's replay),
counted per row and scene.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from dopt.lab.report.base import ReportError, Result, short_commit
from dopt.lab.report.trials import TrialInfo, machines_text, out_folder, record_stamp
from dopt.lab.trialpack import PackError, stored_trials
from planners.svr_mpc.episode import CONTROLS_FIELDS


def mpc_sweeps_in_progress_section(results_dir: Path, results: list[Result]) -> list[str]:
    """Per MPC sweep folder ``runs/<sweep>`` (Table 1, Fig. 4: not ``fig7-*``) with committed
    trials that no recorded summary's ``--out`` names: its trials counted per row (method,
    rho, theta) and scene, their commits and machines, and whether every trial keeps its start
    state and controls (``CONTROLS_FIELDS``, ``--keep-controls``: the folder replays in
    dopt-view). No costs: means, intervals and claims wait for the summary the sweep's
    command records."""
    named = {out_folder(results_dir, r.origin_command) for r in results}
    lines = []
    for folder in sorted(Path(results_dir).glob("runs/*")):
        if folder.name.startswith("fig7-") or folder in named or not folder.is_dir():
            continue
        try:
            files = stored_trials(folder / "trials")
            records = [json.loads(p.read_text()) for p in files]        # each read once
            params = [rec.get("params") or {} for rec in records]
        except (PackError, OSError, ValueError, AttributeError) as e:
            raise ReportError(f"{folder}: its trials cannot be read: {e}") from e
        if not files or not all(p.get("method") and "seed" in p for p in params):
            continue                                  # not an MPC sweep's trials
        rows: dict[tuple, set] = {}
        for p in params:
            rows.setdefault((p["method"], p.get("rho"), p.get("theta")), set()).add(p["seed"])
        scenes = sorted(len(s) for s in rows.values())
        seeds = sorted(set().union(*rows.values()))
        methods = Counter(method for method, _, _ in rows)
        stamps = [record_stamp(rec) for rec in records]
        info = TrialInfo(folder.name, files, machines=Counter(m for _, m in stamps))
        commits = Counter(c for c, _ in stamps)
        replayable = all(set(CONTROLS_FIELDS) <= set(rec.get("result") or {}) for rec in records)
        first = params[0]
        problem = "the authors' problem" if first.get("problem") == "authors" else "our problem"
        lines += ["", f"### `{folder.name}`: {first.get('task')}, {problem}",
                  "", f"{len(files)} trials over {len(rows)} rows (method, rho, theta: "
                  + ", ".join(f"{m} {n}" for m, n in sorted(methods.items()))
                  + f"), {scenes[0]}" + (f"-{scenes[-1]}" if scenes[-1] != scenes[0] else "")
                  + (" scene" if scenes[-1] == 1 else " scenes")
                  + (f" each (seed {seeds[0]})" if len(seeds) == 1
                     else f" each (seeds {seeds[0]}-{seeds[-1]})") + "; written at "
                  + ", ".join(f"`{short_commit(c)}` ({n})" for c, n in commits.most_common())
                  + f"; {machines_text(info)}."
                  + (f" Every trial keeps its start state and executed controls: `dopt-view "
                     f"docs/results/runs/{folder.name}` replays them." if replayable else "")]
    if not lines:
        return []
    return ["## MPC sweeps in progress", "",
            "Trials committed under `docs/results/runs/<sweep>/trials/` that no recorded "
            "summary holds yet (a sweep stopped part-way, or episodes kept for replay in "
            "dopt-view), counted per row and scene; costs, intervals and claims wait for the "
            "summary the sweep's command records (the same command resumes it).", *lines]
