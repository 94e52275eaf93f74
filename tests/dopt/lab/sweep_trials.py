"""Trial functions for the sweep tests (importable by pool and Ray workers)."""

import os
import time


def square(params):
    """Records each call in params['calls'] (a folder), sleeps, returns x^2."""
    if params.get("calls"):
        with open(os.path.join(params["calls"], f"{params['x']}-{os.getpid()}-{time.time()}"),
                  "w"):
            pass
    time.sleep(params.get("sleep", 0.0))
    if params["x"] < 0:
        raise ValueError("negative")
    return {"y": params["x"] ** 2, "pid": os.getpid()}


def count(params, checkpoint=None):
    """Counts to params['n'], saving {"i", "runs"} to its checkpoint after each step; raises
    once i reaches params['stop_at'] (a run killed there). Returns the count, the runs it
    took and the process id."""
    progress = checkpoint.load() if checkpoint is not None else None
    i = progress["i"] if progress else 0
    runs = (progress["runs"] if progress else 0) + 1
    while i < params["n"]:
        i += 1
        if checkpoint is not None:
            checkpoint.save({"i": i, "runs": runs})
        if i == params.get("stop_at"):
            raise RuntimeError(f"killed at {i}")
    return {"i": i, "runs": runs, "pid": os.getpid()}


def walk(params, checkpoint=None, report=None):
    """A chaotic walk, x <- 3.99 x (1 - x) from params['x0'], of params['n'] steps of
    params['sleep'] seconds each, saving {"i", "x"} to its checkpoint and reporting each step.
    Its result depends on every bit of every step: a resumed run that lost or rounded anything
    ends elsewhere."""
    progress = checkpoint.load() if checkpoint is not None else None
    i, x = (progress["i"], progress["x"]) if progress else (0, float(params["x0"]))
    while i < params["n"]:
        time.sleep(params.get("sleep", 0.0))
        x = 3.99 * x * (1.0 - x)
        i += 1
        if checkpoint is not None:
            checkpoint.save({"i": i, "x": x})
        if report is not None:
            report()
    return {"x": x, "i": i, "nan": float("nan"), "inf": [1.0, float("inf")]}


def warn(params):
    """Logs a warning and issues a Python warning, then returns {"ok": True}."""
    import logging
    import warnings
    logging.getLogger("tests.sweep_trials").warning("warned by trial %s", params["x"])
    warnings.warn(f"python warning of trial {params['x']}", UserWarning, stacklevel=1)
    return {"ok": True}


def linger(params, checkpoint=None):
    """Marks its start (an empty file <params['calls']>/<key>-<pid>), then counts to
    params['n'], params['sleep'] s a step, saving {"i"} to its checkpoint after each. At step
    params['die_at'] its process dies: killed by the signal params['signal'], or exiting with
    params['exit']. Returns {"i", "pid"}."""
    open(os.path.join(params["calls"], f"{params['key']}-{os.getpid()}"), "w").close()
    progress = checkpoint.load() if checkpoint is not None else None
    i = progress["i"] if progress else 0
    while i < params["n"]:
        time.sleep(params.get("sleep", 0.0))
        i += 1
        if checkpoint is not None:
            checkpoint.save({"i": i})
        if i == params.get("die_at"):
            if params.get("signal"):
                os.kill(os.getpid(), params["signal"])
                time.sleep(10)                   # (the signal lands first)
            os._exit(params.get("exit", 1))
    return {"i": i, "pid": os.getpid()}


def lock_workers(params):
    """The pid of its process and the worker pids its sweep's lock file (params['lock'])
    names."""
    import json
    with open(params["lock"]) as f:
        held = json.load(f)
    return {"pid": os.getpid(), "workers": held.get("workers"), "holder": held["pid"]}
