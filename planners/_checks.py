"""Input checks shared by the planners: particle index arrays and a task's picker bound.

Scalars, config fields and float arrays use ``dopt.validation``. Every check raises TypeError
(wrong type or dtype) or ValueError (wrong value or shape) with a message that starts with the
name of the argument.
"""

from __future__ import annotations

import numpy as np
import torch

from dopt.validation import is_int


def particle_indices(x, name: str, n_particles: int | None = None, *,
                     distinct: bool = False) -> np.ndarray:
    """(C,) int64 particle indices: 1-D, non-empty, integers (floats, even 3.0, and bools raise
    TypeError), >= 0, < ``n_particles`` when given, and ``distinct`` if asked."""
    try:
        arr = np.asarray(x.detach().cpu() if torch.is_tensor(x) else x)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name} must be a 1-D array of particle indices: {e}") from None
    if arr.dtype == object and arr.size and all(is_int(v) for v in arr.ravel()):
        arr = arr.astype(np.int64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D particle indices, got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty: give at least one particle")
    if arr.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integer particle indices, got dtype {arr.dtype} "
                        f"({arr[:5].tolist()})")
    arr = arr.astype(np.int64)
    if distinct and len(np.unique(arr)) != len(arr):
        raise ValueError(f"{name} has repeated particles: {arr.tolist()}")
    if (arr < 0).any():
        raise ValueError(f"{name} must be particle indices >= 0, got {arr.tolist()}")
    if n_particles is not None and (arr >= n_particles).any():
        raise ValueError(f"{name} must be particle indices < {n_particles} (the task's "
                         f"particles), got {arr[arr >= n_particles].tolist()}")
    return arr


def picker_bound(bound, name: str = "task.bound") -> np.ndarray:
    """A task's bound as a (3,) float64 array of finite non-negative metres (one number is
    used on every axis)."""
    try:
        arr = np.asarray(bound)
    except (TypeError, ValueError):
        arr = np.asarray(None)
    if arr.dtype.kind not in "fiu":                  # None, bools, strings, ragged lists
        raise TypeError(f"{name} must be (3,) metres, got {bound!r}")
    arr = arr.astype(float)
    if arr.shape not in ((), (3,)):
        raise ValueError(f"{name} must be (3,) metres (or one number), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must be finite and >= 0, got {arr.tolist()}")
    return np.broadcast_to(arr, (3,)).copy()
