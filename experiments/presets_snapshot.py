"""Write what every named preset resolves to, for experiments/report.py's stale check.

experiments/report.py runs on the standard library alone, and the presets live in code that
needs torch and MuJoCo; so this script writes ``<results dir>/presets/resolved.json``
(``report_stale.SNAPSHOT``) and the report compares each result's recorded settings with it
(``report_stale``). A test fails while the file is not what today's code gives, so a changed
preset shows up as a failing test and then, once the file is rewritten, as "stale" next to
every result recorded on the old fields.

The file holds:

- "pick": the pick-and-place presets today: "physics" {cloth, rope: {name: every field of
  ``ClothSceneConfig.preset(name)`` / ``RopeSceneConfig.preset(name)``}}, "protocols"
  {protocol: {"task/goal": ``PickPlaceSettings.preset(...).to_dict()`` less the threads}},
  "resolved" {protocol: {"task/goal": ``resolved_physics()``: scene, picker, stability}};
- "svr_mpc": {"ours", "paper", "authors": {task: every field of ``SVRMPCSettings()`` /
  ``.paper(task)`` / ``.authors(task)``}} (authors on clutter needs the authors' scenes: an
  "error" entry);
- "at_commit": {commit: {"pick": "physics" and "protocols" as above}} at the commits of the
  results that record only preset names (``report_stale.needs_backfill``): read from that
  commit's code, extracted by ``git archive`` into a temporary folder and imported there in a
  child process (nothing in this checkout changes). A commit already in the file is kept
  (``--refresh`` reads them all again).

    python experiments/presets_snapshot.py            # write the file
    python experiments/presets_snapshot.py --check    # exit 1 if it is not current
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from report_base import ROOT, load_results
from report_stale import SNAPSHOT, base_commit, needs_backfill

from dopt import atomic
from dopt.lab.cli import EPILOG, ArgumentParser, existing_dir, guarded

#: resolves the pick-and-place presets of the code it is run in (this checkout, or a commit's
#: code extracted elsewhere): prints {"physics", "protocols", "resolved"} as JSON
PICK_RESOLVER = r'''
import json
from dataclasses import asdict

out = {}
try:
    from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS as C, ClothSceneConfig
    from dopt.tasks.pick.rope_scene import PHYSICS_PRESETS as R, RopeSceneConfig
    out["physics"] = {"cloth": {n: asdict(ClothSceneConfig.preset(n)) for n in C},
                      "rope": {n: asdict(RopeSceneConfig.preset(n)) for n in R}}
except Exception as e:
    out["physics"] = {"error": f"{type(e).__name__}: {e}"}
try:
    import planners.pick_place as pp
    protocols = list(getattr(pp, "PROTOCOLS", {"ours": None}))
    out["protocols"], out["resolved"] = {}, {}
    for p in protocols:
        for task, goals in pp.GOALS.items():
            for goal in goals:
                s = (pp.PickPlaceSettings.preset(task, goal) if p == "ours"
                     else pp.PickPlaceSettings.preset(task, goal, protocol=p))
                d = s.to_dict()
                d.pop("threads", None)
                out["protocols"].setdefault(p, {})[f"{task}/{goal}"] = d
                if hasattr(s, "resolved_physics"):
                    out["resolved"].setdefault(p, {})[f"{task}/{goal}"] = s.resolved_physics()
except Exception as e:
    out["protocols"] = {"error": f"{type(e).__name__}: {e}"}
print(json.dumps(out, default=str))
'''


def svr_presets() -> dict:
    """{"ours", "paper", "authors": {task: every SVRMPCSettings field}} of today's code."""
    from dataclasses import asdict, replace

    from dopt.tasks import PUSH_TASKS
    from planners.svr_mpc import SVRMPCSettings

    out: dict = {"ours": {}, "paper": {}, "authors": {}}
    for task in PUSH_TASKS:
        for name, make in (("ours", lambda t: replace(SVRMPCSettings(), task=t)),
                           ("paper", SVRMPCSettings.paper), ("authors", SVRMPCSettings.authors)):
            try:
                out[name][task] = asdict(make(task))
            except (ValueError, TypeError) as e:
                out[name][task] = {"error": f"{type(e).__name__}: {e}"}
    return out


def pick_presets(code_root: Path | None = None) -> dict:
    """``PICK_RESOLVER``'s answer for the code under ``code_root`` (None: this checkout), in
    a child process with that folder first on the path."""
    root = Path(code_root or ROOT)
    env = {**os.environ, "PYTHONPATH": str(root), "MUJOCO_GL": "egl"}
    proc = subprocess.run([sys.executable, "-c", PICK_RESOLVER], cwd=root, env=env,
                          capture_output=True, text=True, timeout=600)
    if proc.returncode != 0:
        raise RuntimeError(f"resolving the presets under {root} failed: "
                           f"{proc.stderr.strip().splitlines()[-1:]}")
    return json.loads(proc.stdout)


def at_commit(commit: str) -> dict:
    """The pick-and-place presets of ``commit``'s code (``git archive`` of its packages into
    a temporary folder; the checkout is not touched)."""
    with tempfile.TemporaryDirectory() as tmp:
        archive = Path(tmp) / "code.tar"
        with open(archive, "wb") as f:
            proc = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", commit,
                                   "dopt", "planners", "deformables"], stdout=f,
                                  stderr=subprocess.PIPE, timeout=300)
        if proc.returncode != 0:
            raise RuntimeError(f"git archive {commit}: {proc.stderr.decode().strip()}")
        code = Path(tmp) / "code"
        with tarfile.open(archive) as t:
            t.extractall(code, filter="data")
        pick = pick_presets(code)
    return {"pick": {k: v for k, v in pick.items() if k in ("physics", "protocols")}}


def snapshot(results_dir: Path, old: dict | None, refresh: bool = False) -> dict:
    """The file's contents: today's presets, and the presets at every commit whose results
    need them (kept from ``old`` unless ``refresh``)."""
    commits = sorted({c for r in load_results(results_dir) if needs_backfill(r)
                      and (c := base_commit(r.origin.get("git_commit")))})
    kept = {} if refresh else dict((old or {}).get("at_commit") or {})
    return {"generated_by": "python experiments/presets_snapshot.py",
            "pick": pick_presets(), "svr_mpc": svr_presets(),
            "at_commit": {c: kept[c] if c in kept else at_commit(c) for c in commits}}


def text_of(data: dict) -> str:
    return json.dumps(data, indent=1, sort_keys=True) + "\n"


def parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(prog="presets_snapshot.py", description=__doc__,
                        epilog=EPILOG,
                        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--results-dir", type=existing_dir, default=ROOT / "docs" / "results",
                    help="folder of the result files (default docs/results)")
    ap.add_argument("--check", action="store_true",
                    help="write nothing; exit 1 if the file is not what this code gives")
    ap.add_argument("--refresh", action="store_true",
                    help="read the presets at every result's commit again")
    return ap


@guarded("presets_snapshot.py")
def main(argv=None) -> int:
    args = parser().parse_args(argv)
    path = Path(args.results_dir) / SNAPSHOT
    old = json.loads(path.read_text()) if path.is_file() else None
    text = text_of(snapshot(args.results_dir, old, args.refresh))
    current = path.is_file() and path.read_text() == text
    if args.check:
        print(f"{path}: " + ("up to date" if current else
                             "differs from today's presets; run "
                             "`python experiments/presets_snapshot.py`"),
              file=sys.stdout if current else sys.stderr)
        return 0 if current else 1
    if not current:
        atomic.write_text(path, text)
    print(f"{'wrote' if not current else 'up to date:'} {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
