r"""Fisher information of a sensor set for the physical parameters to be updated.

A test measures, for each target mode, its eigenvalue and its shape at the chosen dofs.  With the
residuals femupdate's update uses (:class:`~femupdate.options.ModalOptions`, ``"shapes"``: the
relative eigenvalue error and the shape scaled to unit length over the measured dofs), the
sensitivity matrix of a sensor set s is

.. math::  S_s = \begin{bmatrix} \partial\lambda_i/\partial p \,/\, \lambda_i \\
           \partial\psi_{i,s}/\partial p \end{bmatrix}, \qquad
           \psi_{i,s} = \phi_{i,s}/\lVert\phi_{i,s}\rVert,

and under independent noise of relative standard deviation :math:`\sigma_\lambda` on the
eigenvalues and :math:`\sigma_\psi` on the unit-scaled shape entries, the Fisher information is
:math:`F = S^T W S`, :math:`W = \mathrm{diag}(\sigma^{-2})`; :math:`F^{-1}` is the covariance of
the least-squares estimate (Cramér-Rao).  A sensor set at a single dof carries no shape
information once scaled (frequencies only), as in femupdate's uniqueness studies.

:class:`SensitivityBank` differentiates the target modes once per parameter point at every
candidate dof (:func:`femupdate.sensitivity.jacobian`, mass-normalised shapes); a set's S is then
a scaling of rows (:func:`femupdate.sensitivity.scaled_shape`), with no new eigen-solution.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import InputError, NumericalError
from ..modal import model_modes
from ..sensitivity import jacobian, scaled_shape


@dataclass(frozen=True)
class Noise:
    """Measurement noise of a plan: relative std of the eigenvalues and std of the unit-scaled
    shape entries (both > 0).  A relative frequency std σ_f is a relative eigenvalue std of 2 σ_f."""

    eigenvalue: float = 0.002
    shape: float = 0.01

    def __post_init__(self):
        for name in ("eigenvalue", "shape"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"noise: the {name} standard deviation must be a finite number > 0, got {v!r} "
                                 "(zero noise makes every information infinite)")


class SensitivityBank:
    """Target-mode sensitivities at every candidate dof, at one parameter point.

    Parameters
    ----------
    model : Model
    dofs : sequence of str
        The candidate dofs (rows).
    target : sequence of int
        Target modes (0-based, at the nominal point).
    params : sequence of str
        The parameters to identify.
    values : array_like, optional
        The parameter point (default nominal).
    reference : ndarray, shape ``(n_dofs, m)``, optional
        Target shapes at the nominal point: at another point the target modes are those paired
        with them by the largest total MAC (mode tracking), not the same indices.
    """

    def __init__(self, model, dofs: Sequence[str], target: Sequence[int], params: Sequence[str], values=None,
                 reference: np.ndarray | None = None):
        self.values = model.resolve(values)
        self.dof_labels = tuple(dofs)
        n = max(target) + 1
        n_modes = min(model.n_dofs, max(n + 6, 2 * n))
        modes = model_modes(model, self.values, n_modes=n_modes)
        which = np.asarray(target, dtype=int)
        if reference is not None:
            G = reference.T @ modes.shapes
            mac = G ** 2 / np.outer(np.sum(reference ** 2, axis=0), np.sum(modes.shapes ** 2, axis=0))
            from scipy.optimize import linear_sum_assignment

            which = linear_sum_assignment(-mac)[1]  # the pairing of largest total MAC: distinct modes
        self.which = which
        self.shapes_full = modes.shapes[:, which]
        try:
            jr = jacobian(model, modes, which, list(dofs), params=list(params), values=self.values,
                          shape_scaling="mass")
        except NumericalError as exc:
            if "repeated" in str(exc):
                raise NumericalError(f"target modes repeated at {_point_text(model, self.values)} (a symmetric "
                                     f"structure?): {str(exc).split(':')[0]}; planning does not treat repeated modes "
                                     "yet - target other modes (--modes, --band) or break the symmetry") from None
            raise NumericalError(f"sensitivities at {_point_text(model, self.values)}: {exc}") from None
        self.eigenvalues = jr.eigenvalues
        self.dlam = jr.dlam  # (m, L), relative
        self.phi = jr.psi  # (n_c, m), mass-normalised
        self.dphi = jr.dpsi  # (n_c, m, L)
        self.parameter_values = self.values[model.parameter_indices(list(params))]
        self.parameter_names = tuple(params)

    def matrix(self, rows: Sequence[int], noise: Noise | None = None, normalised: bool = False) -> np.ndarray:
        """S of the sensor set whose dofs are ``rows`` (divided by the noise's std when given;
        columns multiplied by the parameter values when ``normalised``: unit-free)."""
        rows = list(rows)
        m = self.dlam.shape[0]
        blocks = [self.dlam / (noise.eigenvalue if noise else 1.0)]
        if len(rows) >= 2:
            for r in range(m):
                _, d = scaled_shape(self.phi[rows, r], self.dphi[rows, r, :], "unit")
                blocks.append(d / (noise.shape if noise else 1.0))
        S = np.vstack(blocks)
        return S * np.abs(self.parameter_values)[None, :] if normalised else S

    def shapes(self, rows: Sequence[int]) -> np.ndarray:
        """The target shapes at ``rows``, unit length per mode."""
        P = self.phi[list(rows)]
        return P / np.where(np.linalg.norm(P, axis=0) > 0, np.linalg.norm(P, axis=0), 1.0)


def _point_text(model, values) -> str:
    return ", ".join(f"{n}={v:.4g}" for n, v in zip(model.parameter_names, values))


def fisher(S: np.ndarray) -> np.ndarray:
    """:math:`F = S^T S` of a noise-weighted sensitivity matrix."""
    return S.T @ S


def rank_and_condition(S: np.ndarray) -> tuple[int, float, np.ndarray]:
    """Numerical rank (singular values above ``max(S.shape) eps s_max``, as the uniqueness studies
    count it), condition number (inf when rank-deficient) and the singular values of S."""
    s = np.linalg.svd(S, compute_uv=False) if S.size else np.zeros(0)
    L = S.shape[1]
    rank = int(np.sum(s > max(S.shape) * np.finfo(float).eps * s[0])) if s.size and s[0] > 0 else 0
    cond = float(s[0] / s[-1]) if s.size == L and rank == L else math.inf
    return rank, cond, s


@dataclass(frozen=True, eq=False)
class Design:
    r"""A design criterion with a Gaussian prior: ``kind`` ``"d"`` or ``"a"`` and the prior
    variances of the relative parameters (:func:`prior_variances`).  With a prior, D-optimal is
    the expected information gain by the Laplace approximation,
    :math:`\tfrac12\log\det(I + \Sigma_{prior} F)` (the mutual information between the
    parameters and the data of a linear-Gaussian model), and A-optimal is
    :math:`-\mathrm{trace}\,(\Sigma_{prior}^{-1} + F)^{-1}` (the posterior variances)."""

    kind: str = "d"
    prior_var: np.ndarray | None = None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "prior_relative_std": None if self.prior_var is None
                else np.sqrt(self.prior_var).tolist()}


def design_kind(design) -> str:
    """``"d"`` or ``"a"`` of a design given as a string or a :class:`Design`."""
    return design if isinstance(design, str) else design.kind


def design_value(F: np.ndarray, design) -> float:
    """D-optimal ``log det F`` or A-optimal ``-trace F^-1`` (larger is better; -inf when singular);
    with a :class:`Design` that carries a prior, the expected information gain
    ``½ log det(I + Σ F)`` or ``-trace (Σ⁻¹ + F)⁻¹`` (finite for every F)."""
    kind = design_kind(design)
    prior = None if isinstance(design, str) else design.prior_var
    if prior is not None:
        s = np.sqrt(np.asarray(prior, float))
        A = np.eye(F.shape[0]) + s[:, None] * F * s[None, :]  # I + S F S, similar to I + Σ F
        if kind == "d":
            return 0.5 * float(np.linalg.slogdet(A)[1])
        return -float(np.trace(s[:, None] * np.linalg.inv(A) * s[None, :]))  # Σ^½ (I + S F S)^-1 Σ^½
    sign, ld = np.linalg.slogdet(F)
    if sign <= 0 or not np.isfinite(ld):
        return -math.inf
    if kind == "d":
        return float(ld)
    try:
        return -float(np.trace(np.linalg.inv(F)))
    except np.linalg.LinAlgError:
        return -math.inf


def prior_variances(model, params: Sequence[str], nominal=None) -> np.ndarray:
    """Variances of the relative parameters p / abs(p₀) under their priors, for :class:`Design`:
    ``normal(mean, std)``: (std/p₀)²; ``lognormal(median, s)``: s² (the variance of ln p);
    ``uniform`` or no prior: (upper − lower)²/12 within the bounds, /p₀².

    Raises
    ------
    InputError
        A parameter with neither a normal/lognormal prior nor finite bounds (named).
    """
    p0 = model.resolve(nominal)
    out = []
    for name in params:
        j = model.parameter_indices([name])[0]
        par = model.parameters[j]
        pr = par.prior
        v0 = abs(p0[j]) or 1.0
        if pr is not None and pr.kind == "normal":
            out.append((pr.b / v0) ** 2)
        elif pr is not None and pr.kind == "lognormal":
            out.append(pr.b ** 2)
        else:
            lo, hi = par.bounds
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise InputError(f"prior: parameter {name} has no normal or lognormal prior and no finite bounds for a "
                                 "uniform one; declare its prior (docs/bayes.md) or give finite bounds")
            out.append((hi - lo) ** 2 / 12 / v0 ** 2)
    return np.array(out, dtype=float)


def parameter_points(model, params: Sequence[str], n_points: int, box=None, seed: int = 0
                     ) -> tuple[list[np.ndarray], dict[str, tuple[float, float]]]:
    """The nominal point and ``n_points`` random points (uniform) of the parameter box, and the box
    ({name: (lower, upper)}).

    Parameters
    ----------
    box : mapping of str to (float, float), optional
        Per parameter its (lower, upper); default the model's bounds, where finite, else ±50 % of
        the nominal value.

    Raises
    ------
    InputError
        A box with lower >= upper (named), or for an unknown parameter.
    """
    idx = model.parameter_indices(list(params))
    p0 = model.values.copy()
    lo_m, hi_m = model.bounds
    given = dict(box or {})
    unknown = [k for k in given if k not in params]
    if unknown:
        raise InputError(f"box: {', '.join(unknown)} is not among the parameters to identify ({', '.join(params)})")
    lo, hi = [], []
    for j, name in zip(idx, params):
        if name in given:
            a, b = (float(v) for v in given[name])
        else:
            a = lo_m[j] if np.isfinite(lo_m[j]) else p0[j] - 0.5 * abs(p0[j])
            b = hi_m[j] if np.isfinite(hi_m[j]) else p0[j] + 0.5 * abs(p0[j])
            if p0[j] > 0 and np.isfinite(a) and a <= 0:  # a positive parameter's bound at 0: not a point to plan at
                a = 0.5 * p0[j] if not np.isfinite(hi_m[j]) else max(a, 1e-3 * p0[j])
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise InputError(f"box: parameter {name} has lower {a:g} >= upper {b:g}; give lower < upper")
        lo.append(a)
        hi.append(b)
    rng = np.random.default_rng(seed)
    points = [p0]
    for _ in range(int(n_points)):
        p = p0.copy()
        p[idx] = rng.uniform(lo, hi)
        points.append(p)
    return points, {n: (a, b) for n, a, b in zip(params, lo, hi)}


__all__ = ["Noise", "SensitivityBank", "fisher", "rank_and_condition", "Design", "design_kind", "design_value",
           "prior_variances", "parameter_points"]
