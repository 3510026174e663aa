"""How the compiled kernels take their array arguments: C-contiguous, of the kernel's dtype
(a copy only where the input is not already so)."""

from __future__ import annotations

import numpy as np


def f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def pair(a, name: str) -> np.ndarray:
    """Two float64 values (an origin, a spacing), or ValueError naming the argument."""
    arr = f64(a).ravel()
    if arr.shape[0] < 2:
        raise ValueError(f"{name} must hold 2 values")
    return arr
