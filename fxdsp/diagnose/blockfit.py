"""Least squares with time-blocked cross-validation, done on per-segment normal equations.

The log is cut into contiguous segments; fold f holds out the segments s with s % n_folds == f, so
each held-out fold is a set of contiguous stretches spread over the whole chamber programme (the
polynomials in temperature then interpolate rather than extrapolate, and slow effects such as
warm-up are seen in both the training and the held-out data). Keeping X^T X, X^T y and y^T y per
segment makes every fold fit, every held-out error and every delete-a-segment jackknife a p x p
solve, so a nonlinear parameter can be searched on a grid with the fold fits nested inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from fxdsp.errors import InputError


@dataclass(frozen=True)
class Blocks:
    """Segment boundaries (row indices) and the fold of each segment."""

    edges: np.ndarray  # n_segments + 1 row indices
    fold: np.ndarray  # fold of each segment
    n_folds: int

    n_groups: int = 20  # jackknife groups: runs of consecutive segments

    @classmethod
    def contiguous(cls, n_rows: int, n_segments: int = 200, n_folds: int = 5, n_groups: int = 20,
                   breaks=None) -> "Blocks":
        """Segments of about n_rows / n_segments rows, also cut at ``breaks`` (row indices).

        Short segments spread every chamber phase (a dwell, a ramp) over all folds, so a held-out
        stretch is always bracketed by training data at its temperature. Cutting at every rate
        step puts the steps of one rate table into different folds: a held-out +200 deg/s step is
        predicted from the -200 and +100 deg/s steps at the same temperature, not from S(T)
        interpolated between tables, whose error a spurious cubic term would then absorb.
        """
        n_segments = int(max(n_folds, min(n_segments, n_rows // 20)))
        edges = np.linspace(0, n_rows, n_segments + 1).round().astype(int)
        if breaks is not None and len(breaks):
            edges = np.union1d(edges, np.asarray(breaks, dtype=int))
            edges = edges[(edges >= 0) & (edges <= n_rows)]
        n_segments = edges.size - 1
        return cls(edges=edges, fold=np.arange(n_segments) % n_folds, n_folds=n_folds,
                   n_groups=int(min(n_groups, n_segments)))

    def group(self) -> np.ndarray:
        """Jackknife group of each segment: n_groups runs of consecutive rows. The groups are long
        (1/20 of the log) so that correlated noise stays inside a group."""
        return np.minimum((self.edges[:-1] * self.n_groups) // max(self.edges[-1], 1), self.n_groups - 1)

    @property
    def n_segments(self) -> int:
        return self.fold.size

    def row_fold(self) -> np.ndarray:
        return np.repeat(self.fold, np.diff(self.edges))

    def row_group(self) -> np.ndarray:
        """Jackknife group of each row."""
        return np.repeat(self.group(), np.diff(self.edges))


class FoldTargets:
    """Many series fitted with one design after another (the draws of a noise null, [n, k]), their
    rows put in fold order once: each design's per-fold normals are then one matmul per fold over
    contiguous rows, and y^T y per fold is computed once for every design (a matmul per segment over
    hundreds of segments, and the draws copied in each design's fold order, were most of a null)."""

    def __init__(self, target: np.ndarray, blocks: Blocks):
        row_fold = blocks.row_fold()
        self.blocks = blocks
        self.order = np.argsort(row_fold, kind="stable")
        self.edges = np.concatenate([[0], np.cumsum(np.bincount(row_fold, minlength=blocks.n_folds))])
        self.rows = np.ascontiguousarray(np.asarray(target, dtype=float)[self.order])
        self.yty = np.stack([np.einsum("ij,ij->j", self.rows[a:b], self.rows[a:b]) for a, b in self.spans()])

    def spans(self) -> list[tuple[int, int]]:
        return list(zip(self.edges[:-1], self.edges[1:]))


class SegmentNormals:
    """Per-segment X^T X, X^T y, y^T y of a design (columns scaled to unit rms for conditioning).

    ``target`` is one series [n], or several sharing the design as :class:`FoldTargets` (the draws of a
    noise null): the sums are then kept per fold, and only ``folds`` may be asked, each error per
    fold and target [folds, k]."""

    def __init__(self, design: np.ndarray, target, blocks: Blocks, weight: float = 1.0):
        design = np.asarray(design, dtype=float)
        rms = np.sqrt(np.mean(design * design, axis=0))
        self.alive = rms > 0  # an all-zero column (e.g. no ramp yet) carries no information
        self.scale = np.where(self.alive, rms, 1.0)
        xs = design[:, self.alive] / self.scale[self.alive]
        self.p = xs.shape[1]
        self.weight = float(weight)  # 1/noise variance: makes channels comparable
        self.blocks = blocks
        self.per_fold = isinstance(target, FoldTargets)
        if self.per_fold:
            if target.blocks is not blocks:
                raise TypeError("target: FoldTargets ordered for other blocks")
            self._fold_sums(xs, target)
            return
        # per-segment sums: outer products per row would be n*p*p memory, and a matmul per segment a
        # Python loop over hundreds of segments; each of the p(p+1)/2 column products is summed per
        # segment in one reduceat instead (the same sums)
        s = blocks.n_segments
        starts = blocks.edges[:-1]
        self.xtx = np.empty((s, self.p, self.p))
        for i in range(self.p):
            for j in range(i, self.p):
                self.xtx[:, i, j] = self.xtx[:, j, i] = np.add.reduceat(xs[:, i] * xs[:, j], starts)
        target = np.asarray(target, dtype=float)
        if target.ndim != 1:
            raise TypeError("target: one series, or several as FoldTargets")
        self.xty = np.add.reduceat(xs * target[:, None], starts, axis=0)                  # [segments, p]
        self.yty = np.add.reduceat(target * target, starts, axis=0)
        self.counts = np.diff(blocks.edges)
        self.tot = (self.xtx.sum(0), self.xty.sum(0), self.yty.sum(0))

    def _fold_sums(self, xs: np.ndarray, targets: FoldTargets) -> None:
        """The sums per fold (xtx [folds, p, p], xty [folds, p, k], yty [folds, k]) in place of per segment."""
        xo = xs[targets.order]
        spans = targets.spans()
        self.xtx = np.stack([xo[a:b].T @ xo[a:b] for a, b in spans])
        self.xty = np.stack([xo[a:b].T @ targets.rows[a:b] for a, b in spans])
        self.yty = targets.yty
        self.counts = np.diff(targets.edges)
        self.tot = (self.xtx.sum(0), self.xty.sum(0), self.yty.sum(0))

    def _per_segment(self, what: str) -> None:
        if self.per_fold:   # a caller's mistake, not the user's input
            raise TypeError(f"{what}: normals of FoldTargets are kept per fold; only folds() is available")

    # -- solving -----------------------------------------------------------------------------
    def _solve(self, xtx: np.ndarray, xty: np.ndarray) -> np.ndarray:
        """The ridge-stabilised solution of each of a stack of systems (xtx [s, p, p], xty [s, p], or
        [s, p, k] for k targets) in one call; a singular one by least squares."""
        ridge = 1e-10 * np.maximum(np.trace(xtx, axis1=1, axis2=2) / max(self.p, 1), 1e-300)
        one = xty.ndim == 2
        rhs = xty[..., None] if one else xty
        try:
            beta = np.linalg.solve(xtx + ridge[:, None, None] * np.eye(self.p), rhs)
        except np.linalg.LinAlgError:
            beta = np.array([np.linalg.lstsq(a, b, rcond=None)[0] for a, b in zip(xtx, rhs)])
        return beta[..., 0] if one else beta

    @staticmethod
    def _sse(beta, xtx, xty, yty) -> np.ndarray:
        """The residual sum of squares of each of a stack (beta [s, p], or [s, p, k]: [s, k])."""
        quad = np.einsum("si...,sij,sj...->s...", beta, xtx, beta)
        return np.maximum(yty - 2.0 * np.einsum("si...,si...->s...", beta, xty) + quad, 0.0)

    def _sums_by(self, group: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-group sums of the segments' normals (group: one label 0..s-1 per segment)."""
        member = (np.asarray(group)[None, :] == np.arange(s)[:, None]).astype(float)   # [s, segments]
        n = self.xtx.shape[0]
        return ((member @ self.xtx.reshape(n, -1)).reshape(s, self.p, self.p), np.tensordot(member, self.xty, axes=1),
                np.tensordot(member, self.yty, axes=1))

    def coefficients(self, beta_scaled: np.ndarray) -> np.ndarray:
        """Coefficients of the unscaled design columns (dead columns get 0), of one fit or a stack."""
        out = np.zeros(beta_scaled.shape[:-1] + self.alive.shape)
        out[..., self.alive] = beta_scaled / self.scale[self.alive]
        return out

    def fit_all(self) -> tuple[np.ndarray, float]:
        tot = tuple(np.asarray(a)[None] for a in self.tot)
        beta = self._solve(tot[0], tot[1])
        return self.coefficients(beta[0]), float(self._sse(beta, *tot)[0])

    def _left_out(self, group: np.ndarray, s: int):
        """(the sums without each group, the group's own sums, the fits without it)."""
        h = self._sums_by(group, s)
        t = (self.tot[0] - h[0], self.tot[1] - h[1], self.tot[2] - h[2])
        return t, h, self._solve(t[0], t[1])

    def folds(self) -> tuple[np.ndarray, np.ndarray]:
        """(training SSE, held-out SSE) per fold, both weighted."""
        fold = np.arange(self.blocks.n_folds) if self.per_fold else self.blocks.fold   # per fold already: each its own
        t, h, beta = self._left_out(fold, self.blocks.n_folds)
        return self._sse(beta, *t) * self.weight, self._sse(beta, *h) * self.weight

    def jackknife(self, by: str = "group") -> tuple[np.ndarray, np.ndarray]:
        """Delete-one-group fits: (coefficients [n_groups, p_all], training SSE [n_groups]); with
        ``by="fold"`` the groups are the cross-validation folds (interleaved, not contiguous)."""
        self._per_segment("jackknife")
        if by == "fold":
            group, s = self.blocks.fold, self.blocks.n_folds
        elif by == "group":
            group, s = self.blocks.group(), self.blocks.n_groups
        else:
            raise InputError(f"by: expected 'group' or 'fold', got {by!r}")
        t, _, beta = self._left_out(group, s)
        return self.coefficients(beta), self._sse(beta, *t) * self.weight

    def heldout_rows(self, design: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Held-out residual of every row (each row predicted by the fit without its fold)."""
        self._per_segment("heldout_rows")
        resid = np.empty(target.size)
        row_fold = self.blocks.row_fold()
        xs = design[:, self.alive] / self.scale[self.alive]
        _, _, beta = self._left_out(self.blocks.fold, self.blocks.n_folds)
        for f in range(self.blocks.n_folds):
            rows = row_fold == f
            resid[rows] = target[rows] - xs[rows] @ beta[f]
        return resid


def jackknife_sd(values: np.ndarray) -> float:
    """Delete-one-group jackknife standard deviation of an estimate."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    g = values.size
    if g < 2:
        return float("nan")
    return float(np.sqrt((g - 1) / g * np.sum((values - values.mean()) ** 2)))
