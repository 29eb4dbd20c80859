r"""Dynamic stiffness per spectral line, its solves, and the distance of each line to resonance.

The forced, steady-state response at ω (paper eq. 23, with optional damping) is

.. math::  Z(\omega)\,x = f, \qquad
           Z(\omega) = (1 + i\eta + i\omega\beta)\,K(p) + (i\omega a - \omega^2)\,M(p),

undamped (:math:`Z = K - \omega^2 M`, real) unless a :class:`Damping` is given: viscous
proportional damping :math:`C = aM + bK` (Rayleigh) and/or structural (hysteretic) damping
:math:`i\eta K`.  Because the model is affine, :math:`\partial Z/\partial p_j = c_K\,K_j + c_M\,M_j`
with the same two scalars :math:`c_K(\omega) = 1 + i\eta + i\omega b`,
:math:`c_M(\omega) = i\omega a - \omega^2`.

Two solution paths, chosen by size: small models stack every line's dense Z into one
``(n_lines, n, n)`` array and solve them in one LAPACK call; large ones factorise each line's
sparse Z once (SuperLU with a symmetric ordering, :func:`femupdate.modal.factorize`) and reuse the
factor for every right-hand side.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .._errors import InputError, NumericalError
from ..dofs import canonical, describe
from ..modal import arpack_options

log = logging.getLogger(__name__)

#: models up to this many dofs stack their lines densely; larger ones use sparse LU per line
DENSE_LIMIT = 200
#: bytes allowed for one stacked block of dense dynamic stiffness matrices
BLOCK_BYTES = 64 * 2**20


def nonnegative(value, what: str) -> float:
    """``value`` as a finite float >= 0, or an :class:`InputError` naming ``what``.

    Parameters
    ----------
    value : object
        Anything :class:`float` converts (a number, a numeric string, a size-1 array).
    what : str
        Its name in messages.

    Returns
    -------
    float
        ``float(value)``.

    Raises
    ------
    InputError
        ``value`` is not a number, or is negative, NaN or infinite.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise InputError(f"{what} = {v!r} must be finite and >= 0")
    return v


@dataclass(frozen=True)
class Damping:
    r"""Proportional viscous and structural damping of the FRF model.

    Attributes
    ----------
    alpha, beta : float
        Rayleigh coefficients of :math:`C = \alpha M + \beta K` (1/s and s), >= 0.
    eta : float
        Structural (hysteretic) loss factor: stiffness :math:`K(1 + i\eta)`, >= 0.

    The default is undamped (the paper's assumption): receptances are then real.
    """

    alpha: float = 0.0
    beta: float = 0.0
    eta: float = 0.0

    def __post_init__(self):
        for name in ("alpha", "beta", "eta"):
            object.__setattr__(self, name, nonnegative(getattr(self, name), f"damping {name}"))

    @property
    def undamped(self) -> bool:
        """True when alpha, beta and eta are all 0 (receptances are then real)."""
        return self.alpha == 0 and self.beta == 0 and self.eta == 0

    def coefficients(self, omega) -> tuple[np.ndarray, np.ndarray]:
        r"""``(c_K, c_M)`` per line: :math:`Z = c_K K + c_M M` (real when undamped).

        Parameters
        ----------
        omega : float or array_like of float, shape ``(n_lines,)``
            Circular frequencies ω (rad/s).

        Returns
        -------
        c_K : numpy.ndarray, shape of ``omega``
            :math:`1 + i\eta + i\omega\beta` (dimensionless); ones (float) when undamped.
        c_M : numpy.ndarray, shape of ``omega``
            :math:`i\omega\alpha - \omega^2` (rad²/s²); :math:`-\omega^2` (float) when undamped.
        """
        w = np.asarray(omega, float)
        if self.undamped:
            return np.ones_like(w), -(w**2)
        return 1.0 + 1j * self.eta + 1j * w * self.beta, 1j * w * self.alpha - w**2

    def as_dict(self) -> dict:
        """``{"alpha": ..., "beta": ..., "eta": ...}`` (the keys :func:`as_damping` takes)."""
        return {"alpha": self.alpha, "beta": self.beta, "eta": self.eta}

    def modal_damping_ratio(self, omega) -> np.ndarray:
        r"""The modal damping ratio of an undamped mode of circular frequency ω:
        :math:`\zeta = \alpha/(2\omega) + \beta\omega/2 + \eta/2` (Rayleigh damping is
        diagonal in the real modes; a loss factor η is the viscous ratio η/2 at resonance).

        Parameters
        ----------
        omega : float or array_like of float
            The modes' circular frequencies ω = √λ (rad/s), > 0 where ``alpha`` > 0.

        Returns
        -------
        numpy.ndarray
            ζ per mode (infinite at ω = 0 when ``alpha`` > 0).
        """
        w = np.asarray(omega, float)
        with np.errstate(divide="ignore"):
            mass_term = np.where(w > 0, self.alpha / (2 * np.where(w > 0, w, 1.0)), np.inf if self.alpha else 0.0)
        return mass_term + self.beta * w / 2 + self.eta / 2

    @classmethod
    def rayleigh_fit(cls, omega, zeta, std=None) -> tuple[Damping, np.ndarray]:
        r"""The Rayleigh damping that best fits measured modal damping ratios: α, β ≥ 0
        minimising :math:`\sum_r ((\alpha/(2\omega_r) + \beta\omega_r/2 - \zeta_r)/\sigma_r)^2`
        (non-negative least squares).

        Parameters
        ----------
        omega : array_like of float, shape ``(n,)``
            Circular frequencies of the measured modes (rad/s), > 0.
        zeta : array_like of float, shape ``(n,)``
            Their measured damping ratios.
        std : array_like of float, shape ``(n,)``, optional
            Standard deviations of the ratios (default: equal weights).

        Returns
        -------
        damping : Damping
            α and β (η = 0).
        residual : numpy.ndarray, shape ``(n,)``
            The fitted ratio minus the measured one, per mode.

        Raises
        ------
        InputError
            Fewer than one mode, a frequency that is not > 0, or sizes that differ.
        """
        from scipy.optimize import nnls

        w = np.asarray(omega, float).ravel()
        z = np.asarray(zeta, float).ravel()
        if w.size == 0 or w.shape != z.shape or not np.all(w > 0) or not np.all(np.isfinite(z)):
            raise InputError("Rayleigh fit: needs at least one mode with a frequency > 0 and a finite damping ratio")
        s = np.ones_like(z) if std is None else np.asarray(std, float).ravel()
        A = np.column_stack([1 / (2 * w), w / 2]) / s[:, None]
        x, _ = nnls(A, z / s)
        fit = cls(alpha=float(x[0]), beta=float(x[1]))
        return fit, fit.modal_damping_ratio(w) - z


UNDAMPED = Damping()


def as_damping(damping) -> Damping:
    """``None`` (undamped), a :class:`Damping`, or a mapping {alpha, beta, eta}.

    Parameters
    ----------
    damping : None, Damping or mapping of str to float
        A mapping may give any of ``alpha`` (1/s), ``beta`` (s) and ``eta``; the others are 0.

    Returns
    -------
    Damping
        :data:`UNDAMPED` for None, ``damping`` itself for a :class:`Damping`.

    Raises
    ------
    InputError
        An unknown key; a value that is not a finite number >= 0; any other type.
    """
    if damping is None:
        return UNDAMPED
    if isinstance(damping, Damping):
        return damping
    if isinstance(damping, Mapping):
        unknown = sorted(set(damping) - {"alpha", "beta", "eta"})
        if unknown:
            raise InputError(f"damping: unknown key(s) {', '.join(unknown)} (use alpha, beta, eta)")
        return Damping(**damping)
    raise InputError(f"damping must be a Damping or a mapping {{alpha, beta, eta}}, got {damping!r}")


def check_omega(omega, what: str = "omega") -> np.ndarray:
    """A 1-D, finite, non-negative frequency axis in rad/s.

    Parameters
    ----------
    omega : float or array_like of float
        Circular frequencies ω (rad/s), any shape (flattened).
    what : str, default ``"omega"``
        Its name in messages.

    Returns
    -------
    numpy.ndarray of float, shape ``(n_lines,)``
        ``omega`` flattened, as floats.

    Raises
    ------
    InputError
        Complex or non-numeric values; no value; a NaN, infinite or negative value (the lines,
        1-based, named).
    """
    w = np.asarray(omega)
    if np.iscomplexobj(w):
        raise InputError(f"{what}: frequencies must be real numbers (rad/s), got complex values")
    try:
        w = np.asarray(w, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"{what}: frequencies must be numbers (rad/s)") from None
    if w.size == 0:
        raise InputError(f"{what}: no frequencies given")
    bad = np.flatnonzero(~np.isfinite(w) | (w < 0))
    if bad.size:
        raise InputError(f"{what}: line(s) {(bad + 1).tolist()} not finite or negative ({w[bad].tolist()})")
    return w


def force_vector(model, force: Mapping, what: str = "force") -> np.ndarray:
    """The model-sized force vector of ``{dof: amplitude}`` (real, or complex if any is complex).

    Raises :class:`InputError` naming every dof the model lacks, and for an empty, zero or
    non-finite force.

    Parameters
    ----------
    model : Model
        The model (its ``dofs`` and ``n_dofs``).
    force : mapping of dof label to float or complex
        Force amplitudes (N, or N·m at a rotational dof) at the excited dofs.
    what : str, default ``"force"``
        Its name in messages.

    Returns
    -------
    numpy.ndarray of float or complex, shape ``(n_dofs,)``
        The force vector, zero at the dofs not given; complex if any amplitude is complex.

    Raises
    ------
    InputError
        Not a mapping, or empty; a bad dof label; a dof given twice (after canonicalisation) or
        one the model lacks; an amplitude that is not a number or not finite; every amplitude zero.
    """
    if not isinstance(force, Mapping) or not force:
        raise InputError(f"{what}: give the force as {{dof: amplitude}} with at least one dof")
    labels = {}
    for k, v in force.items():
        lab = canonical(k)
        if lab in labels:
            raise InputError(f"{what}: dof {lab} given twice")
        labels[lab] = v
    idx = {d: i for i, d in enumerate(model.dofs)}
    missing = [d for d in labels if d not in idx]
    if missing:
        raise InputError(f"{what}: force at dof(s) the model {model.name!r} lacks: {describe(missing)}")
    cplx = any(isinstance(v, complex) or np.iscomplexobj(v) for v in labels.values())
    f = np.zeros(model.n_dofs, dtype=complex if cplx else float)
    for d, v in labels.items():
        try:
            f[idx[d]] = complex(v) if cplx else float(v)
        except (TypeError, ValueError):
            raise InputError(f"{what} at {d}: amplitude {v!r} is not a number") from None
    if not np.all(np.isfinite(f)):
        raise InputError(f"{what}: amplitude not finite at {describe([d for d in labels if not np.isfinite(f[idx[d]])])}")
    if not np.any(f):
        raise InputError(f"{what}: every amplitude is zero")
    return f


def use_dense(n: int, method: str = "auto") -> bool:
    """Whether a model of ``n`` dofs takes the dense (stacked) path.

    Parameters
    ----------
    n : int
        The number of dofs.
    method : {"auto", "dense", "sparse"}, default ``"auto"``
        ``"auto"``: dense up to :data:`DENSE_LIMIT` dofs.

    Returns
    -------
    bool
        True for the dense path, False for sparse LU per line.

    Raises
    ------
    InputError
        An unknown ``method``.
    """
    if method not in ("auto", "dense", "sparse"):
        raise InputError(f"unknown solver method {method!r}: use auto, dense or sparse")
    return method == "dense" or (method == "auto" and n <= DENSE_LIMIT)


def line_name(i: int, w: float) -> str:
    """How messages name a spectral line.

    Parameters
    ----------
    i : int
        0-based line index (shown 1-based).
    w : float
        Its frequency ω (rad/s).

    Returns
    -------
    str
        ``"line {i+1} (omega = {w} rad/s)"``.
    """
    return f"line {i + 1} (omega = {w:.6g} rad/s)"


def dense_stack(K: np.ndarray, M: np.ndarray, cK: np.ndarray, cM: np.ndarray) -> np.ndarray:
    """``Z[i] = cK[i] K + cM[i] M`` for dense K, M: shape ``(n_lines, n, n)``.

    Parameters
    ----------
    K, M : numpy.ndarray of float, shape ``(n, n)``
        Dense stiffness (N/m) and mass (kg) matrices.
    cK, cM : numpy.ndarray, shape ``(n_lines,)``
        The coefficients of :meth:`Damping.coefficients`.

    Returns
    -------
    numpy.ndarray, shape ``(n_lines, n, n)``
        The dynamic stiffness of every line (N/m); complex when the coefficients are.
    """
    return cK[:, None, None] * K[None] + cM[:, None, None] * M[None]


def solve_stacked(Z: np.ndarray, B: np.ndarray, on_singular: str = "raise", omega=None) -> np.ndarray:
    """Solve every ``Z[g] X[g] = B[g]`` of a stack at once (``B`` ``(n, k)`` or ``(G, n, k)``).

    A stack that contains exactly singular matrices (an undamped line exactly on a resonance)
    raises :class:`NumericalError` naming the line (``on_singular="raise"``), or gives ``inf``
    for those members and the solutions of the others (``"inf"``: residual surfaces).

    Parameters
    ----------
    Z : numpy.ndarray, shape ``(G, n, n)``
        The stack (any leading axes).
    B : numpy.ndarray, shape ``(n, k)`` or ``(G, n, k)``
        Right-hand sides: one block for every member, or one per member.
    on_singular : str, default ``"raise"``
        ``"raise"``; any other value acts as ``"inf"``.  A member is singular when its
        determinant is zero or not finite.
    omega : array_like of float, shape ``(G,)``, optional
        The members' frequencies (rad/s), to name the singular line in the message (else
        ``"member g"``).

    Returns
    -------
    numpy.ndarray, shape ``(G, n, k)``
        The solutions; ``inf`` for every singular member with ``"inf"``.

    Raises
    ------
    NumericalError
        A singular member with ``on_singular="raise"`` (the first one named).
    """
    Bb = np.broadcast_to(B, Z.shape[:-2] + B.shape[-2:]) if B.ndim == 2 else B
    try:
        return np.linalg.solve(Z, Bb)
    except np.linalg.LinAlgError:
        pass
    det = np.linalg.det(Z)
    sing = ~np.isfinite(det) | (det == 0)
    if on_singular == "raise":
        g = int(np.flatnonzero(sing.ravel())[0]) if sing.any() else 0
        where = line_name(g, float(np.ravel(omega)[g])) if omega is not None else f"member {g + 1}"
        raise NumericalError(f"the dynamic stiffness K - omega^2 M is singular at {where}: the line lies exactly "
                             "on a resonance of the model (move the line, skip it, or add damping)")
    Zs = np.where(sing[..., None, None], np.eye(Z.shape[-1]), Z)
    X = np.linalg.solve(Zs, Bb.astype(np.result_type(Zs, Bb)))
    X[sing] = np.inf
    return X


def factor(Z, where: str):
    """Sparse LU of one line's dynamic stiffness (complex symmetric when damped).

    Parameters
    ----------
    Z : sparse matrix, shape ``(n, n)``
        The line's dynamic stiffness (N/m).
    where : str
        The line's name in messages (:func:`line_name`).

    Returns
    -------
    femupdate.workspace.SuperLUFactor
        The factor (:func:`femupdate.modal.factorize`).

    Raises
    ------
    NumericalError
        Z is exactly singular (the line lies on a resonance of the model).
    """
    from ..modal import factorize

    try:
        return factorize(Z, definite=False)  # K - omega^2 M: indefinite above the first resonance
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise NumericalError(f"the dynamic stiffness is singular at {where} ({exc}): the line lies on a "
                             "resonance of the model (move the line, skip it, or add damping)") from None


class LineSystems:
    """The dynamic stiffness of every line at one parameter vector, ready to solve with.

    ``solve(B)`` returns ``Z(ω_i)^{-1} B`` for every line, shape ``(n_lines, n, k)``; the dense
    path solves all lines in one stacked call, the sparse path factorises each line once (the
    factor is kept only while that line is being processed, see :meth:`each`).

    Parameters
    ----------
    model : Model
        The parametrised model.
    p : numpy.ndarray of float, shape ``(n_parameters,)``
        The full parameter vector (:meth:`Model.resolve`).
    omega : array_like of float, shape ``(n_lines,)``
        Circular frequencies of the lines (rad/s).
    damping : Damping, default :data:`UNDAMPED`
        The model's damping.
    method : {"auto", "dense", "sparse"}, default ``"auto"``
        The solution path (:func:`use_dense`).

    Attributes
    ----------
    cK, cM : numpy.ndarray, shape ``(n_lines,)``
        The coefficients of :meth:`Damping.coefficients`.
    K, M : sparse matrix, shape ``(n, n)``
        Stiffness (N/m) and mass (kg) at ``p``; ``Kd``, ``Md`` their dense copies on the dense path.
    dense : bool
        Whether the dense path is used.

    Raises
    ------
    InputError
        An unknown ``method``.
    """

    def __init__(self, model, p: np.ndarray, omega: np.ndarray, damping: Damping = UNDAMPED, method: str = "auto"):
        self.model = model
        self.p = p
        self.omega = np.asarray(omega, float)
        self.damping = damping
        self.cK, self.cM = damping.coefficients(self.omega)
        self.dense = use_dense(model.n_dofs, method)
        self.K = model.K(p)
        self.M = model.M(p)
        if self.dense:
            self.Kd, self.Md = self.K.toarray(), self.M.toarray()

    @property
    def complex(self) -> bool:
        """True when the responses are complex (the damping is not zero)."""
        return not self.damping.undamped

    def Z(self, i: int):
        """The dynamic stiffness of line ``i``.

        Parameters
        ----------
        i : int
            0-based line index.

        Returns
        -------
        scipy.sparse.csc_array, shape ``(n, n)``
            c_K(ω_i) K + c_M(ω_i) M (N/m).
        """
        Z = self.cK[i] * self.K + self.cM[i] * self.M
        return sp.csc_array(Z)

    def solve(self, B: np.ndarray, on_singular: str = "raise") -> np.ndarray:
        """``Z(ω_i)^{-1} B`` for every line.

        Parameters
        ----------
        B : numpy.ndarray, shape ``(n,)`` or ``(n, k)``
            Right-hand sides (forces, N).
        on_singular : str, default ``"raise"``
            ``"raise"``: a line exactly on a resonance raises; ``"inf"``: that line's solution is
            ``inf``.  Other values act as ``"inf"`` on the dense path and as ``"raise"`` on the
            sparse one.

        Returns
        -------
        numpy.ndarray, shape ``(n_lines, n)`` or ``(n_lines, n, k)``
            The responses (m/N times B's units), real or complex.

        Raises
        ------
        NumericalError
            A singular line with ``on_singular="raise"``.
        """
        B = np.asarray(B)
        B2 = B[:, None] if B.ndim == 1 else B
        if self.dense:
            n = self.model.n_dofs
            per = max(1, BLOCK_BYTES // (16 * n * n))
            out = []
            for s in range(0, self.omega.size, per):
                sl = slice(s, s + per)
                Z = dense_stack(self.Kd, self.Md, self.cK[sl], self.cM[sl])
                out.append(solve_stacked(Z, B2, on_singular, self.omega[sl]))
            X = np.concatenate(out, axis=0)
        else:
            X = np.empty((self.omega.size,) + B2.shape, dtype=np.result_type(B2, self.cK))
            for i, lu in self.each(on_singular):
                X[i] = np.inf if lu is None else lu_apply(lu, B2)
        return X[..., 0] if B.ndim == 1 else X

    def each(self, on_singular: str = "raise"):
        """Yield ``(i, lu)`` for every line: one sparse factorisation each, released after use
        (``lu`` is None for an exactly singular line when ``on_singular="inf"``).

        Parameters
        ----------
        on_singular : str, default ``"raise"``
            ``"inf"``: yield None for a singular line; any other value: raise.

        Yields
        ------
        i : int
            0-based line index.
        lu : femupdate.workspace.SuperLUFactor or None
            The factor of :meth:`Z` ``(i)``.

        Raises
        ------
        NumericalError
            A singular line, unless ``on_singular="inf"``.
        """
        for i, w in enumerate(self.omega):
            try:
                lu = factor(self.Z(i), line_name(i, w))
            except NumericalError:
                if on_singular != "inf":
                    raise
                lu = None
            yield i, lu
            del lu


def lu_apply(lu, B: np.ndarray) -> np.ndarray:
    """``Z^{-1} B`` with a SuperLU factor; a real factor takes complex ``B`` in two real solves.

    Parameters
    ----------
    lu : femupdate.workspace.SuperLUFactor or scipy.sparse.linalg.SuperLU
        The factor of Z, shape ``(n, n)``.
    B : numpy.ndarray, shape ``(n,)`` or ``(n, k)``
        Right-hand sides, real or complex.

    Returns
    -------
    numpy.ndarray, shape of ``B``
        The solution; complex when ``B`` or the factor is.
    """
    if np.iscomplexobj(B):
        try:
            return lu.solve(np.ascontiguousarray(B))
        except TypeError:  # a real factor: solve the real and imaginary parts
            return lu.solve(np.ascontiguousarray(B.real)) + 1j * lu.solve(np.ascontiguousarray(B.imag))
    return lu.solve(np.ascontiguousarray(B))


def derivative_stack(model, idx) -> tuple[sp.csr_array, sp.csr_array]:
    """``dK/dp_j`` and ``dM/dp_j`` of the parameters ``idx`` stacked row-wise into two sparse
    matrices of shape ``(L n, n)``: one product with a block of vectors gives every parameter's
    ``K_j X`` at once.

    Parameters
    ----------
    model : Model
        The parametrised model (its ``dK``, ``dM``).
    idx : sequence of int, length L
        0-based parameter indices.

    Returns
    -------
    Ks, Ms : scipy.sparse.csr_array, shape ``(L n, n)``
        Block j (rows ``j n .. (j+1) n - 1``) is ∂K/∂p_j, resp. ∂M/∂p_j (zero for a parameter
        that does not enter that matrix).
    """
    n = model.n_dofs
    zero = sp.csr_array((n, n))
    Ks = sp.vstack([model.dK[j] if model.dK[j] is not None else zero for j in idx], format="csr")
    Ms = sp.vstack([model.dM[j] if model.dM[j] is not None else zero for j in idx], format="csr")
    return Ks, Ms


class ParameterForms:
    r"""The bilinear forms :math:`U^T (c_K K_j + c_M M_j) V` of every parameter j at once, ``(L, p, q)``.

    From the COO triplets (a, b, v) of the row-stacked derivative matrices (stored entries grouped
    by parameter): every entry contributes :math:`v\,U_{a,:}^T V_{b,:}` to its parameter, and one
    segmented sum (:func:`numpy.add.reduceat`) adds them up — no loop over parameters and no
    ``(L n, q)`` intermediate: the cost is O(nnz · p · q) whatever the number of parameters.

    Parameters
    ----------
    model : Model
        The parametrised model.
    idx : sequence of int, length L
        0-based parameter indices (:func:`derivative_stack`).

    Calling ``forms(U, V, cK, cM)`` with ``U`` ``(n, p)``, ``V`` ``(n, q)`` and the scalar
    coefficients ``cK``, ``cM`` of one line returns the ``(L, p, q)`` array of
    :math:`U^T (c_K K_j + c_M M_j) V`.
    """

    def __init__(self, model, idx):
        n, L = model.n_dofs, len(idx)
        self.L = L
        self.parts = []
        for stack in derivative_stack(model, idx):
            coo = stack.tocoo()
            order = np.argsort(coo.row, kind="stable")
            j, a = np.divmod(coo.row[order].astype(np.int64), n)
            starts = np.searchsorted(j, np.arange(L))
            used = starts < np.append(starts[1:], j.size)  # parameters with stored entries here
            self.parts.append((a, coo.col[order].astype(np.int64), coo.data[order], starts[used], used))

    def __call__(self, U: np.ndarray, V: np.ndarray, cK, cM) -> np.ndarray:
        """The forms :math:`U^T (c_K K_j + c_M M_j) V` of every parameter.

        Parameters
        ----------
        U : numpy.ndarray, shape ``(n, p)``
            Left vectors.
        V : numpy.ndarray, shape ``(n, q)``
            Right vectors.
        cK, cM : float or complex
            One line's coefficients (:meth:`Damping.coefficients`).

        Returns
        -------
        numpy.ndarray, shape ``(L, p, q)``
            Entry ``[j]`` for parameter ``idx[j]``; zero for a parameter without stored entries.
        """
        p, q = U.shape[1], V.shape[1]
        out = np.zeros((self.L, p, q), dtype=np.result_type(U, V, cK, cM))
        for (a, b, v, starts, used), c in zip(self.parts, (cK, cM)):
            if v.size == 0:
                continue
            Ua = v[:, None] * U[a]  # (nnz, p)
            Vb = V[b]  # (nnz, q)
            for e in range(q):  # usually one or a few excitation columns
                out[used, :, e] += c * np.add.reduceat(Ua * Vb[:, e:e + 1], starts, axis=0)
        return out


# ------------------------------------------------------------------------------- resonances
@dataclass(frozen=True, eq=False)
class Resonances:
    r"""Where each line lies with respect to the model's undamped resonances.

    Attributes
    ----------
    omega : ndarray (n_lines,)
    distance : ndarray (n_lines,)
        Relative eigenvalue distance to the nearest resonance,
        :math:`d_i = \min_r |\omega_i^2 - \lambda_r| / \max(\lambda_r, \omega_i^2)`
        (0: exactly on a resonance; about twice the relative frequency distance when small).
    nearest : ndarray (n_lines,)
        That resonance's eigenvalue :math:`\lambda_r` (rad²/s²).
    mode : ndarray (n_lines,)
        Its mode number (1-based; -1 when found by a local shift-invert search, whose rank is unknown).
    sensitivity : ndarray (n_lines, L) or None
        Relative eigenvalue sensitivity of that mode, :math:`s_{ij} = p_j\,\partial\lambda_r/\partial p_j / \lambda_r`
        (Fox & Kapoor, eq. 21), when parameters were given.
    """

    omega: np.ndarray
    distance: np.ndarray
    nearest: np.ndarray
    mode: np.ndarray
    sensitivity: np.ndarray | None = None

    def near(self, tol: float) -> np.ndarray:
        """Indices of the lines within ``tol`` (relative eigenvalue distance) of a resonance.

        Parameters
        ----------
        tol : float
            Relative eigenvalue distance (``distance < tol``, strictly).

        Returns
        -------
        numpy.ndarray of int
            0-based line indices, ascending.
        """
        return np.flatnonzero(self.distance < tol)

    def first_order_error(self, delta: float) -> np.ndarray:
        r"""Estimated relative error of a first-order (Brandon) prediction of the receptance for a
        relative parameter change ``delta``: :math:`|\delta\, s_{ij}| / d_i`, ``(n_lines, L)``
        (``(n_lines,)`` with the bound :math:`|s| \le 1` when no sensitivities are known).

        Near resonance, where one mode dominates, :math:`\alpha \approx \phi\phi^T / (\lambda - \omega^2)`
        and the exact change is :math:`-\phi\phi^T\Delta\lambda / ((\lambda-\omega^2)(\lambda+\Delta\lambda-\omega^2))`
        against the first-order :math:`-\phi\phi^T\Delta\lambda/(\lambda-\omega^2)^2`: their relative
        difference is :math:`|\Delta\lambda / (\lambda + \Delta\lambda - \omega^2)| \approx \delta\, s / d`.

        Parameters
        ----------
        delta : float
            Relative parameter change Δp/p.

        Returns
        -------
        numpy.ndarray of float, shape ``(n_lines, L)`` or ``(n_lines,)``
            The estimate; a distance of 0 counts as the smallest normal float (a huge error).
        """
        d = np.maximum(self.distance, np.finfo(float).tiny)
        if self.sensitivity is None:
            return abs(delta) / d
        return np.abs(delta * self.sensitivity) / d[:, None]

    def describe(self, lines) -> str:
        """The lines' distances to their resonances, in words, for messages.

        Parameters
        ----------
        lines : iterable of int
            0-based line indices (e.g. from :meth:`near`).

        Returns
        -------
        str
            One ``"line k (omega = ... rad/s) is d (relative) from mode m at ... rad/s"`` per line,
            joined by ``"; "``.
        """
        return "; ".join(
            f"{line_name(int(i), float(self.omega[i]))} is {self.distance[i]:.2g} (relative) from "
            f"{'mode ' + str(int(self.mode[i])) if self.mode[i] > 0 else 'a mode'} at "
            f"{math.sqrt(max(self.nearest[i], 0.0)):.6g} rad/s" for i in lines)


def _distance(w2: np.ndarray, lam: np.ndarray) -> np.ndarray:
    scale = np.maximum(np.maximum(lam, w2), np.finfo(float).tiny)
    return np.abs(w2 - lam) / scale


def nearest_mode(K, M, s: float, lu, where: str) -> tuple[float, np.ndarray]:
    """The eigenpair of (K, M) nearest ``s`` = ω², by shift-invert Lanczos (k = 1) with the given
    real factor ``lu`` of K − sM; the vector mass-normalised.

    Parameters
    ----------
    K, M : sparse matrix, shape ``(n, n)``
        Stiffness (N/m) and mass (kg).
    s : float
        The shift ω² (rad²/s²).
    lu : femupdate.workspace.SuperLUFactor or scipy.sparse.linalg.SuperLU
        Real factor of K − sM (:func:`factor`).
    where : str
        The line's name in messages.

    Returns
    -------
    lam : float
        The nearest eigenvalue (rad²/s²).
    phi : numpy.ndarray of float, shape ``(n,)``
        Its eigenvector, φᵀMφ = 1.

    Raises
    ------
    NumericalError
        ARPACK does not converge.
    """
    op = spla.LinearOperator(K.shape, matvec=lambda v: lu_apply(lu, v), dtype=float)
    try:
        lam, vec = spla.eigsh(K, k=1, M=M, sigma=s, which="LM", OPinv=op, tol=1e-8, ncv=min(8, K.shape[0] - 1),
                              **arpack_options())
    except spla.ArpackNoConvergence as exc:
        raise NumericalError(f"{where}: the nearest resonance was not found ({len(exc.eigenvalues)} converged)") from None
    v = vec[:, 0]
    return float(lam[0]), v / math.sqrt(float(v @ (M @ v)))


def collect_resonances(model, p, w, nearest, Phi, mode_no, params=None) -> Resonances:
    """:class:`Resonances` from the nearest eigenpair of every line (and Fox–Kapoor sensitivities).

    Parameters
    ----------
    model : Model
        The parametrised model.
    p : numpy.ndarray of float, shape ``(n_parameters,)``
        The full parameter vector.
    w : array_like of float, shape ``(n_lines,)``
        Circular frequencies of the lines (rad/s).
    nearest : numpy.ndarray of float, shape ``(n_lines,)``
        Each line's nearest eigenvalue λ_r (rad²/s²).
    Phi : numpy.ndarray of float, shape ``(n, n_lines)``
        The mass-normalised eigenvectors of those modes.
    mode_no : array_like of int, shape ``(n_lines,)``
        Their 1-based mode numbers (−1: unknown).
    params : sequence of int, optional
        0-based parameter indices: with them, :attr:`Resonances.sensitivity` is
        p_j (∂λ_r/∂p_j) / λ_r with ∂λ_r/∂p_j = φ_rᵀ (K_j − λ_r M_j) φ_r (0 where λ_r <= 0).

    Returns
    -------
    Resonances
    """
    n = model.n_dofs
    sens = None
    if params is not None and len(params):
        Ks, Ms = derivative_stack(model, params)
        L = len(params)
        dlam = np.einsum("nl,jnl->lj", Phi, (Ks @ Phi).reshape(L, n, -1))
        if Ms.nnz:
            dlam = dlam - nearest[:, None] * np.einsum("nl,jnl->lj", Phi, (Ms @ Phi).reshape(L, n, -1))
        with np.errstate(divide="ignore", invalid="ignore"):
            sens = np.where(nearest[:, None] > 0, dlam * p[np.asarray(params)][None, :] / nearest[:, None], 0.0)
    return Resonances(np.asarray(w, float), _distance(np.asarray(w, float) ** 2, nearest), nearest, np.asarray(mode_no), sens)


def resonances(model, omega, values=None, params=None) -> Resonances:
    """Distance of every line to the nearest undamped resonance of the model at ``values``.

    Small models (up to :data:`femupdate.modal.DENSE_LIMIT` dofs): every eigenvalue, densely.
    Large ones: the eigenpair nearest each ω² by shift-invert Lanczos, one factorisation of
    K − ω²M per line (:func:`nearest_mode`).  With ``params`` (indices), the relative
    eigenvalue sensitivities of the nearest mode too.

    Parameters
    ----------
    model : Model
        The parametrised model.
    omega : array_like of float
        Circular frequencies of the lines (rad/s), checked by :func:`check_omega`.
    values : None, mapping or array_like, optional
        Parameter values (:meth:`Model.resolve`; None: nominal).
    params : sequence of int, optional
        0-based parameter indices for the sensitivities (:func:`collect_resonances`).

    Returns
    -------
    Resonances

    Raises
    ------
    InputError
        A bad frequency axis or bad ``values``; small models: as :func:`femupdate.modal.solve_modes`
        (e.g. a negative eigenvalue).
    NumericalError
        Small models: as :func:`femupdate.modal.solve_modes`; large models: a line exactly on a
        resonance (K − ω²M singular), or no convergence of the shift-invert search.
    """
    from ..modal import DENSE_LIMIT as MODAL_DENSE
    from ..modal import solve_modes

    w = check_omega(omega)
    p = model.resolve(values)
    K, M = model.K(p), model.M(p)
    if model.n_dofs <= MODAL_DENSE:
        modes = solve_modes(K, M, dofs=model.dofs, method="dense")
        lam = modes.eigenvalues
        r = np.argmin(_distance(w[:, None] ** 2, lam[None, :]), axis=1)
        return collect_resonances(model, p, w, lam[r], modes.shapes[:, r], r + 1, params)
    nearest = np.empty(w.size)
    Phi = np.empty((model.n_dofs, w.size))
    for i, wi in enumerate(w):
        where = line_name(i, wi)
        nearest[i], Phi[:, i] = nearest_mode(K, M, wi**2, factor(sp.csc_array(K - wi**2 * M), where), where)
    return collect_resonances(model, p, w, nearest, Phi, np.full(w.size, -1), params)


def dense_eigen_stack(K: np.ndarray, M: np.ndarray):
    """Eigenvalues (ascending) and M-orthonormal eigenvectors of a stack of symmetric pencils
    ``(G, n, n)`` at once: Cholesky M = L Lᵀ, then ``eigh`` of L⁻¹ K L⁻ᵀ (batched LAPACK).

    Parameters
    ----------
    K : numpy.ndarray of float, shape ``(G, n, n)``
        Symmetric stiffness matrices (N/m); any leading axes (or none).
    M : numpy.ndarray of float, shape ``(G, n, n)``
        Symmetric positive definite mass matrices (kg).

    Returns
    -------
    lam : numpy.ndarray of float, shape ``(G, n)``
        Eigenvalues ω² (rad²/s²), ascending per member.
    Phi : numpy.ndarray of float, shape ``(G, n, n)``
        Eigenvectors as columns, ΦᵀMΦ = I.

    Raises
    ------
    numpy.linalg.LinAlgError
        A mass matrix that is not positive definite (NumPy's error, not a NumericalError).
    """
    Lc = np.linalg.cholesky(M)
    A = np.linalg.solve(Lc, np.swapaxes(np.linalg.solve(Lc, K), -1, -2))
    A = 0.5 * (A + np.swapaxes(A, -1, -2))
    lam, Y = np.linalg.eigh(A)
    Phi = np.linalg.solve(np.swapaxes(Lc, -1, -2), Y)
    return lam, Phi


