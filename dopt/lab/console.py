"""The console of an experiment's sweep (``dopt.lab.sweep.run_sweep``), the same for every script:

- one line before the first trial: how many trials are reused, resumed from a checkpoint and
  run from the start (``SweepPlan.line``), and one after the last (``SweepResult.line``);
- a progress bar of the steps of every trial (CEM iterations, MPC steps), those of a process
  pool's and Ray's running trials included (their ``report``), starting at what the folder
  already holds; a trial that ends early (an MPC episode that succeeds) tops the bar up;
- log records and Python warnings printed above the bar, never on its line (tqdm's logging
  redirect; the pool's workers send theirs to this process, ``dopt.lab.sweep_pool``);
- an estimate of the run's time before the first trial (where the script gives each trial's
  ``seconds``), revised on each trial's ``finished`` line from the steps done so far, which
  also says the trial's result (the script's ``describe``).

``print_outputs`` is every script's last word: the paths of its pictures and the ``dopt-view``
command that opens its trials.

Also ``out_lock``: an experiment holds its --out folder's lock (``dopt.lab.sweep.OutLock``) for the
whole run, so that a second run on the same folder refuses at once, naming the first.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from dopt.lab.cli import guarded
from dopt.lab.sweep import OutLock, SweepPlan, SweepResult, Trial, run_sweep


def out_lock(out: Path) -> OutLock:
    """The lock of the folder ``out`` (a context manager; ``SweepLockedError`` on enter when
    another live process holds it)."""
    return OutLock(out)


@contextlib.contextmanager
def sweep_session(out: Path, verbose: bool):
    """What a sweep script holds while it runs: logging at INFO (``verbose``) or WARNING, the
    folder ``out`` made, and its lock (``out_lock``: a second run on it refuses at once)."""
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    out.mkdir(parents=True, exist_ok=True)
    with out_lock(out):
        yield


def sweep_main(script: str, parse: Callable, experiment: Callable) -> Callable:
    """A sweep script's ``main(argv=None) -> int``: ``parse(argv)`` its flags, then
    ``experiment(args, argv)`` inside its ``sweep_session`` (logging, OUT made and locked), all
    under ``guarded(script)`` (a failure is one line and an exit status)."""
    @guarded(script)
    def main(argv=None) -> int:
        args = parse(argv)
        with sweep_session(args.out, args.verbose):
            return experiment(args, argv)
    return main


@contextlib.contextmanager
def _warnings_logged():
    """Python warnings go through logging (and so above the bar) while the block runs."""
    logging.captureWarnings(True)
    try:
        yield
    finally:
        logging.captureWarnings(False)


def run_with_console(fn: Callable, trials: list[Trial], out: Path, *,
                     steps: Callable[[Trial], int], held: Callable[[Trial], int],
                     unit: str, desc: str,
                     seconds: Callable[[Trial], float] | None = None, basis: str = "",
                     describe: Callable[[dict], str] | None = None,
                     **sweep) -> SweepResult:
    """``run_sweep(fn, trials, out, **sweep)`` with the console of the module docstring.

    Args:
        steps: the steps of a whole trial (what the bar counts; 0 for a trial that reports
            none, such as the scripted policy).
        held: the steps of a trial the folder holds already (a finished trial's, a
            checkpoint's); not asked when ``sweep`` has ``fresh=True``.
        unit, desc: the bar's unit and label.
        seconds: the expected wall time of a whole trial (s); with it, the estimate line
            before the first trial (the steps left at that pace over the workers; ``basis``
            says where the pace comes from).
        describe: a finished trial's record -> its result in a few words, on its
            ``finished`` line.
    """
    from tqdm import tqdm
    from tqdm.contrib.logging import logging_redirect_tqdm

    whole = {t.key: int(steps(t)) for t in trials}
    start = {t.key: 0 if sweep.get("fresh") else int(held(t)) for t in trials}
    counted: Counter = Counter()
    began = time.perf_counter()
    finished, running = [0], []
    with tqdm(total=sum(whole.values()), initial=sum(start.values()), unit=unit,
              desc=desc) as bar, logging_redirect_tqdm(), _warnings_logged():
        def on_start(plan: SweepPlan) -> None:
            bar.write(f"sweep: {plan.line()}", file=sys.stderr)
            keys = set(plan.resumed) | set(plan.fresh)
            running.extend(t for t in trials if t.key in keys)
            if seconds is not None and running:
                bar.write(estimate_line(running, whole, start, seconds, basis,
                                        int(sweep.get("workers") or 1)), file=sys.stderr)

        def tick(key: str, n: int) -> None:
            counted[key] += n
            bar.update(n)

        def done(key: str, rec: dict | None) -> None:
            rest = whole[key] - start[key] - counted[key]
            if rec is not None and rest > 0:          # ended early, or reported no steps
                bar.update(rest)
            finished[0] += 1
            left = left_line(bar.n - bar.initial, bar.total - bar.n,
                             time.perf_counter() - began, unit)
            where = (f"{finished[0]}/{len(running) or len(trials)} trials run"
                     + (f"; {left}" if left else ""))
            if rec is None:
                bar.write(f"FAILED {key} ({where})")
                return
            said = ""
            if describe is not None:
                try:
                    said = f": {describe(rec)}"
                except (KeyError, TypeError, ValueError) as e:   # a console line, not the run
                    said = f": (no summary: {type(e).__name__} {e})"
            bar.write(f"finished {key}{said} ({where})")

        res = run_sweep(fn, trials, out, on_start=on_start, tick=tick, progress=done,
                        **sweep)
    print(f"sweep: {res.line()}", file=sys.stderr)
    return res


def duration(seconds: float) -> str:
    """A duration in words: seconds below 90 s, minutes below 90 min, else hours."""
    return f"{seconds:.0f} s" if seconds < 90 else (
        f"{seconds / 60:.0f} min" if seconds < 5400 else f"{seconds / 3600:.1f} h")


def estimate_line(trials: list[Trial], whole: dict, start: dict,
                  seconds: Callable[[Trial], float], basis: str, workers: int) -> str:
    """What the sweep's ``trials`` (those it runs) will take, said before the first: each
    one's ``seconds`` times the share of its ``whole`` steps not held at ``start``, over the
    workers (at most one per trial)."""
    total = sum(float(seconds(t)) * (1 - min(start[t.key], whole[t.key]) / whole[t.key]
                                     if whole[t.key] else 1.0) for t in trials)
    total /= max(1, min(workers, len(trials)))
    return (f"estimate: about {duration(total)} for {len(trials)} trials"
            + (f" at {basis}" if basis else "") + "; revised as trials finish")


def left_line(done: int, left: int, elapsed: float, unit: str) -> str:
    """The time left at this run's pace so far (``done`` steps in ``elapsed`` s), or "" before
    any step was counted."""
    if done <= 0 or elapsed <= 0:
        return ""
    if left <= 0:
        return "none left"
    return f"about {duration(left * elapsed / done)} left at {done / elapsed:.3g} {unit}/s"


def print_outputs(out: Path, pictures=(), view: Path | None = None,
                  viewer: bool = True) -> None:
    """A script's last lines: the paths of its ``pictures`` (names under ``out``, or paths)
    that exist, and (``viewer``: its trials are episodes dopt-view opens) the ``dopt-view``
    command that opens the trials of ``view`` (default ``out``), with the viewer's install
    line."""
    out = Path(out)
    found = [p for p in (out / name for name in pictures) if p.is_file()]
    if found:
        print("pictures: " + " ".join(str(p) for p in found))
    if viewer:
        print(f"replay its trials in the browser: dopt-view {view or out}   "
              f"(the viewer: pip install -e \".[viz]\")")


def print_captures(out: Path, captures: list[dict]) -> list[dict]:
    """One console line per blow-up capture of a run (``dopt.blowup.captures_of``); returns
    ``captures``, a summary's "blowups"."""
    for c in captures:
        print(f"blow-up capture {Path(out) / c['path']}: trial {c['trial']}, step {c['step']}"
              f", {c['reason']}, body {c['body']} (dopt-view opens it at that step)")
    return captures
