r"""Complex modes of a damped model: the quadratic eigenproblem by its state-space form.

.. math::  (\lambda^2 M + \lambda C + K + iD)\,\varphi = 0
           \quad\Longleftrightarrow\quad
           \begin{bmatrix} 0 & I \\ -(K + iD) & -C \end{bmatrix} z
           = \lambda \begin{bmatrix} I & 0 \\ 0 & M \end{bmatrix} z,
           \qquad z = \begin{bmatrix} \varphi \\ \lambda\varphi \end{bmatrix}

(Tisseur & Meerbergen, "The quadratic eigenvalue problem", SIAM Review 43(2), 2001, the first
companion linearisation).  Small models: every eigenvalue by :func:`scipy.linalg.eig` on the
dense pencil; large ones: the eigenvalues nearest a shift σ by shift-invert Arnoldi
(:func:`scipy.sparse.linalg.eigs` on :math:`(A - \sigma B)^{-1} B`, one sparse LU).

Each underdamped mode is kept once, with :math:`\operatorname{Im}\lambda > 0` (viscous damping
gives conjugate pairs; with hysteretic damping the other root of each pair has a positive real
part and no physical meaning: the usual convention).  Eigenvalues are sorted by
:math:`|\lambda|` (the undamped natural frequency of a proportionally damped mode).  The
shapes are normalised so that

.. math::  \varphi^T (2\lambda M + C)\, \varphi = 1

(plain transpose, no conjugate: the normalisation of the state-space form
:math:`z^T \begin{bmatrix} C & M \\ M & 0\end{bmatrix} z = 1`, under which the left eigenvector
of the symmetric problem is :math:`\varphi` itself and the receptance is
:math:`H(s) = \sum_r \varphi_r\varphi_r^T/(s - \lambda_r) + \text{conjugates}`).

A model whose damping makes it unstable (an eigenvalue with a positive real part) is refused.
Modal damping ratios (:class:`DampedModel` ``modal``) act in the real modal coordinates of the
first undamped modes: :math:`\tilde M = I`, :math:`\tilde K = \operatorname{diag}(\omega_r^2) +
i\Phi^T D\Phi`, :math:`\tilde C = \Phi^T C \Phi + \operatorname{diag}(2\zeta_r\omega_r)`; the
complex modes are :math:`\Phi q` with :math:`q^T(2\lambda I + \tilde C) q = 1`
(:mod:`femupdate.damping.modal_ratios`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._errors import InputError, NumericalError
from ..workspace import nearly_singular
from .complexity import mean_phase_deviation, modal_phase_collinearity
from .model import DampedModel

#: models up to this many dofs are solved densely (every eigenvalue) by default
DENSE_LIMIT = 400


@dataclass(frozen=True, eq=False)
class ComplexModes:
    r"""Complex modes with labelled dofs.

    Attributes
    ----------
    eigenvalues : numpy.ndarray of complex, shape ``(n_modes,)``
        :math:`\lambda_r = -\zeta_r\omega_r + i\omega_r\sqrt{1 - \zeta_r^2}` (rad/s),
        :math:`\operatorname{Im}\lambda_r > 0`, by ascending :math:`|\lambda_r|`.
    shapes : numpy.ndarray of complex, shape ``(n_dofs, n_modes)``
        :math:`\varphi_r`, normalised :math:`\varphi^T(2\lambda M + C)\varphi = 1`.
    dofs : tuple of str
    solver : str
        ``"dense"``, ``"sparse (sigma=...)"``, or ``"modal coordinates (N modes)"``.
    n_rigid : int
        Zero eigenvalues of the state-space form left out (two per undamped rigid-body mode).
    n_overdamped : int
        Real negative eigenvalues (overdamped motions) left out.
    modal : bool
        Solved in modal coordinates (modal damping ratios): the normalisation holds there.
    """

    eigenvalues: np.ndarray
    shapes: np.ndarray
    dofs: tuple
    solver: str = "dense"
    n_rigid: int = 0
    n_overdamped: int = 0
    modal: bool = False

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.eigenvalues.size)

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        r""":math:`|\lambda|/2\pi` (Hz)."""
        return np.abs(self.eigenvalues) / (2 * np.pi)

    @property
    def damped_frequencies_hz(self) -> np.ndarray:
        r""":math:`\operatorname{Im}\lambda/2\pi` (Hz)."""
        return self.eigenvalues.imag / (2 * np.pi)

    @property
    def damping_ratios(self) -> np.ndarray:
        r""":math:`\zeta = -\operatorname{Re}\lambda/|\lambda|` (fractions of critical damping)."""
        return -self.eigenvalues.real / np.abs(self.eigenvalues)

    @property
    def mpc(self) -> np.ndarray:
        """Modal phase collinearity of each shape (:func:`~femupdate.damping.modal_phase_collinearity`)."""
        return modal_phase_collinearity(self.shapes)

    @property
    def mpd(self) -> np.ndarray:
        """Mean phase deviation of each shape, degrees (:func:`~femupdate.damping.mean_phase_deviation`)."""
        return mean_phase_deviation(self.shapes)

    def to_json(self, model: str = "", parameters=None) -> dict:
        """The ``complex-modes`` result (docs/file-formats.md): per mode λ as ``[re, im]``, the
        frequencies, ζ, MPC and MPD, and the shapes as ``[re, im]`` pairs.

        Parameters
        ----------
        model : str, default ""
            The model's name.
        parameters : mapping of str to float, optional
            The parameter values used.
        """
        from ..serialise import SCHEMA_VERSION

        pairs = lambda z: [[float(v.real), float(v.imag)] for v in z]  # noqa: E731
        return {"kind": "complex-modes", "schema_version": SCHEMA_VERSION, "model": model,
                "eigenvalues": pairs(self.eigenvalues),
                "natural_frequencies_hz": self.natural_frequencies_hz.tolist(),
                "damped_frequencies_hz": self.damped_frequencies_hz.tolist(),
                "damping_ratios": self.damping_ratios.tolist(), "mpc": self.mpc.tolist(), "mpd_deg": self.mpd.tolist(),
                "dofs": list(self.dofs), "shapes": [pairs(self.shapes[:, r]) for r in range(self.n_modes)],
                "normalisation": "modal coordinates" if self.modal else "phi^T (2 lambda M + C) phi = 1",
                "solver": self.solver, "n_rigid": self.n_rigid, "n_overdamped": self.n_overdamped,
                "parameters": None if parameters is None else {k: float(v) for k, v in dict(parameters).items()}}


def complex_modes(dm: DampedModel, n_modes: int | None = None, values=None, method: str = "auto",
                  sigma: complex | None = None) -> ComplexModes:
    r"""The lowest complex modes of a damped model.

    Parameters
    ----------
    dm : DampedModel
    n_modes : int, optional
        Number of underdamped modes (default: every one for dense, 6 for sparse; with modal
        damping ratios, as many as ratios).
    values : None, mapping or array_like, optional
        Parameter values (:meth:`DampedModel.resolve`); default nominal.
    method : str, default ``"auto"``
        ``"dense"``, ``"sparse"`` or ``"auto"`` (dense up to :data:`DENSE_LIMIT` dofs).
    sigma : complex, optional
        Sparse shift (rad/s); default 0 (just below 0 when K is singular).

    Returns
    -------
    ComplexModes

    Raises
    ------
    InputError
        An unknown method; ``n_modes`` < 1; the damped model is unstable (an eigenvalue with a
        positive real part: a negative damper, an indefinite C, or a stiffness that is not
        positive semi-definite).
    NumericalError
        The sparse eigensolver did not converge.
    """
    if method not in ("auto", "dense", "sparse"):
        raise InputError(f"complex modes: method must be auto, dense or sparse, got {method!r}")
    if n_modes is not None and (isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or n_modes < 1):
        raise InputError(f"complex modes: n_modes must be an integer >= 1, got {n_modes!r}")
    p = dm.resolve(values)
    K, M, C = dm.K(p), dm.M(p), dm.C(p)
    Kc = (K + 1j * dm.D(p)) if dm.hysteretic else K
    if dm.modal:
        from .modal_ratios import modal_modes

        lam, Phi, n_rigid, n_over, m = modal_modes(dm, p, n_modes, _select, normalise)
        return ComplexModes(lam, Phi, dm.dofs, f"modal coordinates ({m} modes)", n_rigid, n_over, modal=True)
    n = dm.n_dofs
    dense = method == "dense" or (method == "auto" and n <= DENSE_LIMIT)
    scale = _scale(K, M)
    if dense:
        A, B = _pencil(Kc, M, C, dense=True, s=scale)
        lam, Z = la.eig(A, B)
        lam, Phi, n_rigid, n_over = _select(dm, lam, Z[:n], scale, n_modes)
        solver = "dense"
    else:
        want, k = n_modes or min(6, n - 1), 2 * (n_modes or min(6, n - 1)) + 4
        while True:  # more eigenvalues when rigid-body or overdamped ones took the places of modes
            lam, Z, s = _sparse(Kc, M, C, k, sigma, scale)
            found = _select(dm, lam, Z[:n], scale, None)
            if found[0].size >= want or k >= 2 * n - 2:
                break
            k = min(2 * k, 2 * n - 2)
        if found[0].size < want:
            raise InputError(f"complex modes: the sparse solver found {found[0].size} underdamped mode(s) among the "
                             f"{k} eigenvalues nearest sigma = {s:.4g}, {want} asked for; use method='dense'")
        lam, Phi, n_rigid, n_over = found[0][:want], found[1][:, :want], found[2], found[3]
        solver = f"sparse (sigma={s:.4g})"
    Phi = normalise(Phi, lam, M, C)
    return ComplexModes(lam, Phi, dm.dofs, solver, n_rigid, n_over)


def _scale(K, M) -> float:
    """The pencil's frequency scale (rad/s): √(median K_ii/M_ii) over dofs with both."""
    d, md = np.abs(K.diagonal()), M.diagonal()
    both = (d > 0) & (md > 0)
    return float(np.sqrt(np.median(d[both] / md[both]))) if np.any(both) else 1.0


def _pencil(Kc, M, C, dense: bool, s: float = 1.0):
    """The state-space pencil of z = [s φ; λ φ] (s the frequency scale balances the blocks)."""
    n = M.shape[0]
    eye = sp.identity(n, format="csr")
    A = sp.block_array([[None, s * eye], [-Kc / s, -C]], format="csc")
    B = sp.block_array([[eye, None], [None, M]], format="csc")
    A = A.astype(complex if np.iscomplexobj(Kc.data) else float)
    return (A.toarray(), B.toarray()) if dense else (A, B)


def _sparse(Kc, M, C, k: int, sigma, scale: float):
    n = M.shape[0]
    A, B = _pencil(Kc, M, C, dense=False, s=scale)
    A = A.astype(complex)
    k = min(k, 2 * n - 2)
    s = complex(sigma) if sigma is not None else 0.0
    for attempt in range(2):
        try:
            lu = spla.splu(sp.csc_array(A - s * B))
            if not np.all(np.isfinite(lu.U.diagonal())) or nearly_singular(lu):
                raise RuntimeError("singular")
            break
        except RuntimeError:
            if sigma is not None or attempt:
                raise InputError(f"complex modes: the shift sigma = {s:.4g} is an eigenvalue (A - sigma B is "
                                 "singular); give another sigma") from None
            s = -1e-3 * scale  # K singular (rigid-body modes): just left of zero
    op = spla.LinearOperator(A.shape, matvec=lambda x: lu.solve(np.asarray(B @ x, dtype=complex)), dtype=complex)
    try:
        mu, Z = spla.eigs(op, k=k, which="LM", v0=np.ones(A.shape[0], dtype=complex))
    except spla.ArpackNoConvergence as exc:
        raise NumericalError(f"complex modes: the sparse eigensolver did not converge ({exc})") from None
    with np.errstate(divide="ignore"):
        lam = s + 1.0 / mu
    return lam, Z, s


def _select(dm, lam, Phi, scale: float, n_modes):
    """Drop infinite, rigid-body and overdamped eigenvalues; refuse instability; keep Im > 0."""
    ok = np.isfinite(lam)
    lam, Phi = lam[ok], Phi[:, ok]
    mag = np.abs(lam)
    rigid = mag <= 1e-7 * scale
    tol = 1e-8 * np.maximum(mag, scale)
    upper = (lam.imag >= -tol) & ~rigid  # one root of each pair (the physical one with hysteretic damping)
    unstable = upper & (lam.real > tol)
    if np.any(unstable):
        r = int(np.flatnonzero(unstable)[np.argmin(mag[unstable])])
        v = lam[r]
        raise InputError(f"damped model {dm.name!r} is unstable: eigenvalue {v.real:.6g}{v.imag:+.6g}i "
                         f"({abs(v) / (2 * np.pi):.4g} Hz) has a positive real part; the damping must dissipate "
                         "energy (dampers and damping parameters >= 0, C positive semi-definite) and K be "
                         "positive semi-definite")
    osc = upper & (lam.imag > tol)
    over = int(np.sum(upper & ~osc))
    order = np.flatnonzero(osc)[np.argsort(mag[osc], kind="stable")]
    if n_modes is not None:
        if n_modes > order.size:
            raise InputError(f"complex modes: {n_modes} modes asked for, the model has {order.size} underdamped modes")
        order = order[:n_modes]
    return lam[order], Phi[:, order], int(np.sum(rigid)), over


def normalise(Phi: np.ndarray, lam: np.ndarray, M, C) -> np.ndarray:
    r"""Scale each column so that :math:`\varphi^T(2\lambda M + C)\varphi = 1` (plain transpose).

    Parameters
    ----------
    Phi : numpy.ndarray of complex, shape ``(n_dofs, n_modes)``
    lam : numpy.ndarray of complex, shape ``(n_modes,)``
    M, C : sparse or dense matrices, shape ``(n_dofs, n_dofs)``

    Returns
    -------
    numpy.ndarray of complex
        The scaled shapes (a new array), the largest entry of each with a positive real part.

    Raises
    ------
    NumericalError
        A mode whose :math:`\varphi^T(2\lambda M + C)\varphi` vanishes (a defective eigenvalue).
    """
    out = np.array(Phi, dtype=complex)
    for r, v in enumerate(lam):
        phi = out[:, r]
        s = phi @ (2 * v * (M @ phi) + C @ phi)
        if abs(s) <= 1e-13 * np.linalg.norm(phi) ** 2 * (abs(2 * v) * abs(M).max() + abs(C).max() + 1e-300):
            raise NumericalError(f"complex mode {r + 1} (eigenvalue {v:.6g}) cannot be normalised: "
                                 "phi^T (2 lambda M + C) phi vanishes (a repeated, defective eigenvalue)")
        phi = phi / np.sqrt(s)
        k = int(np.argmax(np.abs(phi)))
        out[:, r] = -phi if phi[k].real < 0 else phi
    return out


__all__ = ["ComplexModes", "complex_modes", "normalise", "DENSE_LIMIT"]
