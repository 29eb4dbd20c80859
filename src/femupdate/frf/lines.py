r"""Dynamic stiffness per spectral line and its solves.

The forced, steady-state response at ω (paper eq. 23, with optional damping) is

.. math::  Z(\omega)\,x = f, \qquad
           Z(\omega) = (1 + i\eta + i\omega\beta)\,K(p) + (i\omega a - \omega^2)\,M(p),

undamped (:math:`Z = K - \omega^2 M`, real) unless a :class:`~femupdate.frf.damping.Damping` is
given: viscous proportional damping :math:`C = aM + bK` (Rayleigh) and/or structural
(hysteretic) damping :math:`i\eta K` (:mod:`femupdate.frf.damping`).  Because the model is
affine, :math:`\partial Z/\partial p_j = c_K\,K_j + c_M\,M_j` with the same two scalars
:math:`c_K(\omega) = 1 + i\eta + i\omega b`, :math:`c_M(\omega) = i\omega a - \omega^2`.

Two solution paths, chosen by size: small models stack every line's dense Z into one
``(n_lines, n, n)`` array and solve them in one LAPACK call; large ones factorise each line's
sparse Z once (SuperLU with a symmetric ordering, :func:`femupdate.modal.factorize`) and reuse the
factor for every right-hand side.  How far each line lies from a resonance:
:mod:`femupdate.frf.resonance`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

import numpy as np
import scipy.sparse as sp

from .._errors import InputError, NumericalError
from ..dofs import canonical, describe
from .damping import UNDAMPED, Damping, as_damping, nonnegative

log = logging.getLogger(__name__)

#: models up to this many dofs stack their lines densely; larger ones use sparse LU per line
DENSE_LIMIT = 200
#: bytes allowed for one stacked block of dense dynamic stiffness matrices
BLOCK_BYTES = 64 * 2**20


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


def _tangent(model, values, who: str):
    """``model`` when affine; else its tangent affine model at ``values`` (which must be given: the
    derivatives of a non-linear model depend on where they are taken)."""
    if getattr(model, "is_affine", True):
        return model
    if values is None:
        from ..coefficients import route_refusal
        route_refusal(model, f"{who} without the parameter values to differentiate at")
    return model.linearised(values)


def derivative_stack(model, idx, values=None) -> tuple[sp.csr_array, sp.csr_array]:
    """``dK/dp_j`` and ``dM/dp_j`` of the parameters ``idx`` stacked row-wise into two sparse
    matrices of shape ``(L n, n)``: one product with a block of vectors gives every parameter's
    ``K_j X`` at once.

    Parameters
    ----------
    model : Model
        The parametrised model (its ``dK``, ``dM``).
    idx : sequence of int, length L
        0-based parameter indices.
    values : array_like or mapping, optional
        Where to differentiate; needed for a non-linear model (its tangent there), ignored by an
        affine one.

    Returns
    -------
    Ks, Ms : scipy.sparse.csr_array, shape ``(L n, n)``
        Block j (rows ``j n .. (j+1) n - 1``) is ∂K/∂p_j, resp. ∂M/∂p_j (zero for a parameter
        that does not enter that matrix).
    """
    model = _tangent(model, values, "derivative_stack")
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
    values : array_like or mapping, optional
        Where to differentiate (needed for a non-linear model, :func:`derivative_stack`).

    Calling ``forms(U, V, cK, cM)`` with ``U`` ``(n, p)``, ``V`` ``(n, q)`` and the scalar
    coefficients ``cK``, ``cM`` of one line returns the ``(L, p, q)`` array of
    :math:`U^T (c_K K_j + c_M M_j) V`.
    """

    def __init__(self, model, idx, values=None):
        model = _tangent(model, values, "the FRF parameter forms")
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


#: names that moved to :mod:`femupdate.frf.resonance` (still importable from here)
_MOVED = ("Resonances", "resonances", "collect_resonances", "nearest_mode", "dense_eigen_stack")


def __getattr__(name: str):
    if name in _MOVED:
        from . import resonance

        return getattr(resonance, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["DENSE_LIMIT", "BLOCK_BYTES", "Damping", "UNDAMPED", "as_damping", "nonnegative", "check_omega",
           "force_vector", "use_dense", "line_name", "dense_stack", "solve_stacked", "factor", "LineSystems",
           "lu_apply", "derivative_stack", "ParameterForms"]
