"""Small numerical steps shared by parts of several tiers (the ramp reading, the diagnosis)."""

from __future__ import annotations

import numpy as np


def parabolic_argmin(grid: np.ndarray, values: np.ndarray) -> float:
    """Minimum of a sampled curve: the grid minimum refined by a parabola through its neighbours."""
    i = int(np.argmin(values))
    if i == 0 or i == grid.size - 1:
        return float(grid[i])
    x0, x1, x2 = grid[i - 1:i + 2]
    y0, y1, y2 = values[i - 1:i + 2]
    denom = (x0 - x1) * (x0 - x2) * (x1 - x2)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / denom
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / denom
    if a <= 0:
        return float(x1)
    return float(np.clip(-b / (2 * a), x0, x2))


def orthonormal_basis(a: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """An orthonormal basis of the columns of ``a`` (numerical rank: singular values above ``tol``
    of the largest): a design with a dead or repeated column still projects onto its span only."""
    if a.shape[1] == 0:
        return a
    q, sv, _ = np.linalg.svd(a, full_matrices=False)
    return q[:, sv > tol * max(sv[0], 1e-300)] if sv.size else q
