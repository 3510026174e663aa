"""The triangle pairs of a first contact between two placed bodies (``collision.vehicles.contact_centres``):
for each contact, every pair of triangles whose boxes come within a reach of each other, after each
side is shrunk to the box of the other's near triangles. The compiled kernel, and its numpy twin."""

from __future__ import annotations

import numpy as np

from tankcd_cli.collision._contact_pairs import near_triangle_pairs

__all__ = ["near_triangle_pairs", "near_triangle_pairs_numpy"]


def near_triangle_pairs_numpy(A: np.ndarray, B: np.ndarray, reach: float, rounds: int = 3):
    """``near_triangle_pairs`` in numpy (placed triangles (K, m, 3, 3) in; owner, ia, ib out): the
    compiled kernel's twin, which the tests hold it to."""
    alo, ahi, blo, bhi = A.min(axis=2), A.max(axis=2), B.min(axis=2), B.max(axis=2)
    owners, ias, ibs = [], [], []
    for i in range(len(alo)):
        al, ah, bl, bh = alo[i], ahi[i], blo[i], bhi[i]
        near_a, near_b = np.arange(len(al)), np.arange(len(bl))
        for _ in range(rounds):  # each side's triangles in the box of the other's near ones
            lo, hi = bl[near_b].min(axis=0, initial=np.inf), bh[near_b].max(axis=0, initial=-np.inf)
            near_a = near_a[((al[near_a] <= hi + reach) & (ah[near_a] >= lo - reach)).all(axis=1)]
            lo, hi = al[near_a].min(axis=0, initial=np.inf), ah[near_a].max(axis=0, initial=-np.inf)
            near_b = near_b[((bl[near_b] <= hi + reach) & (bh[near_b] >= lo - reach)).all(axis=1)]
        close = ((al[near_a, None] <= bh[None, near_b] + reach) & (ah[near_a, None] >= bl[None, near_b] - reach)).all(axis=2)
        a, b = np.nonzero(close)
        owners.append(np.full(len(a), i, dtype=np.int64))
        ias.append(near_a[a].astype(np.int64))
        ibs.append(near_b[b].astype(np.int64))
    if not owners:
        z = np.zeros(0, dtype=np.int64)
        return z, z.copy(), z.copy()
    return np.concatenate(owners), np.concatenate(ias), np.concatenate(ibs)
