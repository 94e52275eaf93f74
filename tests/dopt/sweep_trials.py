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
