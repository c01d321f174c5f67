"""A local inverse of the pen's kinematics learnt from the arm's own motion: locally weighted
regression on motor babbling (seed 001, sec. 4).

Seed 001's synthesis inverts the kinematics with "a non parametric learning algorithm which
processes the mapping (y, dx) -> dy, y being the state and x the output of the system" (the ASM
model, its ref. [12]); a PID then inverts the dynamics. The seed names the mapping but writes no
equation for it (and numbers none of its equations), so the regression below is the standard
locally weighted least squares (Atkeson, Moore & Schaal 1997, written as in Calinon's tutorials),
with the seed's state y = q (joint angles [rad]) and output x the 5-D pen task of
:mod:`inkarm.control.ik`: the tip position [m] and the pen's two tilts,

    x(q) = [p ; y_s . a ; -x_s . a]          (so that dx = J5 dq to first order, J5 of ik.py)

with a the pen axis the paper wants. Tilts are zero when the pen is perpendicular.

Data (babbling, :func:`babble`). N small random joint motions dq_i ~ N(0, s^2 I) made from poses
q_i around the plan's drawing poses, on the controller's own kinematic model, with what they
did to the pen:

    dx_i = x(q_i + dq_i) - x(q_i)                                        (B)

Query (q*, dx*) (:meth:`LocalInverse.predict`), seed 001's mapping (y, dx) -> dy:

    w_i = exp(-||q_i - q*||^2 / (2 h^2))                                  (K)  kernel, bandwidth h
    B(q*) = (sum_i w_i dq_i dx_i^T) (sum_i w_i dx_i dx_i^T + lambda I)^-1  (W)  weighted LS
    dq* = B(q*) dx*                                                        (P)

Why (W) is the analytic inverse: where the motions are linear, dx_i = J dq_i, and with
S = sum_i w_i dq_i dq_i^T, (W) is B = S J^T (J S J^T)^-1, so J B = I (the pen does what was
asked) and B is the minimum-norm inverse in the metric S^-1; for isotropic babbling S -> c I and
B -> J^T (J J^T)^-1 = J^+, the Jacobian pseudo-inverse. What the sample leaves anisotropic in S
only moves the arm in the null space of J (``tests/control/test_sensorimotor.py`` checks both
against J^+ at the drawing poses).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.control.ik import pen_jacobian
from inkarm.control.kinematics import ArmKinematics

TASK_DIM = 5
"""The pen task: tip position (3) and the two tilts of the pen axis."""
RIDGE = 1e-9
"""lambda of (W), relative to the trace of sum_i w_i dx_i dx_i^T / 5."""


def pen_output(R: np.ndarray, p: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """x(q) of the module docstring from the tip ``p`` [m] and the site axes ``R`` (columns
    x_s, y_s, z_s): [p ; y_s . a ; -x_s . a] for the pen axis ``a``."""
    out = np.empty(TASK_DIM)
    out[:3] = p
    out[3] = R[:, 1] @ axis
    out[4] = -(R[:, 0] @ axis)
    return out


def task_output(kin: ArmKinematics, q: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """x(q) on the kinematic model ``kin`` (module docstring)."""
    p, R = kin.fk(q)
    return pen_output(R, p, axis)


def task_jacobian(kin: ArmKinematics, q: np.ndarray) -> np.ndarray:
    """The analytic J5 (5, n) at ``q``: dx = J5 dq to first order (:func:`ik.pen_jacobian`)."""
    _, R, Jp, Jr = kin.jacobian_views(q)
    return pen_jacobian(R, Jp, Jr).copy()


def pseudo_inverse_step(J: np.ndarray, dx: np.ndarray, damping: float = 1e-6) -> np.ndarray:
    """dq = J^T (J J^T + damping^2 I)^-1 dx: the (damped) pseudo-inverse of the analytic
    Jacobian, the comparison of seed 001's learnt inverse."""
    A = J @ J.T
    A[np.diag_indices_from(A)] += damping * damping
    return J.T @ np.linalg.solve(A, dx)


@dataclass(frozen=True, eq=False)
class Babbling:
    """Motor babbling: poses q (N, n) [rad], motions dq (N, n) [rad] and their effect on the
    pen dx (N, 5) ([m] and tilt), equation (B)."""

    q: np.ndarray
    dq: np.ndarray
    dx: np.ndarray

    def __len__(self) -> int:
        return self.q.shape[0]


def babble(
    kin: ArmKinematics,
    centres: np.ndarray,
    axis: np.ndarray,
    samples: int,
    motion_rad: float,
    spread_rad: float,
    seed: int = 0,
) -> Babbling:
    """``samples`` random motions (B): poses q_i = c + N(0, spread^2 I) around the ``centres``
    (m, n) taken in turn, motions dq_i ~ N(0, motion^2 I), on the model ``kin``; seeded by
    ``seed`` (the same babbling every run). Poses are kept inside the joint ranges."""
    centres = np.atleast_2d(np.asarray(centres, dtype=float))
    rng = np.random.default_rng(seed)
    n = kin.n
    q = centres[np.arange(samples) % len(centres)] + spread_rad * rng.standard_normal((samples, n))
    dq = motion_rad * rng.standard_normal((samples, n))
    margin = 2.0 * motion_rad
    q = np.clip(q, kin.lower + margin, kin.upper - margin)
    dx = np.empty((samples, TASK_DIM))
    for i in range(samples):
        dx[i] = task_output(kin, q[i] + dq[i], axis) - task_output(kin, q[i], axis)
    return Babbling(q, dq, dx)


class LocalInverse:
    """Seed 001's learnt kinematic inversion (q, dx) -> dq: locally weighted regression (K),
    (W), (P) of the module docstring on a :class:`Babbling`, with kernel bandwidth
    ``bandwidth_rad`` in joint space.

    The matrix B(q*) of (W) is cached and re-fitted when the query has moved more than a tenth
    of the bandwidth from where it was fitted (the kernel weights hardly change within that)."""

    def __init__(self, data: Babbling, bandwidth_rad: float):
        self.data = data
        self.h = float(bandwidth_rad)
        self._inv_2h2 = 1.0 / (2.0 * self.h * self.h)
        self._refit = (0.1 * self.h) ** 2
        self._at: np.ndarray | None = None
        self._B: np.ndarray | None = None

    def weights(self, q: np.ndarray) -> np.ndarray:
        """w_i of (K) at the query pose ``q``."""
        d = self.data.q - q
        return np.exp(-np.einsum("ij,ij->i", d, d) * self._inv_2h2)

    def fit(self, q: np.ndarray) -> np.ndarray:
        """B(q) (n, 5) of (W)."""
        w = self.weights(q)
        wdx = self.data.dx * w[:, None]
        cross = self.data.dq.T @ wdx  # sum_i w_i dq_i dx_i^T   (n, 5)
        gram = self.data.dx.T @ wdx  # sum_i w_i dx_i dx_i^T   (5, 5)
        gram[np.diag_indices_from(gram)] += RIDGE * max(float(np.trace(gram)), 1e-300) / TASK_DIM
        return np.linalg.solve(gram, cross.T).T  # cross @ gram^-1 (gram is symmetric)

    def effective_samples(self, q: np.ndarray) -> float:
        """(sum w)^2 / sum w^2 at ``q``: how many babbling samples the fit at ``q`` rests on."""
        w = self.weights(q)
        return float(w.sum() ** 2 / max(float((w * w).sum()), 1e-300))

    def predict(self, q: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """dq = B(q) dx, (P)."""
        at = self._at
        if at is None or float(np.dot(q - at, q - at)) > self._refit:
            self._B = self.fit(q)
            self._at = np.array(q, dtype=float)
        return self._B @ dx


__all__ = ["RIDGE", "TASK_DIM", "Babbling", "LocalInverse", "babble", "pen_output",
           "pseudo_inverse_step", "task_jacobian", "task_output"]
