r"""The modal dynamic residual: the equilibrium of the full model at each measured mode.

Per test mode k, with its measured eigenvalue λ_k and its shape scaled as the test data give it
(unit length over the measured dofs), the full shape φ_k has the measured entries fixed to the
test values ψ_k and the unmeasured entries u_k as unknowns; the residual is the equilibrium of
every dof of the model (Farhat & Hemez 1993; Zhu, Dong & Wang 2016, the modal dynamic residual
approach):

.. math::  r_k(p, u_k) = \frac{w_k}{c_k}\,\bigl(K(p) - \lambda_k M(p)\bigr)
           \begin{bmatrix}\psi_k \\ u_k\end{bmatrix}

No eigen-solution is needed, so a model with massless dofs is fine.  The unmeasured entries
enter linearly: for each p they are solved for exactly, u_k(p) = argmin ‖r_k(p, u)‖ (variable
projection, Golub & Pereyra 1973), and the solver iterates over the parameters alone.  The
minimum over (p, u) is the minimum over p of the projected residual, so nothing is lost; the
parameters' bounds, regularisation, multi-start clustering and diagnostics stay those of the
parameters, and the covariance of the diagnostics is the parameters' marginal covariance (the
Schur complement of the joint one).  The Jacobian of the projected residual is exact: with
A = (K − λ_k M)/c_k, B = A[:, u] and A_j = (K_j − λ_k M_j)/c_k (K_j = ∂K/∂p_j: constant for an
affine model, taken at p by the chain rule for a non-linear one),

.. math::  \frac{\partial r}{\partial p_j} = P^\perp A_j\varphi - B\,(B^T B)^{-1}
           A_j[:, u]^T r, \qquad P^\perp = I - B (B^T B)^{-1} B^T

(the derivative of the joint residual, :math:`A_j\varphi` in p and :math:`B` in u, with
:math:`\partial u/\partial p_j` from differentiating the normal equations :math:`B^T r = 0`).

Normalisation: :math:`c_k = \lambda_k \|M(p_0)\,\varphi_k^0\|`, with p_0 the nominal parameter
values (the model's, or the fixed ``values``; not the start, so that every start of a
multi-start study solves the same problem) and φ_k^0 the test shape expanded on the nominal
model.  A model whose shape matches the test shape exactly but whose eigenvalue is
λ_A = (1 + δ) λ_k then has ‖r_k‖ = ``|δ|`` ‖Mφ‖/‖M_0φ^0‖ ≈ ``|δ|``: the dynamic residual is
dimensionless and of the size of the relative eigenvalue error of the other formulations, and
does not depend on how the test shape is scaled.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._errors import InputError, NumericalError
from .targets import Targets

#: models up to this many dofs expand the shapes by a dense QR factorisation; larger ones by a
#: sparse LU factorisation of the augmented system [[I, B], [Bᵀ, 0]]
DENSE_DYNAMIC = 1000


def _undetermined(k: int) -> str:
    return (f"test mode {k + 1}: the equilibrium equations do not determine the unmeasured entries of its shape "
            "(the model has a mode at the measured frequency that vanishes at every measured dof): measure more "
            "dofs, or use another formulation (--formulation shapes or mac)")


class _Expansion:
    """One test mode's shape expanded at one point: its full shape, residual and the
    factorisation that differentiates them."""

    def __init__(self, k: int, A, m: np.ndarray, u: np.ndarray, psi: np.ndarray, dense: bool):
        n = A.shape[0]
        self.k, self.m, self.u, self.dense = k, m, u, dense
        b = np.asarray(A[:, m] @ psi, float)
        phi = np.zeros(n)
        phi[m] = psi
        if u.size == 0:
            r = np.asarray(b, float)
        elif dense:
            Q, R = sla.qr(A[:, u], mode="economic")
            d = np.abs(np.diag(R))
            if not d.size or not d.min() > n * np.finfo(float).eps * d.max():
                raise NumericalError(_undetermined(k))
            self.Q, self.R = Q, R
            qb = Q.T @ b
            phi[u] = -sla.solve_triangular(R, qb)
            r = b - Q @ qb
        else:
            Bu = A[:, u]
            aug = sp.bmat([[sp.eye(n, format="csc"), Bu], [Bu.T, None]], format="csc")
            try:
                self.lu = spla.splu(aug)
            except RuntimeError:
                raise NumericalError(_undetermined(k)) from None
            sol = self.lu.solve(np.concatenate([b, np.zeros(u.size)]))
            phi[u] = -sol[n:]
            r = sol[:n]
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(phi))):
            raise NumericalError(_undetermined(k))
        self.phi, self.r = phi, r

    def derivative(self, V: np.ndarray, G: np.ndarray) -> np.ndarray:
        """∂r/∂p (n, L) from V = A_j φ (n, L) and G = A_j[:, u]ᵀ r (n_u, L)."""
        if self.u.size == 0:
            return V
        if self.dense:
            return V - self.Q @ (self.Q.T @ V) - self.Q @ sla.solve_triangular(self.R, G, trans="T")
        n = V.shape[0]
        return self.lu.solve(np.vstack([V, -G]))[:n]


class DynamicResidual:
    """The modal dynamic residuals of the test modes of ``targets`` on ``model``, and their exact
    Jacobian (see the module).

    Parameters
    ----------
    model : Model
        The model (affine in its parameters).
    targets : Targets
        The measured modes; every one must have a compared shape.
    idx : numpy.ndarray of int
        The updated parameters (indices into the model's parameter vector).
    p_nominal : numpy.ndarray, shape ``(n_parameters,)``
        The nominal parameter values p_0 of the normalisation.

    Attributes
    ----------
    c : numpy.ndarray, shape ``(T,)``
        The normalisation c_k = λ_k ‖M(p_0) φ_k^0‖ of each test mode.

    Raises
    ------
    InputError
        A test mode's expanded nominal shape carries no mass (c_k = 0).
    NumericalError
        The unmeasured entries of a test shape are not determined at the nominal values.
    """

    def __init__(self, model, targets: Targets, idx: np.ndarray, p_nominal: np.ndarray):
        self.model = model
        self.targets = targets
        self.n = int(model.n_dofs)
        self.idx = np.asarray(idx, np.intp)
        self.dense = self.n <= DENSE_DYNAMIC
        T = targets.n_test
        self.m = [np.asarray(targets.pos[targets.measured(k)], np.intp) for k in range(T)]
        self.u = [np.setdiff1d(np.arange(self.n), mk) for mk in self.m]
        self.psi = [np.asarray(targets.psi_e[targets.measured(k)], float) for k in range(T)]
        self._stacks_at: bytes | None = None
        self._stacks(np.asarray(p_nominal, float))
        K0, M0 = model.K(p_nominal).tocsc(), model.M(p_nominal).tocsc()
        self.c = np.ones(T)
        for k in range(T):
            lam = float(targets.lam_e[k])
            A0 = K0 - lam * M0
            scale = float(abs(A0).max()) or 1.0  # any positive factor: the expansion does not depend on it
            phi0 = self._expand(k, A0 / scale).phi
            c = lam * float(np.linalg.norm(M0 @ phi0))
            if not (np.isfinite(c) and c > 0):
                raise InputError(f"test mode {k + 1}: its shape expanded on the nominal model carries no mass, so "
                                 "its dynamic residual cannot be normalised; use another formulation")
            self.c[k] = c
        self._key: bytes | None = None
        self._cache: list[_Expansion] = []

    def _stacks(self, p: np.ndarray) -> None:
        """The derivative matrices stacked, (L·n, n), and their transposes: A_j φ and A_jᵀ r of every
        parameter in one product each.  An affine model's once; a non-linear model's at each p (the
        chain rule, :meth:`Model.dK_dp <femupdate.Model.dK_dp>`)."""
        key = b"" if self.model.is_affine else p.tobytes()
        if key == self._stacks_at:
            return
        dK = [self.model.dK_dp(int(j), p) for j in self.idx]
        dM = [self.model.dM_dp(int(j), p) for j in self.idx]
        empty = sp.csr_array((0, self.n))
        self.DK = sp.csr_array(sp.vstack(dK or [empty], format="csr"))
        self.DM = sp.csr_array(sp.vstack(dM or [empty], format="csr"))
        self.DKT = sp.csr_array(sp.vstack([d.T for d in dK] or [empty], format="csr"))
        self.DMT = sp.csr_array(sp.vstack([d.T for d in dM] or [empty], format="csr"))
        self._stacks_at = key

    def _matrix(self, K, M, k: int):
        """A = (K − λ_k M) / c_k, dense (K and M given dense) or sparse."""
        A = (K - float(self.targets.lam_e[k]) * M) / self.c[k]
        return A if self.dense else sp.csc_array(A)

    def _expand(self, k: int, A) -> _Expansion:
        if self.dense and sp.issparse(A):
            A = A.toarray()
        elif not self.dense:
            A = sp.csc_array(A)
        return _Expansion(k, A, self.m[k], self.u[k], self.psi[k], self.dense)

    def expansions(self, p: np.ndarray) -> list[_Expansion]:
        """Each test mode's expansion at the full parameter vector p (the last p is cached)."""
        p = np.asarray(p, float)
        key = p.tobytes()
        if key != self._key:
            K, M = self.model.K(p), self.model.M(p)
            K, M = (K.toarray(), M.toarray()) if self.dense else (K.tocsc(), M.tocsc())
            self._cache = [self._expand(k, self._matrix(K, M, k)) for k in range(self.targets.n_test)]
            self._key = key
        return self._cache

    def shapes(self, p: np.ndarray) -> np.ndarray:
        """The expanded full shapes at p, (n_dofs, T): the measured entries the scaled test shape,
        the others those that minimise the residual."""
        return np.column_stack([e.phi for e in self.expansions(p)])

    def residuals(self, p: np.ndarray) -> np.ndarray:
        """The weighted residuals at p, (T · n_dofs,), mode after mode."""
        tg = self.targets
        return np.concatenate([tg.w_lam[e.k] * e.r for e in self.expansions(p)])

    def jacobian(self, p: np.ndarray, dpdx: np.ndarray) -> np.ndarray:
        """∂r/∂x at p, (T · n_dofs, L), with ∂p/∂x ``dpdx``."""
        tg = self.targets
        L = self.idx.size
        self._stacks(np.asarray(p, float))
        out = np.zeros((tg.n_test * self.n, L))
        for e in self.expansions(p):
            lam, c = float(tg.lam_e[e.k]), self.c[e.k]
            V = ((self.DK @ e.phi - lam * (self.DM @ e.phi)) / c).reshape(L, self.n).T  # A_j φ
            G = ((self.DKT @ e.r - lam * (self.DMT @ e.r)) / c).reshape(L, self.n).T[e.u]  # A_j[:, u]ᵀ r
            out[e.k * self.n:(e.k + 1) * self.n] = tg.w_lam[e.k] * e.derivative(V, G) * dpdx[None, :]
        return out


__all__ = ["DynamicResidual", "DENSE_DYNAMIC"]
