r"""Real modes of the undamped structure, :math:`K \phi = \lambda M \phi`.

Dense (LAPACK ``eigh``) for small models, sparse shift-invert Lanczos (ARPACK through
:func:`scipy.sparse.linalg.eigsh`) for large ones, chosen by size.  Rigid-body modes of
free-free structures are found with a negative shift.  Shapes are normalised to unit modal
mass (default), unit length, unit largest entry, or unit value at a reference dof.  The sparse
path (ARPACK with one factorisation of K − σM) is :mod:`femupdate.modal_sparse`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import ClassVar

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from . import rules
from ._checks import array_arg, count_arg, flag_arg, model_arg, modes_count, str_arg, values_arg
from ._errors import InputError, NumericalError
from ._threads import LARGE_DENSE, blas_phase
from .workspace import PIVOT_THRESHOLD, NotPositiveDefinite, factorize, nearly_singular  # noqa: F401  (named here too)
from .dofs import canonical, describe, index_of
from .modal_sparse import SHIFT_FRACTION, _sparse, _sparse_reused, arpack_options  # noqa: F401  (named here too)
from .static_loads import check_static_loads  # noqa: F401  (named here too)
from .serialise import RunContext, Serialisable

DENSE_LIMIT = 1500  # models up to this many dofs are solved densely when every mode (or no number) is asked for

#: when a number of modes is asked for, sparse shift-invert Lanczos is used from this many dofs on,
#: for at most SPARSE_MAX_SHARE of the model's modes.  Measured with one BLAS thread on frame
#: models, 10 modes: dense 25 ms against sparse 3 ms (through the model's workspace, warm-started)
#: at 456 dofs, 145 against 6 ms at 1,056 dofs, 769 against 13 ms at 1,512 dofs; dense ahead below
#: about 250 dofs (8 against 9 ms at 216)
SPARSE_FROM = 300
SPARSE_MAX_SHARE = 0.2


def eigensolver_for(n: int, n_modes: int | None, n_finite: int | None = None) -> str:
    """The path ``method="auto"`` takes: ``"dense"`` or ``"sparse"``.

    Dense when every mode is wanted (``n_modes`` None up to :data:`DENSE_LIMIT` dofs, or at least
    n_finite − 1 modes), or when the model is small (below :data:`SPARSE_FROM` dofs) or the
    modes asked for are more than :data:`SPARSE_MAX_SHARE` of its modes (up to
    :data:`DENSE_LIMIT` dofs); sparse otherwise.

    Parameters
    ----------
    n : int
        Dofs of the model.
    n_modes : int or None
        Modes asked for (None: the default number).
    n_finite : int, optional
        Dofs with mass (default n).

    Returns
    -------
    str
    """
    n_finite = n if n_finite is None else n_finite
    if n_modes is None:
        return "dense" if n <= DENSE_LIMIT else "sparse"
    if n_modes >= n_finite - 1:
        return "dense"
    if n <= DENSE_LIMIT and (n < SPARSE_FROM or n_modes > SPARSE_MAX_SHARE * n_finite):
        return "dense"
    return "sparse"
NORMALISATIONS = ("mass", "unit", "max")


@dataclass(frozen=True, eq=False)
class Modes(Serialisable):
    """Modes with labelled dofs.

    Built by :func:`solve_modes` / :func:`model_modes`; each parameter is stored as the
    attribute of the same name.  A result of kind ``modes`` (:mod:`femupdate.serialise`):
    ``to_json()`` is what ``femupdate modes --json`` writes (with the model's name and parameter
    values when made by :func:`model_modes`), ``to_frame()`` one row per mode (:meth:`records`).

    Parameters
    ----------
    eigenvalues : ndarray, shape ``(n_modes,)``
        :math:`\\lambda = \\omega^2` in rad^2/s^2, ascending.
    shapes : ndarray, shape ``(n_dofs, n_modes)``
        Column r is mode r on ``dofs``.
    dofs : tuple of str
        Dof labels ``"node:dir"`` of the rows of ``shapes``.
    normalisation : str
        ``"mass"``, ``"unit"``, ``"max"`` or ``"ref:<dof>"``.
    n_rigid : int
        Number of rigid-body (zero-frequency) modes among them.
    factor : tuple (lu, sigma) or None
        The sparse path's factorisation of K − σM (SuperLU) and its shift: the series
        sensitivity routes reuse it instead of factorising again.  None on the dense path.
        It keeps the factor's memory alive as long as these modes are referenced.
    context : RunContext, optional
        The model and parameter values the modes were computed at (:func:`model_modes`; not
        serialised, :mod:`femupdate.serialise`).
    """

    kind: ClassVar[str] = "modes"

    eigenvalues: np.ndarray
    shapes: np.ndarray
    dofs: tuple[str, ...]
    normalisation: str = "mass"
    n_rigid: int = 0
    factor: object = field(default=None, repr=False, compare=False)
    context: RunContext | None = field(default=None, repr=False, compare=False)

    def payload(self) -> dict:
        from .modal_record import modes_kind

        return modes_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .modal_record import modes_from

        return modes_from(obj)

    def records(self) -> list[dict]:
        """One record per mode (0-based ``mode``, ``frequency_hz``, ``eigenvalue``): :meth:`to_frame`'s rows."""
        return [{"mode": r, "frequency_hz": float(f), "eigenvalue": float(v)}
                for r, (f, v) in enumerate(zip(self.frequencies_hz, self.eigenvalues))]

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Natural frequencies √λ / 2π in Hz, shape ``(n_modes,)`` (negative λ read as 0)."""
        return np.sqrt(np.clip(self.eigenvalues, 0.0, None)) / (2 * np.pi)

    @property
    def solver(self) -> str:
        """How these modes were computed: ``"dense (LAPACK)"``, or ``"sparse (ARPACK, <the
        factorisation of K − σM>)"`` — band Cholesky, PARDISO Cholesky, CHOLMOD Cholesky or SuperLU."""
        if self.factor is None:
            return "dense (LAPACK)"
        from .workspace import factor_name

        lu = self.factor[0] if isinstance(self.factor, tuple) else self.factor
        return f"sparse (ARPACK, {factor_name(lu)})"

    @property
    def n_modes(self) -> int:
        """Number of modes held."""
        return self.eigenvalues.size

    def at(self, dofs: Sequence[str]) -> np.ndarray:
        """Shape components at the given dof labels.

        Parameters
        ----------
        dofs : sequence of str
            Dof labels ``"node:dir"``, each one of :attr:`dofs`.

        Returns
        -------
        numpy.ndarray, shape ``(len(dofs), n_modes)``
            The rows of :attr:`shapes` at those dofs, in the order given.

        Raises
        ------
        InputError
            A label that is not one of :attr:`dofs`.
        """
        return self.shapes[index_of(self.dofs, dofs, "mode shapes"), :]

    def normalised(self, how: str, M=None) -> Modes:
        """Copy renormalised (``M`` is needed for ``"mass"``).

        Parameters
        ----------
        how : str
            ``"mass"``, ``"unit"``, ``"max"`` or ``"ref:<dof>"``, as :func:`normalise`.
        M : array_like or sparse matrix, shape ``(n_dofs, n_dofs)``, optional
            Mass matrix (kg), required for ``"mass"``.

        Returns
        -------
        Modes
            Same eigenvalues and dofs, rescaled shapes, ``normalisation=how``.

        Raises
        ------
        InputError, NumericalError
            As :func:`normalise`.
        """
        return replace(self, shapes=normalise(self.shapes, how, M=M, dofs=self.dofs), normalisation=how)


def _sign_fix(Phi: np.ndarray) -> np.ndarray:
    """Make the largest-magnitude entry of each column positive (deterministic signs).

    "Largest" is the first entry within a relative 1e-6 of the column's maximum, so that modes
    with entries of equal magnitude and opposite sign (antisymmetric shapes) get the same sign
    from every eigensolver, whatever its round-off."""
    A = np.abs(Phi)
    k = np.argmax(A >= (1.0 - 1e-6) * A.max(axis=0, initial=0.0), axis=0)
    s = np.sign(Phi[k, np.arange(Phi.shape[1])])
    s[s == 0] = 1.0
    return Phi * s


def normalise(Phi: np.ndarray, how: str = "mass", M=None, dofs: Sequence[str] | None = None) -> np.ndarray:
    """Scale each column of ``Phi``.

    ``"mass"``: :math:`\\phi^T M \\phi = 1`; ``"unit"``: :math:`\\|\\phi\\| = 1`; ``"max"``:
    largest-magnitude entry = +1; ``"ref:<dof>"``: entry at that dof = 1 (the paper's eq. 33
    scaling, "the amplitude of the first freedom being one").  Signs are made deterministic.

    Parameters
    ----------
    Phi : array_like, shape ``(n_dofs, n_modes)``
        Mode shapes, one per column (not modified; a scaled copy is returned).
    how : str, default ``"mass"``
        ``"mass"``, ``"unit"``, ``"max"`` or ``"ref:<dof>"``.
    M : array_like or sparse matrix, shape ``(n_dofs, n_dofs)``, optional
        Mass matrix (kg); required for ``"mass"``.
    dofs : sequence of str, optional
        Labels ``"node:dir"`` of the rows of ``Phi``; required for ``"ref:<dof>"``.

    Returns
    -------
    numpy.ndarray, shape ``(n_dofs, n_modes)``
        The scaled shapes.  With ``"mass"`` and M in kg, the entries are in kg^-1/2.

    Raises
    ------
    InputError
        Unknown ``how``; ``"mass"`` without ``M``; ``"ref:<dof>"`` without ``dofs`` or with a
        dof not among them.
    NumericalError
        A non-positive modal mass φᵀMφ (``"mass"``), or a mode with a zero at the reference dof
        (``"ref:<dof>"``).
    """
    array_arg(Phi, "Phi", "normalise", ndim=2, empty=False)
    str_arg(how, "how", "normalise")
    Phi = np.array(Phi, dtype=float, copy=True)
    if how == "mass":
        if M is None:
            raise InputError("mass normalisation needs the mass matrix")
        mm = np.einsum("ij,ij->j", Phi, M @ Phi)
        if np.any(mm <= 0):
            raise NumericalError("mass normalisation: a mode has non-positive modal mass (M not positive definite?)")
        return _sign_fix(Phi / np.sqrt(mm))
    if how == "unit":
        return _sign_fix(Phi / np.linalg.norm(Phi, axis=0))
    if how == "max":
        Phi = _sign_fix(Phi)
        return Phi / np.max(np.abs(Phi), axis=0)
    if how.startswith("ref:"):
        if dofs is None:
            raise InputError("reference-dof normalisation needs dof labels")
        ref = canonical(how[4:])
        (i,) = index_of(dofs, [ref], "normalisation reference")
        v = Phi[i]
        small = np.abs(v) <= 1e-12 * np.max(np.abs(Phi), axis=0)
        if np.any(small):
            bad = np.flatnonzero(small) + 1
            raise NumericalError(f"cannot scale to 1 at {ref}: mode(s) {bad.tolist()} have a node (zero) there")
        return Phi / v
    raise InputError(f"unknown normalisation {how!r}: use mass, unit, max or ref:<dof>")


def massless_dofs(M) -> np.ndarray:
    """(n,) bool: the dofs whose row of M is zero (no mass and no mass coupling) — the massless
    rotations of frame models as commercial codes export them.

    Parameters
    ----------
    M : array_like or sparse matrix, shape ``(n, n)``

    Returns
    -------
    numpy.ndarray of bool, shape ``(n,)``
    """
    if sp.issparse(M):
        return np.asarray(abs(sp.csr_array(M)).sum(axis=1)).ravel() == 0
    return ~np.any(np.asarray(M, float) != 0, axis=1)


def _check_mass(M, dofs) -> np.ndarray:
    """The massless dofs (:func:`massless_dofs`); any other dof without positive mass is refused."""
    d = M.diagonal()
    massless = massless_dofs(M)
    bad = np.flatnonzero(~(d > 0) & ~massless)
    neg = bad[d[bad] < 0]
    if neg.size:
        raise InputError("the mass matrix is not positive semi-definite: negative mass at dof(s) "
                         f"{describe([dofs[i] for i in neg]) if dofs else neg[:8].tolist()} (diagonal "
                         f"{', '.join(f'{d[i]:.4g}' for i in neg[:4])}{' ...' if neg.size > 4 else ''})")
    if bad.size:
        raise InputError("the mass matrix is not positive semi-definite: no positive mass at dof(s) "
                         f"{describe([dofs[i] for i in bad]) if dofs else bad[:8].tolist()}, which are coupled to "
                         "others by M (add mass there, or remove/condense those dofs)")
    if massless.all():
        raise InputError("the mass matrix is zero: no dof has mass")
    return massless


def solve_modes(K, M, n_modes: int | None = None, dofs: Sequence[str] | None = None, normalisation: str = "mass",
                method: str = "auto", sigma: float | None = None, tol: float = 0.0, workspace=None,
                start=None) -> Modes:
    """Lowest ``n_modes`` modes of the pencil (K, M).

    Parameters
    ----------
    K, M : array_like or sparse matrix, shape ``(n_dofs, n_dofs)``
        Stiffness (N/m) and mass (kg) matrices, symmetric; M positive semi-definite: rows of M
        that are zero (massless dofs) are condensed exactly (they follow the other dofs
        quasi-statically), so there is one mode per dof with mass.
    n_modes : int, optional
        Number of modes, between 1 and n_dofs, at most the number of dofs with mass (default:
        all for dense, ``min(10, n - 1)`` for sparse, n the dofs with mass).
    dofs : sequence of str, optional
        Labels ``"node:dir"`` of the matrix rows (required for ``ref:<dof>`` normalisation;
        default ``"1:x"``, ``"2:x"``, ...).
    normalisation : str, default ``"mass"``
        ``"mass"`` | ``"unit"`` | ``"max"`` | ``"ref:<dof>"``, as :func:`normalise`.
    method : str, default ``"auto"``
        ``"auto"`` | ``"dense"`` | ``"sparse"``.  ``auto``: :func:`eigensolver_for` — dense for
        every mode of a model up to :data:`DENSE_LIMIT` dofs, or when at least n_dofs − 1 modes
        are asked for; sparse from :data:`SPARSE_FROM` dofs when a few modes are asked for.
    sigma : float, optional
        Shift for shift-invert (sparse), rad²/s².  Default 0, or a small negative shift when K
        is singular (rigid-body modes).
    tol : float, default 0.0
        ARPACK's relative accuracy of the eigenvalues (sparse only; 0 means machine precision).
    workspace : femupdate.workspace.SparseWorkspace, optional
        Sparse only: the pattern's reusable ordering and factorisation route
        (:func:`femupdate.workspace.workspace_of`); ignored unless K and M have its pattern.
        Without it every call factorises afresh with SuperLU.
    start : Modes or (eigenvalues, shapes), optional
        Sparse with ``workspace`` only: modes of a nearby model (the previous iterate) to start
        from: ARPACK's starting vector is the sum of their shapes, and, when ``sigma`` is not
        given, the shift is :data:`SHIFT_FRACTION` times their lowest eigenvalue (checked: the
        shift must come out below every computed eigenvalue and at most half the highest,
        which proves they are the lowest of the model; else the solution is repeated at σ = 0).

    Returns
    -------
    Modes
        Eigenvalues λ = ω² (rad²/s²) ascending, with rigid-body ones set to exactly 0 and
        counted in ``n_rigid``; shapes normalised as asked; on the sparse path, the
        factorisation in ``factor``.

    Raises
    ------
    InputError
        K and M not square or of different sizes; a zero or negative diagonal mass entry, or a
        failed Cholesky factorisation of M (dense); ``n_modes`` out of range; an unknown
        ``method``; ``method="sparse"`` with ``n_modes >= n_dofs - 1``; a negative eigenvalue
        (K not positive semi-definite); and as :func:`normalise`.
    NumericalError
        The sparse eigensolver failed or did not converge; and as :func:`normalise`.
    """
    for what, A in (("K", K), ("M", M)):
        if not sp.issparse(A):  # an array of 2 dimensions
            array_arg(A, what, "solve_modes", ndim=2)
    count_arg(n_modes, "n_modes", "solve_modes", optional=True)
    n = K.shape[0]
    if K.shape != (n, n) or M.shape != (n, n):
        raise InputError(f"K {K.shape} and M {M.shape} must be square and of the same size")
    dofs = tuple(dofs) if dofs is not None else tuple(f"{i + 1}:x" for i in range(n))
    massless = _check_mass(M, dofs if dofs else None)
    n_finite = int(n - massless.sum())  # a massless dof adds an infinite eigenvalue, not a mode
    if method == "auto":
        method = eigensolver_for(n, None if n_modes is None else min(int(n_modes), n_finite), n_finite)
    if n_modes is None:
        n_modes = n_finite if method == "dense" else min(10, n_finite - 1)
    n_modes = int(n_modes)
    if not 1 <= n_modes <= n:
        raise InputError(f"n_modes must be between 1 and the number of dofs ({n}), got {n_modes}")
    n_modes = min(n_modes, n_finite)
    factor = None
    if method == "dense":
        with blas_phase("dense" if n >= LARGE_DENSE else "solve"):  # BLAS threads: femupdate._threads
            lam, Phi = _dense(K, M, n_modes, dofs, massless)
    elif method == "sparse":
        if n_modes >= n - 1:
            raise InputError(f"the sparse eigensolver computes fewer than n - 1 = {n - 1} modes of {n} dofs: use the "
                             "dense one (--method dense; method='dense' in Python)")
        with blas_phase("solve"):
            if workspace is not None and workspace.matches(K, M):
                lam, Phi, factor = _sparse_reused(K, M, n_modes, sigma, tol, workspace, start)
            else:
                lam, Phi, factor = _sparse(K, M, n_modes, sigma, tol)
    else:
        raise InputError(f"unknown eigensolver method {method!r}: use auto, dense or sparse")
    order = np.argsort(lam)
    lam, Phi = lam[order], Phi[:, order]
    # Scale of the pencil, whichever modes were asked for: the largest Rayleigh quotient of a
    # single dof (<= lambda_max).  Round-off leaves rigid-body eigenvalues at ~1e-16 of it, while
    # a genuine first mode of a fine beam/frame mesh can lie at 1e-10 of it.
    kd = np.abs(K.diagonal() if sp.issparse(K) else np.diag(np.asarray(K, float)))
    md = M.diagonal() if sp.issparse(M) else np.diag(np.asarray(M, float))
    lam = np.array(lam, float)
    computed = lam.copy()
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        ratio = kd[md > 0] / md[md > 0]
    if not np.all(np.isfinite(ratio)) or not np.all(np.isfinite(lam)):
        where = np.flatnonzero(md > 0)[~np.isfinite(ratio)]
        at = f" at dof(s) {describe([dofs[i] for i in where]) if dofs else where[:8].tolist()}" if where.size else ""
        raise InputError(f"the stiffness and mass matrices are too badly scaled for double precision{at} "
                         "(stiffness over mass overflows: a mass too small or a stiffness too large)")
    code, low = rules.check_spectrum(lam, lam.size, float(np.max(ratio)))
    if code != rules.OK:
        raise InputError(
            "K is not positive semi-definite: negative eigenvalue "
            f"{low:.4g} (check for negative stiffness parameters)"
        )
    for i in np.flatnonzero((lam == 0.0) & (computed != 0.0)):
        # zero by the pencil's scale, which one penalty stiffness (a rigid link) can dominate:
        # a rigid-body mode's strain energy is round-off of its terms, an elastic mode's is not
        if strain_energy_ratio(K, Phi[:, i]) > RIGID_ENERGY_TOL:
            lam[i] = computed[i]
    rigid = lam == 0.0
    Phi = normalise(Phi, normalisation, M=M, dofs=dofs)
    return Modes(lam, Phi, dofs, normalisation, int(rigid.sum()), factor)


#: a mode whose strain energy ``|φᵀKφ|`` exceeds this fraction of ``|φ|ᵀ|K||φ|`` is elastic, however small
#: its eigenvalue is next to the pencil's largest single-dof quotient (the compiled route's
#: :func:`femupdate.rules.restore_elastic` uses the same)
RIGID_ENERGY_TOL = rules.RIGID_ENERGY_TOL


def strain_energy_ratio(K, phi) -> float:
    """``|φᵀKφ| / (|φ|ᵀ|K||φ|)``: round-off (about 1e-16 to 1e-14) for a rigid-body mode, whose
    element energies cancel; far above for an elastic mode, even next to penalty stiffnesses.

    Parameters
    ----------
    K : array_like or sparse matrix, shape ``(n, n)``
    phi : numpy.ndarray, shape ``(n,)``

    Returns
    -------
    float
    """
    a = np.abs(phi)
    if sp.issparse(K):
        total = float(a @ (abs(sp.csr_array(K)) @ a))
        energy = float(phi @ (K @ phi))
    else:
        Kd = np.asarray(K, float)
        total = float(a @ np.abs(Kd) @ a)
        energy = float(phi @ Kd @ phi)
    return abs(energy) / total if total > 0 else 0.0


def _dense(K, M, n_modes, dofs, massless=None):
    Kd = K.toarray() if sp.issparse(K) else np.asarray(K, float)
    Md = M.toarray() if sp.issparse(M) else np.asarray(M, float)
    if massless is not None and massless.any():
        return _dense_condensed(Kd, Md, n_modes, dofs, massless)
    try:
        if n_modes < Kd.shape[0]:
            lam, Phi = sla.eigh(Kd, Md, subset_by_index=[0, n_modes - 1], driver="gvx")
        else:
            lam, Phi = sla.eigh(Kd, Md, driver="gvd")
    except np.linalg.LinAlgError:
        raise InputError("the mass matrix is not positive definite (its Cholesky factorisation failed)") from None
    return lam, Phi


def _dense_condensed(Kd, Md, n_modes, dofs, massless):
    """Modes of a pencil with massless dofs s: exact static condensation onto the others m,
    K̃ = K_mm − K_ms K_ss⁻¹ K_sm with M_mm, and φ_s = −K_ss⁻¹ K_sm φ_m (the massless dofs follow
    the others quasi-statically: that is what a zero mass means)."""
    s, m = np.flatnonzero(massless), np.flatnonzero(~massless)
    Kss, Ksm = Kd[np.ix_(s, s)], Kd[np.ix_(s, m)]
    try:
        c = sla.cho_factor(Kss)
    except np.linalg.LinAlgError:
        raise InputError(
            f"massless dof(s) {describe([dofs[i] for i in s])} are not held by positive definite stiffness (their "
            "block of K is singular or indefinite: a mechanism without mass); add stiffness or mass there"
        ) from None
    T = -sla.cho_solve(c, Ksm)
    Kr = Kd[np.ix_(m, m)] + Ksm.T @ T
    Kr = 0.5 * (Kr + Kr.T)
    Mr = Md[np.ix_(m, m)]
    try:
        if n_modes < m.size:
            lam, Pm = sla.eigh(Kr, Mr, subset_by_index=[0, n_modes - 1], driver="gvx")
        else:
            lam, Pm = sla.eigh(Kr, Mr, driver="gvd")
    except np.linalg.LinAlgError:
        raise InputError("the mass matrix is not positive definite on the dofs with mass (its Cholesky "
                         "factorisation failed)") from None
    Phi = np.zeros((Kd.shape[0], lam.size))
    Phi[m] = Pm
    Phi[s] = T @ Pm
    return lam, Phi


def model_modes(model, values=None, n_modes: int | None = None, normalisation: str = "mass", reuse: bool = True,
                **kw) -> Modes:
    """Modes of a :class:`femupdate.Model` at parameter values ``values`` (default nominal).

    :func:`solve_modes` on the model's K(p) and M(p), with the model's dof labels.

    Parameters
    ----------
    model : Model
        The parametrised model.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``
        Parameter values as :meth:`Model.resolve` reads them (default: nominal).
    n_modes : int, optional
        Number of modes (default as :func:`solve_modes`).
    normalisation : str, default ``"mass"``
        ``"mass"`` | ``"unit"`` | ``"max"`` | ``"ref:<dof>"``.
    reuse : bool, default True
        Sparse path: factorise through the model's :class:`~femupdate.workspace.SparseWorkspace`
        (the ordering and factorisation route found once per model and reused; the same
        eigenpairs to round-off); False: SuperLU afresh at every call.
    **kw
        Further options of :func:`solve_modes`: ``method``, ``sigma``, ``tol``, ``start``.

    Returns
    -------
    Modes
        With its context: the model and the parameter values (``to_json()`` names them).

    Raises
    ------
    InputError, NumericalError
        As :meth:`Model.resolve` and :func:`solve_modes`.
    """
    model_arg(model, "model", "model_modes")
    values_arg(model, values, "values", "model_modes")
    modes_count(model, n_modes, "n_modes", "model_modes")
    str_arg(normalisation, "normalisation", "model_modes")
    flag_arg(reuse, "reuse", "model_modes")
    p = model.resolve(values)
    K, M = model.K(p), model.M(p)
    if (reuse and "workspace" not in kw and kw.get("method", "auto") in ("auto", "sparse")
            and (kw.get("method") == "sparse" or eigensolver_for(model.n_dofs, n_modes) == "sparse")):
        from .workspace import workspace_of

        kw["workspace"] = workspace_of(model, K, M)
    try:
        modes = solve_modes(K, M, n_modes=n_modes, dofs=model.dofs, normalisation=normalisation, **kw)
    except InputError as exc:
        from .flags import suspect_values

        suspects = suspect_values(model, p)
        if not suspects or "positive" not in str(exc):
            raise
        raise InputError(f"{exc}; at parameter value(s) {suspects}") from None
    return replace(modes, context=RunContext(model=model, before=dict(zip(model.parameter_names, p.tolist()))))
