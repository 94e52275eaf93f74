"""Resumable trial sweeps on a local process pool or a Ray cluster.

A trial is a pure function of its parameters (a JSON-able dict) that builds everything it needs
and returns a JSON-able dict. Each finished trial is written at once to ``OUT/trials/<key>.json``
(atomically), so a killed sweep loses only the trials that were running, and a rerun skips every
trial whose file exists. The same code runs inline (``workers=1``), on a local process pool, or
on Ray (``ray_address``: "local" starts a local instance, anything else is passed to
``ray.init``), so a sweep of thousands of trials goes to many machines without code changes.
"""

from __future__ import annotations

import json
import logging
import os
import sys
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Trial:
    """key: unique file-name stem; params: the JSON-able arguments of the trial function."""

    key: str
    params: dict

    def __post_init__(self):
        if not self.key or any(ch in self.key for ch in "/\\\0") or self.key.startswith("."):
            raise ValueError(f"trial key {self.key!r} is not a valid file name")


@dataclass(frozen=True)
class SweepResult:
    """records: {key: {"key", "params", "result"}} of every finished trial (old and new);
    ran: keys run in this call; skipped: keys found finished; failed: {key: error message}."""

    records: dict
    ran: list
    skipped: list
    failed: dict


def trial_path(out_dir: Path | str, key: str) -> Path:
    return Path(out_dir) / "trials" / f"{key}.json"


def load_finished(out_dir: Path | str) -> dict:
    """{key: record} of every trial file under OUT/trials."""
    folder = Path(out_dir) / "trials"
    if not folder.is_dir():
        return {}
    out = {}
    for path in sorted(folder.glob("*.json")):
        with open(path) as f:
            rec = json.load(f)
        out[rec["key"]] = rec
    return out


def run_sweep(fn: Callable[[dict], dict], trials: Sequence[Trial], out_dir: Path | str, *,
              workers: int = 1, ray_address: str | None = None,
              progress: Callable[[str, dict | None], None] | None = None) -> SweepResult:
    """Run the trials not yet finished under ``out_dir``.

    Args:
        fn: module-level function params -> JSON-able dict (picklable by reference).
        trials: the sweep; keys must be unique.
        out_dir: results folder; OUT/trials/<key>.json per finished trial.
        workers: processes of the local pool (1: run inline in this process).
        ray_address: run on Ray instead ("local" for a local instance).
        progress: called with (key, record or None on failure) as each trial ends.
    """
    keys = [t.key for t in trials]
    if len(set(keys)) != len(keys):
        raise ValueError("trial keys must be unique")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    (Path(out_dir) / "trials").mkdir(parents=True, exist_ok=True)
    done = load_finished(out_dir)
    todo = [t for t in trials if t.key not in done]
    skipped = [t.key for t in trials if t.key in done]
    log.info("sweep: %d trials, %d already finished, %d to run", len(trials), len(skipped),
             len(todo))
    records = {k: done[k] for k in skipped}
    failed: dict = {}

    def finish(trial: Trial, result=None, error: BaseException | None = None):
        if error is not None:
            failed[trial.key] = f"{type(error).__name__}: {error}"
            log.error("trial %s failed: %s", trial.key, failed[trial.key])
            rec = None
        else:
            rec = {"key": trial.key, "params": trial.params, "result": result}
            _write_json_atomic(trial_path(out_dir, trial.key), rec)
            records[trial.key] = rec
        if progress is not None:
            progress(trial.key, rec)

    if ray_address is not None:
        _run_ray(fn, todo, ray_address, finish)
    elif workers == 1:
        for t in todo:
            try:
                result = fn(t.params)
            except Exception as e:  # recorded, the sweep goes on
                finish(t, error=e)
            else:
                finish(t, result)
    else:
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            futures = {pool.submit(fn, t.params): t for t in todo}
            for fut in as_completed(futures):
                err = fut.exception()
                finish(futures[fut], None if err else fut.result(), err)
    return SweepResult(records, [t.key for t in todo if t.key not in failed], skipped, failed)


def _run_ray(fn, todo, address, finish) -> None:
    import ray
    if not ray.is_initialized():
        if address == "local":
            ray.init(include_dashboard=False, log_to_driver=False)
        else:
            ray.init(address=address, log_to_driver=False)
    module = sys.modules[fn.__module__]
    if getattr(module, "__file__", None) and "site-packages" not in module.__file__:
        # the trial module lives in a script folder, not an installed package: ship it by value
        ray.cloudpickle.register_pickle_by_value(module)
    remote = ray.remote(fn)
    pending = {remote.remote(t.params): t for t in todo}
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        trial = pending.pop(ready[0])
        try:
            finish(trial, ray.get(ready[0]))
        except Exception as e:
            finish(trial, error=e)


def _write_json_atomic(path: Path, obj) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".json")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(obj, f)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
