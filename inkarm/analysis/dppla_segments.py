"""The segment errors d(i, j) of DPPLA (seed 001, sec. 3; :mod:`inkarm.analysis.dppla`), in
O(1) per segment from prefix sums.

``"interpolation"`` (the paper's): the summed squared distance of samples i..j from the chord
X(i) -> X(j) traversed uniformly in the chord parameter tau; ``"perpendicular"``: from the
chord's (infinite) line. The first takes prefix sums of tau, tau^2, x, tau x and |x|^2, the
second of x and x x^T. Errors in [units of X]^2.
"""

from __future__ import annotations

import numpy as np

from inkarm.errors import InputError

ERRORS = ("interpolation", "perpendicular")


class SegmentCost:
    """O(1) segment errors d(i, j) from prefix sums, vectorised over index arrays.

    Args:
        x: (w, p) samples (already weighted).
        tau: (w,) strictly increasing chord parameter (default: the index n, as in the paper).
        error: "interpolation" (seed 001) or "perpendicular".
    """

    def __init__(self, x: np.ndarray, tau: np.ndarray | None = None, error: str = "interpolation"):
        if error not in ERRORS:
            raise InputError(f"dppla error: expected one of {ERRORS}, got {error!r}")
        w = x.shape[0]
        # Centring only conditions the prefix sums; the errors are translation invariant.
        x = x - x.mean(axis=0)
        tau = np.arange(w, dtype=float) if tau is None else np.asarray(tau, dtype=float)
        tau = (tau - tau[0]) / max(tau[-1] - tau[0], np.finfo(float).tiny) * (w - 1)
        tau = tau - tau.mean()
        self.x, self.tau, self.error, self.w = x, tau, error, w

        def prefix(a: np.ndarray) -> np.ndarray:
            return np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)])

        self.sx = prefix(x)
        if error == "interpolation":
            self.st = prefix(tau)
            self.stt = prefix(tau * tau)
            self.stx = prefix(tau[:, None] * x)
            self.sxx = prefix(np.einsum("np,np->n", x, x))
        else:
            self.sxxt = prefix(x[:, :, None] * x[:, None, :])

    def row(self, start: int, j: int) -> np.ndarray:
        """d(i, j) for i = start..j-1: one DP row, indexed by slices rather than index arrays."""
        return self(slice(start, j), j)

    def __call__(self, i, j) -> np.ndarray:
        """d(i, j) for broadcastable integer arrays with i < j (both end samples included),
        shaped as they broadcast; ``i`` may also be a slice of start indices."""
        starts = np.arange(i.start, i.stop) if isinstance(i, slice) else np.asarray(i)
        j = np.asarray(j)
        c = (j - starts + 1).astype(float)
        a, b = self.x[i], self.x[j]
        s_x = self.sx[j + 1] - self.sx[i]
        if self.error == "perpendicular":
            return self._perpendicular(i, j, c, a, b, s_x)
        t_i = self.tau[i]
        span = self.tau[j] - t_i
        s_t = self.st[j + 1] - self.st[i]
        s_tt = self.stt[j + 1] - self.stt[i]
        s_tx = self.stx[j + 1] - self.stx[i]
        s_xx = self.sxx[j + 1] - self.sxx[i]
        # s_n = (tau_n - tau_i) / (tau_j - tau_i) is the chord parameter of sample n.
        sum_s = (s_t - c * t_i) / span
        sum_ss = (s_tt - 2.0 * t_i * s_t + c * t_i * t_i) / (span * span)
        sum_sx = (s_tx - t_i[..., None] * s_x) / span[..., None]
        d = b - a
        # sum ||x_n - a - s_n d||^2 expanded into the prefix sums.
        cost = (
            s_xx
            - 2.0 * _dot(a, s_x)
            + c * _dot(a, a)
            - 2.0 * _dot(d, sum_sx)
            + 2.0 * _dot(d, a) * sum_s
            + _dot(d, d) * sum_ss
        )
        return np.maximum(cost, 0.0)

    def _perpendicular(self, i, j, c, a, b, s_x) -> np.ndarray:
        s_xxt = self.sxxt[j + 1] - self.sxxt[i]
        d = b - a
        norm = np.sqrt(_dot(d, d))
        u = np.divide(d, norm[..., None], out=np.zeros_like(d), where=norm[..., None] > 0)
        # sum ||x_n - a||^2 - (u . (x_n - a))^2; a zero chord leaves the distance to the point a.
        total = np.trace(s_xxt, axis1=-2, axis2=-1) - 2.0 * _dot(a, s_x) + c * _dot(a, a)
        ua = _dot(u, a)
        along = (
            np.einsum("...p,...pq,...q->...", u, s_xxt, u) - 2.0 * ua * _dot(u, s_x) + c * ua * ua
        )
        return np.maximum(total - along, 0.0)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...p,...p->...", a, b)
