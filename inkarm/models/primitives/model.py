"""The factorial HMM of motor primitives (seed 004 sec. 2.2-2.3): parameters, priors, files.

M chains (primitives), each with K states. State 0 is silent: its output mean is fixed at zero
(sec. 2.3), so a chain at rest adds nothing to the pen's velocity. States 1 .. K-1 are the
primitive's samples, so a primitive lasts K-1 samples when it never lingers. The output is

    Y_t ~ N(mu_t, C),   mu_t = sum_m W^m S_t^m                    (eq. 2-3)

with S_t^m the 1-in-K code of chain m's state and W^m stored here as a (K, D) array whose
row k is state k's output mean (the paper's D x K matrix, transposed; row 0 is zero).

Transitions are the left-to-right band of Fig. 3: each state goes to itself or to the next,
and the last state returns to the silent state 0, so ``P(i -> i) = 1 - a_i`` and
``P(i -> i+1 mod K) = a_i``. ``a_0`` is the onset probability of the primitive; ``a_i``
(i >= 1) the rate at which it advances. With ``self_loops=False`` an active state always
advances (a_i = 1): the primitive keeps its exact shape and only its onset is random.

Units: Y is whatever the caller trains on (inkarm's data sets use normalised first differences,
see :mod:`inkarm.plans.primitives_data`); ``scale`` [mm or pressure per sample] and
``rate_hz`` [Hz] say how to turn it back into pen space.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from inkarm.core.npz import read_npz, scalar_int
from inkarm.errors import InputError

FORMAT_VERSION = 1
"""Version of the ``.npz`` model file written by :meth:`PrimitiveModel.save`."""


@dataclass(frozen=True)
class PrimitivesConfig:
    """EM settings (seed 004 sec. 3's pseudo-code).

    Attributes:
        n_chains: M, the number of primitives.
        n_states: K, states per chain including the silent state 0 (a primitive is K-1 samples).
        max_inner: Structured-variational sweeps per E-step (the paper's 20).
        max_outer: EM iterations (the paper's 50).
        tol_inner: An E-step stops when no expectation <S> moved by more than this.
        tol_outer: EM stops when no entry of W, C or the transition probabilities moved by more
            than this.
        self_loops: Whether active states may linger (Fig. 3's band) or must advance.
        stay_init: Initial probability that an active state lingers (with self_loops).
        min_variance: Floor on C's eigenvalues, as a fraction of the data's mean variance.
        prior_samples: lambda, the weight [samples] of the prior on W: each active state's
            mean is drawn from N(0, C / lambda), as if seen lambda more times at zero. It makes
            eq. 10 determined (a state never visited, or chains that always move together,
            would leave W free for rounding to pick).
    """

    n_chains: int = 8
    n_states: int = 10
    max_inner: int = 20
    max_outer: int = 50
    tol_inner: float = 1e-4
    tol_outer: float = 1e-3
    self_loops: bool = True
    stay_init: float = 0.1
    min_variance: float = 1e-6
    prior_samples: float = 1.0

    def __post_init__(self) -> None:
        # the ceilings are budgets, checked before any allocation: past them a request is a
        # typo that would run for days (EM costs max_outer * max_inner * M * K^2 per sample)
        for name, low, high in (("n_chains", 1, 200), ("n_states", 2, 100),
                                ("max_inner", 1, 1000), ("max_outer", 0, 10_000)):
            value = getattr(self, name)
            if (isinstance(value, bool) or not isinstance(value, (int, np.integer))
                    or not low <= value <= high):
                raise InputError(f"expected an integer in {low}..{high}, got {value!r}",
                                 key=name, value=value)
        for name, lo, hi in (("tol_inner", 0.0, np.inf), ("tol_outer", 0.0, np.inf),
                             ("stay_init", 0.0, 1.0), ("min_variance", 0.0, 1.0),
                             ("prior_samples", 0.0, np.inf)):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and lo <= value < hi):
                raise InputError(f"expected a number in [{lo}, {hi}), got {value!r}", key=name,
                                 value=value)
        if 0.0 < self.prior_samples < 1e-6:  # (G + lambda I would be as singular as G)
            raise InputError(f"expected 0 (the paper's pseudo-inverse) or >= 1e-6 samples, got "
                             f"{self.prior_samples!r}", key="prior_samples",
                             value=self.prior_samples)


@dataclass(frozen=True, eq=False)
class PrimitiveModel:
    """Parameters of the primitive fHMM.

    Attributes:
        W: (M, K, D) output means; ``W[:, 0]`` is zero (the silent state).
        advance: (M, K) probability a_i of leaving state i for the next (a_0: onset).
        start: (M, K) initial state distribution pi^m (eq. 4).
        C: (D, D) shared output covariance (eq. 2).
        scale: (D,) what one unit of Y is in pen space [mm / sample, or pressure / sample].
        rate_hz: Sample rate of Y [Hz].
        channels: Names of the D output dimensions (``dx``, ``dy``, ``dp``).
    """

    W: np.ndarray
    advance: np.ndarray
    start: np.ndarray
    C: np.ndarray
    scale: np.ndarray = field(default=None)  # type: ignore[assignment]
    rate_hz: float = 200.0
    channels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        W = np.array(self.W, dtype=float)
        if W.ndim != 3 or W.shape[1] < 2 or W.shape[2] < 1:
            raise InputError(f"expected W of shape (M, K >= 2, D), got {W.shape}", key="W")
        M, K, D = W.shape
        W[:, 0] = 0.0
        shapes = {"advance": (M, K), "start": (M, K), "C": (D, D)}
        arrays = {}
        for name, shape in shapes.items():
            a = np.array(getattr(self, name), dtype=float)
            if a.shape != shape:
                raise InputError(f"expected shape {shape}, got {a.shape}", key=name)
            arrays[name] = a
        scale = np.ones(D) if self.scale is None else np.array(self.scale, dtype=float)
        if scale.shape != (D,):
            raise InputError(f"expected shape ({D},), got {scale.shape}", key="scale")
        for name, a in (("W", W), ("scale", scale), *arrays.items()):
            if not np.all(np.isfinite(a)):
                raise InputError("holds non-finite values", key=name)
        for name in ("advance", "start"):
            a = arrays[name]
            if a.min() < 0 or a.max() > 1:
                raise InputError("expected probabilities in [0, 1]", key=name)
        if not np.allclose(arrays["start"].sum(axis=1), 1.0, atol=1e-6):
            raise InputError("each chain's initial distribution must sum to 1", key="start")
        C = arrays["C"] = 0.5 * (arrays["C"] + arrays["C"].T)
        if np.linalg.eigvalsh(C).min() <= 0:
            raise InputError("expected a symmetric positive definite covariance", key="C")
        if not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise InputError(f"expected a positive rate in Hz, got {self.rate_hz}",
                             key="rate_hz", value=self.rate_hz)
        channels = tuple(str(c) for c in self.channels) or tuple(f"y{d}" for d in range(D))
        if len(channels) != D:
            raise InputError(f"expected {D} channel names, got {len(channels)}", key="channels")
        for name, value in (("W", W), ("scale", scale), ("channels", channels),
                            ("rate_hz", float(self.rate_hz)), *arrays.items()):
            object.__setattr__(self, name, value)

    @property
    def n_chains(self) -> int:
        return self.W.shape[0]

    @property
    def n_states(self) -> int:
        return self.W.shape[1]

    @property
    def dim(self) -> int:
        return self.W.shape[2]

    def log_transitions(self) -> tuple[np.ndarray, np.ndarray]:
        """(log(1 - a), log a), each (M, K): the two non-zero entries of each row of P^m."""
        with np.errstate(divide="ignore"):
            return np.log1p(-self.advance), np.log(self.advance)

    def transition_matrix(self, m: int) -> np.ndarray:
        """Chain m's full (K, K) matrix, rows = from, columns = to (for the exact oracle)."""
        K = self.n_states
        P = np.diag(1.0 - self.advance[m])
        P[np.arange(K), (np.arange(K) + 1) % K] += self.advance[m]
        return P

    def means(self) -> np.ndarray:
        """The primitives' output sequences, (M, K-1, D): W without the silent row."""
        return self.W[:, 1:]

    def save(self, path: str | Path) -> None:
        """Write an ``.npz`` with a ``version`` field (:data:`FORMAT_VERSION`)."""
        np.savez(Path(path), version=np.array(FORMAT_VERSION), W=self.W, advance=self.advance,
                 start=self.start, C=self.C, scale=self.scale, rate_hz=np.array(self.rate_hz),
                 channels=np.array(self.channels))

    @classmethod
    def load(cls, path: str | Path) -> PrimitiveModel:
        """Read a model written by :meth:`save`; a bad file names the file and the field."""
        path = Path(path)
        arrays = read_npz(path, "a primitives model")
        names = [f.name for f in fields(cls)]
        for name in ("version", *names):
            if name not in arrays:
                raise InputError("missing field", file=str(path), key=name)
        version = scalar_int(arrays, "version", path)
        if version != FORMAT_VERSION:
            raise InputError(f"unsupported version {version}; this inkarm reads version "
                             f"{FORMAT_VERSION}", file=str(path), key="version")
        kwargs = {}
        for name in names:
            value = arrays[name]
            if name == "channels":
                if value.dtype.kind != "U":
                    raise InputError("expected text", file=str(path), key=name)
                kwargs[name] = tuple(value.tolist())
            elif value.dtype.kind not in "fiu":
                raise InputError(f"expected numbers, got dtype {value.dtype}", file=str(path),
                                 key=name)
            elif name == "rate_hz" and value.shape != ():
                raise InputError(f"expected a number, got shape {value.shape}", file=str(path),
                                 key=name)
            else:
                kwargs[name] = float(value) if name == "rate_hz" else value
        try:
            return cls(**kwargs)
        except InputError as e:
            raise e.within(file=str(path)) from None
