r"""The reduced basis built greedily: snapshots where the a-posteriori estimate is largest.

Start from the snapshot at the nominal point; then, over a set of training points in the box of
the updated parameters, evaluate the reduced model's lowest modes, lift them and estimate their
frequency error on the full model (:func:`femupdate.rom.estimate.residual_bounds`, in the norm
of the nominal point's factorisation: one factorisation for the whole search); add the snapshot
at the point of largest estimate; stop when the largest estimate is below the tolerance or the
number of snapshots reaches its cap.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .basis import factor_pencil, orthonormalise, snapshot
from .estimate import residual_bounds, ritz_pairs
from .project import extend, reduced_model


def training_points(model, names, n: int, seed: int = 0) -> np.ndarray:
    """``n`` points (rows of full parameter vectors) spread over the box of the parameters ``names``:
    a Latin hypercube, log-uniform for a positive range; an infinite bound is taken as a factor 2
    from the nominal value (or ±1 about 0)."""
    rng = np.random.default_rng(seed)
    p0 = model.values
    idx = model.parameter_indices(list(names))
    lo, hi = model.bounds
    X = np.tile(p0, (n, 1))
    for j in idx:
        a, b = lo[j], hi[j]
        v = p0[j]
        if not math.isfinite(a):
            a = v / 2 if v > 0 else v - max(abs(v), 1.0)
        if not math.isfinite(b):
            b = v * 2 if v > 0 else v + max(abs(v), 1.0)
        u = (rng.permutation(n) + rng.random(n)) / n
        X[:, j] = np.exp(np.log(a) + u * (np.log(b) - np.log(a))) if a > 0 else a + u * (b - a)
    return X


@dataclass
class ReducedBasis:
    """A Ritz basis of a model, the reduced model on it, and how it was built and checked.

    Attributes
    ----------
    model : Model
        The full model.
    dofs : list of str
        The dofs at which the reduced model interpolates (the data's).
    V : numpy.ndarray, shape ``(n, r)``
        The basis, M-orthonormal in the nominal mass matrix.
    n_modes : int
        Modes per snapshot (and modes whose error is estimated).
    corrections : bool
        Whether snapshots add the modes' static corrections.
    points : list of dict
        The parameter points of the snapshots ``{name: value}``, with why each was added.
    history : list of dict
        Per greedy step: the basis size and the largest estimate over the training points.
    """

    model: Any
    dofs: list
    V: np.ndarray
    n_modes: int
    corrections: bool = True
    deflation: float = 1e-8
    points: list = field(default_factory=list)
    history: list = field(default_factory=list)
    seconds: float = 0.0
    projections: list | None = field(default=None, repr=False)
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def size(self) -> int:
        """The number of basis vectors r."""
        return int(self.V.shape[1])

    def reduced(self):
        """``(reduced Model, V T)`` on the current basis (cached until the basis grows)."""
        key = self.size
        if self._cache.get("key") != key:
            M0 = self._cache.get("M0")
            self._cache.clear()
            self._cache.update(key=key, M0=M0, value=reduced_model(self.model, self.V, self.dofs, self.projections))
        return self._cache["value"]

    def add(self, W: np.ndarray, p: np.ndarray, why: str) -> int:
        """Add the new directions of ``W``; the number added."""
        M0 = self._cache.setdefault("M0", self.model.M())
        Q = orthonormalise(W, M0, self.V, self.deflation)
        if Q.shape[1]:
            self.projections = extend(self.projections, self.model, self.V, Q)
            self.V = np.hstack([self.V, Q])
        self.points.append({"parameters": dict(zip(self.model.parameter_names, map(float, p))), "why": why,
                            "added": int(Q.shape[1]), "deflated": int(W.shape[1] - Q.shape[1])})
        return int(Q.shape[1])

    def add_snapshot(self, p: np.ndarray, why: str, modes=None) -> int:
        """Add the snapshot at ``p`` (``modes``: ``(λ, Φ, pencil)`` already computed there)."""
        from .basis import static_corrections

        if modes is None:
            W, *_ = snapshot(self.model, p, self.n_modes + 1, self.corrections)
        else:
            lam, Phi, pencil = modes
            W = np.hstack([Phi, static_corrections(self.model, p, lam, Phi, pencil)]) if self.corrections else Phi
        return self.add(W, p, why)

    def estimates(self, p: np.ndarray, reference) -> dict:
        """The residual bounds of the reduced modes at ``p`` in the reference norm (``(A0, lu0, σ)``)."""
        A0, lu0, sigma = reference
        reduced, Vh = self.reduced()
        lam, X = ritz_pairs(reduced, Vh, p, self.n_modes + 1)
        K, M = self.model.K(p), self.model.M(p)
        return residual_bounds(K, M, lam, X, lu0, A=A0, sigma=sigma, n_bounded=self.n_modes)


def build(model, dofs, n_modes: int, *, names=None, n_train: int = 12, max_points: int = 4, tol: float = 1e-6,
          corrections: bool = True, seed: int = 0, deflation: float = 1e-8) -> ReducedBasis:
    """The greedy reduced basis (see the module's description).

    Parameters
    ----------
    model : Model
    dofs : sequence of str
        The data's dofs (sensors, excitations, loads).
    n_modes : int
        Modes per snapshot, whose error is estimated.
    names : sequence of str, optional
        The parameters spanned by the training points (default: the free ones).
    n_train : int
        Training points.
    max_points : int
        Most snapshots (the nominal one included).
    tol : float
        Target of the largest estimated relative frequency error.
    corrections : bool
        Add each mode's static corrections to a snapshot.
    seed : int
        Of the training points.
    deflation : float
        Relative M-norm below which a new direction is dropped.
    """
    from .._threads import blas_phase

    with blas_phase("solve"):
        return _build(model, dofs, n_modes, names, n_train, max_points, tol, corrections, seed, deflation)


def _build(model, dofs, n_modes, names, n_train, max_points, tol, corrections, seed, deflation) -> ReducedBasis:
    t0 = time.perf_counter()
    names = [model.parameter_names[j] for j in model.free] if names is None else list(names)
    p0 = model.values
    lam0, Phi0, pencil0 = _modes(model, p0, n_modes + 1)
    rb = ReducedBasis(model=model, dofs=list(dofs), V=np.zeros((model.n_dofs, 0)), n_modes=n_modes,
                      corrections=corrections, deflation=deflation)
    rb.add_snapshot(p0, "nominal", (lam0, Phi0, pencil0))
    K0, M0, lu0, sigma0 = pencil0
    if not interpolates(rb.V, model.dof_index(list(dofs), "data")):
        rb.add(attachment(lu0, model.n_dofs, model.dof_index(list(dofs), "data")), p0,
               "attachment: static responses to unit loads at the data's dofs")
    reference = ((K0 - sigma0 * M0).tocsr(), lu0, sigma0)
    train = training_points(model, names, n_train, seed) if names and n_train else np.zeros((0, p0.size))
    while True:
        worst, where = -1.0, None
        for p in train:
            est = float(np.max(rb.estimates(p, reference)["estimate"]))
            if est > worst:
                worst, where = est, p
        rb.history.append({"basis": rb.size, "snapshots": len(rb.points), "largest_estimate": worst,
                           "at": None if where is None else dict(zip(model.parameter_names, map(float, where)))})
        if where is None or worst <= tol or len(rb.points) >= max_points:
            break
        if rb.add_snapshot(where, f"greedy: largest estimate {worst:.3g}") == 0:
            break
    rb.seconds = time.perf_counter() - t0
    return rb


def interpolates(V: np.ndarray, rows: np.ndarray) -> bool:
    """Whether the basis moves the data's dofs independently (rank of its rows there)."""
    if V.shape[1] < rows.size:
        return False
    S = np.linalg.svd(V[rows, :], compute_uv=False)
    return bool(S.size == 0 or S[-1] > 1e-8 * S[0])


def attachment(lu, n: int, rows: np.ndarray) -> np.ndarray:
    """The static responses ``(K - σM)^{-1} e_d`` to unit loads at the data's dofs (n × s)."""
    E = np.zeros((n, rows.size))
    E[rows, np.arange(rows.size)] = 1.0
    return np.asarray(lu.solve(E), float).reshape(E.shape)


def _modes(model, p, n_modes):
    from .basis import full_modes

    return full_modes(model, p, n_modes, factor_pencil(model, p))


__all__ = ["ReducedBasis", "build", "training_points"]
