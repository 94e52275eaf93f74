"""The console of an experiment's sweep (``dopt.sweep.run_sweep``), the same for every script:

- one line before the first trial: how many trials are reused, resumed from a checkpoint and
  run from the start (``SweepPlan.line``), and one after the last (``SweepResult.line``);
- a progress bar of the steps of every trial (CEM iterations, MPC steps), those of a process
  pool's and Ray's running trials included (their ``report``), starting at what the folder
  already holds; a trial that ends early (an MPC episode that succeeds) tops the bar up;
- log records and Python warnings printed above the bar, never on its line (tqdm's logging
  redirect; the pool's workers send theirs to this process, ``dopt.sweep_pool``).

Also ``out_lock``: an experiment holds its --out folder's lock (``dopt.sweep.OutLock``) for the
whole run, so that a second run on the same folder refuses at once, naming the first.
"""

from __future__ import annotations

import contextlib
import logging
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from dopt.sweep import OutLock, SweepPlan, SweepResult, Trial, run_sweep


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
                     unit: str, desc: str, **sweep) -> SweepResult:
    """``run_sweep(fn, trials, out, **sweep)`` with the console of the module docstring.

    Args:
        steps: the steps of a whole trial (what the bar counts; 0 for a trial that reports
            none, such as the scripted policy).
        held: the steps of a trial the folder holds already (a finished trial's, a
            checkpoint's); not asked when ``sweep`` has ``fresh=True``.
        unit, desc: the bar's unit and label.
    """
    from tqdm import tqdm
    from tqdm.contrib.logging import logging_redirect_tqdm

    whole = {t.key: int(steps(t)) for t in trials}
    start = {t.key: 0 if sweep.get("fresh") else int(held(t)) for t in trials}
    counted: Counter = Counter()
    with tqdm(total=sum(whole.values()), initial=sum(start.values()), unit=unit,
              desc=desc) as bar, logging_redirect_tqdm(), _warnings_logged():
        def on_start(plan: SweepPlan) -> None:
            bar.write(f"sweep: {plan.line()}", file=sys.stderr)

        def tick(key: str, n: int) -> None:
            counted[key] += n
            bar.update(n)

        def done(key: str, rec: dict | None) -> None:
            rest = whole[key] - start[key] - counted[key]
            if rec is not None and rest > 0:          # ended early, or reported no steps
                bar.update(rest)
            bar.write(f"finished {key}" if rec is not None else f"FAILED {key}")

        res = run_sweep(fn, trials, out, on_start=on_start, tick=tick, progress=done,
                        **sweep)
    print(f"sweep: {res.line()}", file=sys.stderr)
    return res
