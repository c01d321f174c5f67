"""Zero-phase Butterworth low-pass in NumPy: what ``scipy.signal.filtfilt(*butter(n, wn), x,
axis=0, padtype="odd", padlen=...)`` computes, without importing scipy.signal (a quarter of a
second of start-up, scipy.stats with it).

Design (SciPy's ``butter``): the analog prototype's poles s_k = -w exp(i pi m / (2 n)),
m = -n+1, -n+3, ..., n-1, at the pre-warped cutoff w = 4 tan(pi wn / 2) (sampling rate 2:
``wn`` is a fraction of the Nyquist frequency), mapped by the bilinear transform
z_k = (4 + s_k) / (4 - s_k); every zero at z = -1. The filter runs as a cascade of sections,
one per pair of conjugate poles (and one for the real pole of an odd order), each scaled to
unit gain at z = 1 as the whole filter is: the same filter as SciPy's single (b, a) in exact
arithmetic, well conditioned where high orders at low cutoffs leave (b, a) to round-off
(SciPy's ``sosfiltfilt``).

Filtering a section (SciPy's ``lfilter``, direct form II transposed): y_t = b_0 u_t + z_t[0],
z_(t+1) = M z_t + g u_t, M the transposed companion matrix of a (first column -a[1:], ones
above the diagonal) and g = b[1:] - a[1:] b_0; by blocks of :data:`BLOCK` samples
(:func:`lfilter`), not sample by sample: the same filter up to rounding, not bit for bit.
"""

from __future__ import annotations

import numpy as np


def butter_sections(order: int, wn: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """(b, a) of each section (a[0] = 1, unit gain at z = 1) of the digital Butterworth
    low-pass of ``order`` with its -3 dB point at ``wn`` (0 < wn < 1, a fraction of the
    Nyquist frequency)."""
    m = np.arange(-order + 1, order, 2)
    analog = -4.0 * np.tan(np.pi * wn / 2.0) * np.exp(1j * np.pi * m / (2 * order))
    poles = (4.0 + analog) / (4.0 - analog)
    sections = []
    for pole in poles[m < 0]:  # the upper pole of each conjugate pair (Im > 0 for m < 0)
        a = np.array([1.0, -2.0 * pole.real, abs(pole) ** 2])
        sections.append((a.sum() / 4.0 * np.array([1.0, 2.0, 1.0]), a))
    if order % 2:
        a = np.array([1.0, -poles[m == 0][0].real])
        sections.append((a.sum() / 2.0 * np.array([1.0, 1.0]), a))
    return sections


def _transition(a: np.ndarray) -> np.ndarray:
    """M: the transposed companion matrix of ``a`` (a[0] = 1)."""
    n = a.size - 1
    matrix = np.eye(n, k=1)
    matrix[:, 0] = -a[1:]
    return matrix


def lfilter_zi(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The state of the filter's steady step response: z = M z + g for a unit input
    (``scipy.signal.lfilter_zi``)."""
    return np.linalg.solve(np.eye(a.size - 1) - _transition(a), b[1:] - a[1:] * b[0])


BLOCK = 64
"""Samples a block of :func:`lfilter`: the response within a block is a product with a
BLOCK x BLOCK Toeplitz matrix, the state carried from block to block in a loop."""


def lfilter(b: np.ndarray, a: np.ndarray, u: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """The filtered signal y (shape of ``u``: (T,) or (T, D), filtered along axis 0) from the
    initial state ``zi`` (shape (n,) or (n, D)) of z_(t+1) = M z_t + g u_t, y_t = b_0 u_t +
    z_t[0], by blocks of L samples starting at s:

        y_(s+i) = sum_(j <= i) h_(i-j) u_(s+j) + e_0 M^i z_s,   h_0 = b_0, h_m = e_0 M^(m-1) g,
        z_(s+L) = M^L z_s + sum_(j < L) M^(L-1-j) g u_(s+j).
    """
    steps = u.shape[0]
    size = min(BLOCK, steps)
    blocks = -(-steps // size)
    matrix = _transition(a)
    gain = b[1:] - a[1:] * b[0]
    powers = [np.eye(matrix.shape[0])]  # M^0 .. M^L
    for _ in range(size):
        powers.append(matrix @ powers[-1])
    powers = np.stack(powers)
    response = np.concatenate([b[:1], (powers[: size - 1] @ gain)[:, 0]])  # h_0 .. h_(L-1)
    lag = np.subtract.outer(np.arange(size), np.arange(size))
    toeplitz = np.where(lag >= 0, response[np.maximum(lag, 0)], 0.0)
    inputs = np.zeros((blocks * size, int(np.prod(u.shape[1:]))))
    inputs[:steps] = u.reshape(steps, -1)
    inputs = inputs.reshape(blocks, size, -1)
    carried = (powers[size - 1 :: -1] @ gain).T @ inputs  # sum_j M^(L-1-j) g u_(s+j)
    starts = np.empty_like(carried)
    state = zi.reshape(matrix.shape[0], -1)
    for k in range(blocks):
        starts[k] = state
        state = powers[size] @ state + carried[k]
    out = toeplitz @ inputs + powers[:size, 0, :] @ starts
    return out.reshape(blocks * size, -1)[:steps].reshape(u.shape)


def filtfilt_odd(sections: list[tuple[np.ndarray, np.ndarray]], x: np.ndarray,
                 padlen: int) -> np.ndarray:
    """``x`` (shape (T,) or (T, D)) filtered forwards then backwards along axis 0 by the
    cascade of ``sections``, padded by point reflection about each end over ``padlen`` < T
    samples, each pass started in the steady state of its first sample (every section has
    unit gain at z = 1: it sees that sample too)."""
    x = np.asarray(x, dtype=float)
    y = np.concatenate([2 * x[0] - x[padlen:0:-1], x,
                        2 * x[-1] - x[-2:-(padlen + 2):-1]]) if padlen else x
    for _ in range(2):
        start = y[0]
        for b, a in sections:
            y = lfilter(b, a, y, np.multiply.outer(lfilter_zi(b, a), start))
        y = y[::-1]
    return y[padlen:y.shape[0] - padlen]
