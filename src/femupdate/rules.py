r"""The rules of the modal updating problem, written once.

Every route that evaluates the modal updating problem — one local solve
(:class:`femupdate.updating.Problem`), the compiled batched route
(:mod:`femupdate.updating.batched`), uniqueness studies, multi-configuration updating — takes
these functions for:

* the map between the optimiser's variables x and the physical parameters p
  (:func:`to_p`, :func:`dp_dx`: ``relative`` x = p / ``|p_start|``, ``log`` x = ln p, ``absolute``);
* the checks of a computed spectrum (:func:`check_spectrum`: no negative eigenvalue, rigid-body
  eigenvalues set to exactly zero) and of a mode to be differentiated (:func:`check_distinct`);
* the pairing of test modes with model modes (:func:`pair_modes`, by the policy in
  :data:`PAIRINGS`): by MAC over each test mode's measured dofs (:func:`mac_vector`), the
  assignment maximising the total MAC (Hungarian algorithm, :func:`assign`), a test mode below
  ``min_mac`` failing and test modes without a shape taking the lowest free model modes in
  order (:func:`pair_by_mac`); by frequency order (:func:`pair_by_order`); by frequency, MAC
  breaking ties (:func:`pair_by_frequency`); or ``auto``, by order until the shapes show a
  swap;
* the scaling of a measured shape (:func:`shape_scale`: unit length with the sign of the largest
  entry, 1 at a reference dof, or 1 at the largest entry) and the sign that aligns a unit-length
  model shape with the test shape (:func:`unit_sign`);
* the residuals (:func:`eigenvalue_residual`, :func:`shape_residuals`)

  .. math:: r_\lambda = w_\lambda \frac{\lambda_A - \lambda_E}{\lambda_E}, \qquad
            r_\psi = w_\psi (\psi_A - \psi_E)

  (the normalised sensitivity equation of the reference paper, eq. 19; the reference-dof
  scaling is its eq. 33) and their exact derivatives given ∂λ/∂p and ∂φ/∂p at the measured dofs
  (:func:`eigenvalue_gradient`, :func:`shape_jacobian`): with ψ = φ_s / s(φ_s),
  ψ' = φ_s'/s − ψ s'/s;
* the MAC residuals of the ``"mac"`` formulation (:func:`mac_residuals`, :func:`mac_jacobian`):
  w (I − ê êᵀ) â, whose squared norm is w² (1 − MAC) (not compiled by the batched route, which
  implements the ``"shapes"`` formulation, but written in the same subset).

The functions are plain Python on NumPy arrays and scalars — no objects, no exceptions: a
failure is an error code (:data:`ERRORS`, turned into a message by :func:`message`).  They are
written in the subset of Python that numba compiles, and marked with :func:`rule`; the compiled
backend registers every rule with numba (``numba.extending.register_jitable``) when it is
imported, so that its kernels call these very functions.  Inner products go through
:func:`dot` (and :func:`dot_col`, :func:`sumsq_col` for matrix columns), the primitives with a
compiled implementation of their own (a sequential sum, so
that compiled results do not depend on a BLAS's summation order).  This module does not import
numba.
"""

from __future__ import annotations

import math

import numpy as np

#: every function marked with :func:`rule`, in definition order
RULES: list = []


def rule(fn):
    """Mark ``fn`` as a rule of the problem: plain Python here, compiled by the compiled backend.

    Parameters
    ----------
    fn : function
        A function written in the subset of Python that numba compiles; appended to :data:`RULES`.

    Returns
    -------
    function
        ``fn`` itself, unchanged (a decorator).
    """
    RULES.append(fn)
    return fn


def dot(a, b) -> float:
    """The inner product of two vectors.  Here NumPy's; the compiled backend gives compiled code
    its own implementation, a plain sequential sum (``numba.extending.overload``).

    Parameters
    ----------
    a, b : numpy.ndarray of float, shape ``(n,)``
        The vectors.

    Returns
    -------
    float
        aᵀb.
    """
    return float(np.dot(a, b))


def dot_col(a, B, j) -> float:
    """The inner product of the vector ``a`` with column ``j`` of the matrix ``B`` (compiled: a
    sequential sum that makes no view of the column).

    Parameters
    ----------
    a : numpy.ndarray of float, shape ``(n,)``
        The vector.
    B : numpy.ndarray of float, shape ``(n, m)``
        The matrix.
    j : int
        The column, ``0 <= j < m``.

    Returns
    -------
    float
        aᵀB[:, j].
    """
    return float(np.dot(a, B[:, j]))


def sumsq_col(B, j) -> float:
    """The squared norm of column ``j`` of ``B`` (compiled: a sequential sum, no view).

    Parameters
    ----------
    B : numpy.ndarray of float, shape ``(n, m)``
        The matrix.
    j : int
        The column, ``0 <= j < m``.

    Returns
    -------
    float
        ‖B[:, j]‖², the column's squared Euclidean norm.
    """
    return float(np.dot(B[:, j], B[:, j]))


# ---------------------------------------------------------------------------------------------
# codes
# ---------------------------------------------------------------------------------------------
UNIT, REF, MAX = 0, 1, 2
#: shape scalings by name
SCALINGS = {"unit": UNIT, "ref": REF, "max": MAX}
RELATIVE, LOG, ABSOLUTE = 0, 1, 2
#: parametrisations by name
PARAMETRISATIONS = {"relative": RELATIVE, "log": LOG, "absolute": ABSOLUTE}
#: relative eigenvalue gap below which two modes count as repeated
REPEATED_TOL = 1e-8
#: an eigenvalue within this fraction of the pencil's scale is a rigid-body (zero) eigenvalue
RIGID_TOL = 1e-12
#: a mode whose strain energy ``|φᵀKφ|`` exceeds this fraction of ``|φ|ᵀ|K||φ|`` is elastic, however small
#: its eigenvalue is next to the pencil's largest single-dof quotient (:func:`restore_elastic`)
RIGID_ENERGY_TOL = 1e-11
PAIR_MAC, PAIR_ORDER, PAIR_FREQUENCY, PAIR_AUTO = 0, 1, 2, 3
#: pairing policies by name (:func:`pair_modes`)
PAIRINGS = {"mac": PAIR_MAC, "order": PAIR_ORDER, "frequency": PAIR_FREQUENCY, "auto": PAIR_AUTO}
#: names of the pairing rules by code
PAIRING_NAMES = ("mac", "order", "frequency", "auto")
#: relative frequency window within which ``frequency`` pairing lets MAC decide
FREQUENCY_WINDOW = 0.1
#: how much better than its every other match each shaped test mode's MAC pair must be for
#: ``auto`` pairing to leave the order pairing
AUTO_MARGIN = 0.2
#: the MAC every pair of a MAC pairing must reach for ``auto`` pairing to leave the order pairing
AUTO_SWAP_MAC = 0.9

(OK, E_NONFINITE, E_MASS_DIAG, E_MASS_CHOL, E_NEGATIVE, E_NO_PAIR, E_NO_MODE_LEFT, E_NODE, E_RIGID, E_REPEATED,
 E_DEGENERATE, E_BAD_JACOBIAN) = range(12)

#: messages of the error codes; ``{k}`` and ``{k1}`` are 1-based mode numbers (or positions),
#: ``{i0}`` a count, ``{f0}``/``{f1}`` values, ``{modes}`` the 1-based test modes concerned
ERRORS = {
    E_NONFINITE: "non-finite residuals (the model became singular at these parameter values)",
    E_MASS_DIAG: "the least-squares solver failed: the mass matrix is not positive definite: a dof has no mass",
    E_MASS_CHOL: ("the least-squares solver failed: the mass matrix is not positive definite (its Cholesky "
                  "factorisation failed)"),
    E_NEGATIVE: ("the least-squares solver failed: K is not positive semi-definite: negative eigenvalue {f0:.4g} "
                 "(check for negative stiffness parameters)"),
    E_NO_PAIR: ("test mode(s) {modes} pair with no model mode (MAC below {min_mac:g} for all {i0} computed modes): "
                "check the dof labels, or lower --min-mac"),
    E_NO_MODE_LEFT: "test mode {k}: no model mode left to pair with",
    E_NODE: "cannot scale the shape to 1 at measured dof #{k}: the mode has a node there",
    E_RIGID: ("mode {k} is a rigid-body mode (zero frequency): its derivatives are not defined; differentiate the "
              "flexible modes only"),
    E_REPEATED: ("modes {k} and {k1} are repeated (eigenvalues {f0:.10g} and {f1:.10g}): eigenvector derivatives "
                 "of repeated modes are not unique; femupdate refuses rather than return a wrong derivative (pair "
                 "modes by subspace, or perturb the model to split them)"),
    E_DEGENERATE: "the least-squares solver failed: the trust-region step is degenerate",
    E_BAD_JACOBIAN: "the least-squares solver failed: non-finite Jacobian",
}


def message(code: int, i0: int = 0, i1: int = 0, f0: float = 0.0, f1: float = 0.0, modes=(),
            min_mac: float = 0.5) -> str:
    """The message of error ``code`` with its numbers (``modes``: 0-based test modes).

    Parameters
    ----------
    code : int
        An error code, a key of :data:`ERRORS` (``E_NONFINITE`` ... ``E_BAD_JACOBIAN``).
    i0 : int, default 0
        0-based mode (or position) of the message, shown 1-based as ``{k}``; shown as is as
        ``{i0}`` (a count: the number of computed modes for ``E_NO_PAIR``).
    i1 : int, default 0
        0-based second mode, shown 1-based as ``{k1}`` (``E_REPEATED``).
    f0, f1 : float, default 0.0
        Values shown as ``{f0}``, ``{f1}`` (eigenvalues in rad²/s² for ``E_NEGATIVE`` and
        ``E_REPEATED``).
    modes : sequence of int, default ()
        0-based test modes concerned, shown 1-based as ``{modes}`` (``E_NO_PAIR``).
    min_mac : float, default 0.5
        The MAC threshold shown by ``E_NO_PAIR``.

    Returns
    -------
    str
        The formatted message.

    Raises
    ------
    KeyError
        ``code`` is not an error code (``OK`` has no message).
    """
    return ERRORS[int(code)].format(i0=int(i0), k=int(i0) + 1, k1=int(i1) + 1, f0=float(f0), f1=float(f1),
                                    modes=[int(k) + 1 for k in modes], min_mac=min_mac)


# ---------------------------------------------------------------------------------------------
# parameters
# ---------------------------------------------------------------------------------------------
@rule
def to_p(code, x, scale):
    """Physical values of the updated parameters at the optimiser's variables ``x`` (L,);
    ``scale`` (L,) the ``|starting values|`` of the relative parametrisation.

    Parameters
    ----------
    code : int
        The parametrisation, a value of :data:`PARAMETRISATIONS`: ``RELATIVE`` (p = x·scale),
        ``LOG`` (p = exp x) or ``ABSOLUTE`` (p = x; any other code acts as ``ABSOLUTE``).
    x : numpy.ndarray of float, shape ``(L,)``
        The optimiser's variables.
    scale : numpy.ndarray of float, shape ``(L,)``
        ``|starting values|`` of the parameters (in their own units, e.g. N/m or kg); read only for
        ``RELATIVE``.

    Returns
    -------
    numpy.ndarray of float, shape ``(L,)``
        The physical parameter values p (a new array).
    """
    p = np.empty(x.size)
    for j in range(x.size):
        p[j] = x[j] * scale[j] if code == RELATIVE else (math.exp(x[j]) if code == LOG else x[j])
    return p


@rule
def dp_dx(code, x, scale):
    """∂p/∂x (L,), the diagonal of the parametrisation's Jacobian.

    Parameters
    ----------
    code : int
        The parametrisation, as in :func:`to_p`.
    x : numpy.ndarray of float, shape ``(L,)``
        The optimiser's variables.
    scale : numpy.ndarray of float, shape ``(L,)``
        ``|starting values|`` of the parameters; read only for ``RELATIVE``.

    Returns
    -------
    numpy.ndarray of float, shape ``(L,)``
        ``scale`` for ``RELATIVE``, exp x (= p) for ``LOG``, ones for ``ABSOLUTE`` (and any
        other code).
    """
    d = np.empty(x.size)
    for j in range(x.size):
        d[j] = scale[j] if code == RELATIVE else (math.exp(x[j]) if code == LOG else 1.0)
    return d


# ---------------------------------------------------------------------------------------------
# the spectrum
# ---------------------------------------------------------------------------------------------
@rule
def check_spectrum(lam, nm, pencil_scale):
    """Checks of the lowest ``nm`` eigenvalues ``lam`` (ascending); rigid-body ones set to 0 in
    place.  ``pencil_scale``: the largest single-dof Rayleigh quotient max ``|K_ii|`` / M_ii.

    Returns ``(code, value)``: ``E_NEGATIVE`` and the lowest eigenvalue when one lies below
    −1e-12 of the scale max(``|λ|``, pencil_scale), else ``OK``.

    Parameters
    ----------
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Eigenvalues λ = ω² (rad²/s²), ascending.  When the check passes, every one of the first
        ``nm`` within :data:`RIGID_TOL` of the scale (in magnitude) is set to exactly 0 in place;
        on ``E_NEGATIVE`` ``lam`` is left unchanged.
    nm : int
        How many eigenvalues (the lowest) to check.
    pencil_scale : float
        max_i ``|K_ii|`` / M_ii (rad²/s²); the scale is max(pencil_scale, 1e-300, max ``|λ|``).

    Returns
    -------
    code : int
        ``E_NEGATIVE`` or ``OK``.
    value : float
        The lowest eigenvalue (rad²/s²) for ``E_NEGATIVE``, else 0.0.
    """
    scale = max(pencil_scale, 1e-300)
    low = 0.0
    for i in range(nm):
        scale = max(scale, abs(lam[i]))
        low = min(low, lam[i])
    if low < -RIGID_TOL * scale:
        return E_NEGATIVE, low
    for i in range(nm):
        if abs(lam[i]) <= RIGID_TOL * scale:
            lam[i] = 0.0
    return OK, 0.0


@rule
def restore_elastic(K, Phi, lam, computed, nm):
    """Undo :func:`check_spectrum`'s zero for each mode whose strain energy says it is elastic:
    the pencil's scale, max K_ii / M_ii, can be dominated by one penalty stiffness (a rigid link
    exported as a 1e10 spring) next to which a genuine first mode looks like round-off.  A
    rigid-body mode's strain energy φᵀKφ is round-off of its terms, ``|φ|ᵀ|K||φ|`` times about
    1e-16; an elastic mode's is far above :data:`RIGID_ENERGY_TOL` of it.

    Parameters
    ----------
    K : numpy.ndarray of float, shape ``(n, n)``
        The stiffness matrix (dense).
    Phi : numpy.ndarray of float, shape ``(n, ≥ nm)``
        The mode shapes, column by column.
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        The eigenvalues after :func:`check_spectrum`; an elastic one set to 0 gets its computed
        value back, in place.
    computed : numpy.ndarray of float, shape ``(≥ nm,)``
        The eigenvalues as computed (before :func:`check_spectrum`).
    nm : int
        How many (the lowest) to check.

    Returns
    -------
    None
    """
    n = K.shape[0]
    for i in range(nm):
        if lam[i] == 0.0 and computed[i] != 0.0:
            energy = 0.0
            total = 0.0
            for a in range(n):
                pa = Phi[a, i]
                if pa == 0.0:
                    continue
                for b in range(n):
                    kab = K[a, b]
                    if kab != 0.0:
                        energy += pa * kab * Phi[b, i]
                        total += abs(pa) * abs(kab) * abs(Phi[b, i])
            if total > 0.0 and abs(energy) > RIGID_ENERGY_TOL * total:
                lam[i] = computed[i]


@rule
def check_distinct(lam, nm, t):
    """Can mode ``t`` be differentiated?  ``lam`` the eigenvalues, the lowest ``nm`` computed.

    Returns ``(code, other)``: ``E_RIGID`` for a rigid-body mode, ``E_REPEATED`` and the first
    mode whose eigenvalue lies within :data:`REPEATED_TOL` (relative) of mode t's, else ``OK``.

    Parameters
    ----------
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Eigenvalues (rad²/s²), rigid-body ones already exactly 0 (:func:`check_spectrum`).
    nm : int
        The number of computed eigenvalues: modes ``0 .. nm-1`` are compared with mode ``t``.
    t : int
        The 0-based mode to differentiate.

    Returns
    -------
    code : int
        ``E_RIGID`` when ``lam[t] == 0`` exactly; ``E_REPEATED`` when another of the ``nm``
        eigenvalues lies within ``REPEATED_TOL · max(|λ_t|, 1e-12 · max |λ|)`` of λ_t; else ``OK``.
    other : int
        The first such mode for ``E_REPEATED``, else ``t``.
    """
    scale = 1e-300
    for i in range(nm):
        scale = max(scale, abs(lam[i]))
    li = lam[t]
    if li == 0.0:
        return E_RIGID, t
    tol = REPEATED_TOL * max(abs(li), 1e-12 * scale)
    for j in range(nm):
        if j != t and abs(lam[j] - li) <= tol:
            return E_REPEATED, j
    return OK, t


# ---------------------------------------------------------------------------------------------
# pairing
# ---------------------------------------------------------------------------------------------
@rule
def mac_vector(psi, B, out):
    """MAC of the shape ``psi`` (n_s,) against the columns of ``B`` (n_s, nm) into ``out`` (nm,),
    each in [0, 1] (0 where a column is zero).

    Parameters
    ----------
    psi : numpy.ndarray of float, shape ``(n_s,)``
        The test shape at its measured dofs.
    B : numpy.ndarray of float, shape ``(n_s, nm)``
        The model shapes at the same dofs, one per column.
    out : numpy.ndarray of float, shape ``(≥ nm,)``
        Receives (ψᵀb_j)² / (ψᵀψ · b_jᵀb_j) clipped to [0, 1] in
        ``out[j]``; 0 where the denominator is 0 (a zero column, or a zero ``psi``).

    Returns
    -------
    None
    """
    ee = dot(psi, psi)
    for j in range(B.shape[1]):
        num = dot_col(psi, B, j)
        den = ee * sumsq_col(B, j)
        v = num * num / den if den > 0 else 0.0
        out[j] = min(max(v, 0.0), 1.0)


@rule
def assign(C, nr, nc, out):
    """Rows 0..nr-1 of the cost matrix C (nr <= nc) to distinct columns, minimising the total
    cost (the Hungarian algorithm with potentials and shortest augmenting paths, as
    :func:`scipy.optimize.linear_sum_assignment`); ``out[i]`` the column of row i.

    Parameters
    ----------
    C : numpy.ndarray of float, shape ``(≥ nr, ≥ nc)``
        Finite costs; only ``C[:nr, :nc]`` is read.
    nr, nc : int
        The numbers of rows and columns to assign.
    out : numpy.ndarray of int64, shape ``(≥ nr,)``
        Receives the 0-based column of each row; every entry ``-1`` when ``nr > nc`` (no
        assignment exists).

    Returns
    -------
    None
    """
    if nr > nc:  # no assignment exists: every row unassigned
        for i in range(nr):
            out[i] = -1
        return
    INF = np.inf
    u = np.zeros(nr + 1)
    v = np.zeros(nc + 1)
    p = np.zeros(nc + 1, np.int64)
    way = np.zeros(nc + 1, np.int64)
    for i in range(1, nr + 1):
        p[0] = i
        j0 = 0
        minv = np.full(nc + 1, INF)
        used = np.zeros(nc + 1, np.bool_)
        while True:
            used[j0] = True
            i0 = p[j0]
            delta = INF
            j1 = 0
            for j in range(1, nc + 1):
                if not used[j]:
                    cur = C[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j] = cur
                        way[j] = j0
                    if minv[j] < delta:
                        delta = minv[j]
                        j1 = j
            for j in range(nc + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while True:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
            if j0 == 0:
                break
    for j in range(1, nc + 1):
        if p[j] != 0:
            out[p[j] - 1] = j - 1


@rule
def pair_by_mac(MAC, shaped, nm, min_mac, pairs, bad):
    """Pair the T test modes with the lowest ``nm`` model modes.

    ``MAC`` (T, ≥nm): row k the MAC of test mode k against the model modes (read only where
    ``shaped[k]``).  Test modes with a shape are assigned so that the total MAC is largest (when
    each one's best mode is strictly best, distinct and above ``min_mac``, that is the
    assignment; otherwise :func:`assign`); a paired MAC below ``min_mac`` fails.  Test modes
    without a shape then take the lowest free model modes in order.

    Fills ``pairs`` (T,) and, on ``E_NO_PAIR``, ``bad`` (T,) the failing test modes.  Returns
    ``(code, i)``: ``E_NO_PAIR`` with ``i = nm``, ``E_NO_MODE_LEFT`` with ``i`` the test mode
    left without a model mode, else ``(OK, 0)``.

    Parameters
    ----------
    MAC : numpy.ndarray of float, shape ``(T, ≥ nm)``
        MAC of each test mode (row) against the model modes (:func:`mac_vector`).
    shaped : numpy.ndarray of bool, shape ``(T,)``
        Whether each test mode has a measured shape.
    nm : int
        The number of model modes available for pairing (the lowest ``nm``).
    min_mac : float
        The smallest MAC, in [0, 1], of a pair of shaped modes.
    pairs : numpy.ndarray of int64, shape ``(T,)``
        Receives the 0-based model mode of each test mode (complete only on ``OK``).
    bad : numpy.ndarray of bool, shape ``(T,)``
        Set True at the failing test modes on ``E_NO_PAIR`` (every shaped one when there are
        more shaped test modes than ``nm``); not cleared first.

    Returns
    -------
    code : int
        ``OK``, ``E_NO_PAIR`` or ``E_NO_MODE_LEFT``.
    i : int
        ``nm`` for ``E_NO_PAIR``, the 0-based test mode left without a model mode for
        ``E_NO_MODE_LEFT``, 0 for ``OK``.
    """
    T = shaped.size
    nws = 0
    for k in range(T):
        if shaped[k]:
            nws += 1
    taken = np.zeros(max(nm, 1), np.bool_)
    if nws > nm:  # more test modes with a shape than model modes to pair them with
        for k in range(T):
            if shaped[k]:
                bad[k] = True
        return E_NO_PAIR, nm
    if nws:
        ws = np.empty(nws, np.int64)
        c = 0
        for k in range(T):
            if shaped[k]:
                ws[c] = k
                c += 1
        col = np.empty(nws, np.int64)
        fast = True  # every test mode's best mode strictly best, distinct and above min_mac
        for c in range(nws):
            row = MAC[ws[c]]
            best = 0
            for j in range(1, nm):
                if row[j] > row[best]:
                    best = j
            col[c] = best
            for j in range(nm):
                if j != best and not row[best] > row[j]:
                    fast = False
            if not row[best] >= min_mac:
                fast = False
            for c2 in range(c):
                if col[c2] == best:
                    fast = False
        if not fast:
            C = np.empty((nws, nm))
            for c in range(nws):
                for j in range(nm):
                    C[c, j] = -MAC[ws[c], j]
            assign(C, nws, nm, col)
            failed = False
            for c in range(nws):
                if not MAC[ws[c], col[c]] >= min_mac:
                    bad[ws[c]] = True
                    failed = True
            if failed:
                return E_NO_PAIR, nm
        for c in range(nws):
            pairs[ws[c]] = col[c]
            taken[col[c]] = True
    nxt = 0
    for k in range(T):
        if not shaped[k]:
            while nxt < nm and taken[nxt]:
                nxt += 1
            if nxt >= nm:
                return E_NO_MODE_LEFT, k
            pairs[k] = nxt
            taken[nxt] = True
    return OK, 0


@rule
def pair_by_order(lam, lam_e, nm, pairs):
    """Pair the T test modes with model modes in order of frequency: the elastic test mode of
    lowest measured eigenvalue with the lowest elastic model mode, the next with the next, and
    so on (ties in the order the modes are listed).  Rigid-body model modes (eigenvalue exactly
    0, as :func:`check_spectrum` leaves them) are paired only with test modes of eigenvalue 0,
    so the elastic modes of a free structure are counted from its first elastic mode.

    Parameters
    ----------
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Model eigenvalues, ascending, rigid-body ones exactly 0.
    lam_e : numpy.ndarray of float, shape ``(T,)``
        Measured eigenvalues.
    nm : int
        The number of model modes available (the lowest ``nm``).
    pairs : numpy.ndarray of int64, shape ``(T,)``
        Receives the 0-based model mode of each test mode (complete only on ``OK``).

    Returns
    -------
    code : int
        ``OK``, or ``E_NO_MODE_LEFT`` when the model modes run out.
    i : int
        The 0-based test mode left without a model mode for ``E_NO_MODE_LEFT``, else 0.
    """
    T = lam_e.size
    order = np.argsort(lam_e, kind="mergesort")
    nr = 0
    while nr < nm and lam[nr] == 0.0:
        nr += 1
    rp = 0
    ep = nr
    for r in range(T):
        k = order[r]
        if lam_e[k] == 0.0 and rp < nr:
            j = rp
            rp += 1
        else:
            j = ep
            ep += 1
        if j >= nm:
            return E_NO_MODE_LEFT, k
        pairs[k] = j
    return OK, 0


@rule
def pair_by_frequency(MAC, shaped, lam, lam_e, nm, pairs):
    """Pair the T test modes with model modes by frequency, MAC breaking ties: the assignment
    of least total cost, where a model mode within :data:`FREQUENCY_WINDOW` (relative, of the
    natural frequency) of a test mode costs ``FREQUENCY_WINDOW (1 - MAC)`` (a test mode without a
    shape: the relative frequency difference), and one outside it the relative frequency
    difference ``|ω_A − ω_E| / ω_E`` (at most 1e6).  Never fails on a low MAC.

    Parameters
    ----------
    MAC : numpy.ndarray of float, shape ``(T, ≥ nm)``
        MAC of each test mode against the model modes (read only where ``shaped``).
    shaped : numpy.ndarray of bool, shape ``(T,)``
        Whether each test mode has a measured shape.
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Model eigenvalues, ascending.
    lam_e : numpy.ndarray of float, shape ``(T,)``
        Measured eigenvalues.
    nm : int
        The number of model modes available.
    pairs : numpy.ndarray of int64, shape ``(T,)``
        Receives the 0-based model mode of each test mode (complete only on ``OK``).

    Returns
    -------
    code : int
        ``OK``, or ``E_NO_MODE_LEFT`` when there are more test modes than ``nm``.
    i : int
        ``T - 1`` for ``E_NO_MODE_LEFT`` (the last test mode), else 0.
    """
    T = lam_e.size
    if T > nm:
        return E_NO_MODE_LEFT, T - 1
    if T == 0:
        return OK, 0
    C = np.empty((T, nm))
    for k in range(T):
        we = math.sqrt(max(lam_e[k], 0.0))
        for j in range(nm):
            wa = math.sqrt(max(lam[j], 0.0))
            d = abs(wa - we) / we if we > 0 else (0.0 if wa == 0 else 1e6)
            d = min(d, 1e6)
            if d <= FREQUENCY_WINDOW and shaped[k]:
                C[k, j] = FREQUENCY_WINDOW * (1.0 - MAC[k, j])
            else:
                C[k, j] = d
    assign(C, T, nm, pairs)
    return OK, 0


@rule
def pair_modes(policy, MAC, shaped, lam, lam_e, nm, min_mac, pairs, bad):
    """Pair the T test modes with model modes by the pairing ``policy`` (:data:`PAIRINGS`).

    * ``PAIR_MAC``: :func:`pair_by_mac` (a shaped test mode below ``min_mac`` fails);
    * ``PAIR_ORDER``: :func:`pair_by_order`;
    * ``PAIR_FREQUENCY``: :func:`pair_by_frequency`;
    * ``PAIR_AUTO``: by frequency order (:func:`pair_by_order`) unless the shapes show a swap
      clearly: the order pairing has a shaped pair below ``min_mac`` while the MAC pairing
      (:func:`pair_by_mac`) has every shaped pair at least ``max(min_mac,``
      :data:`AUTO_SWAP_MAC` ``)`` and each of them better than the test mode's every other
      match by :data:`AUTO_MARGIN`; then by MAC.  It never fails on a low MAC, so every start
      of a multi-start study stays alive.  The thresholds are high because with few sensors
      MAC tells modes apart poorly while the model is far from the data: a MAC pairing that
      skips a model mode there leads to a local minimum (measured on shear buildings with
      sensors on a third of the floors, 100 random starts over [0, 2] x nominal: by MAC 48 of
      100 starts reach the truth, by order 100, by ``auto`` with a switch at ``min_mac`` 93, with
      these thresholds 100).

    Parameters
    ----------
    policy : int
        ``PAIR_MAC``, ``PAIR_ORDER``, ``PAIR_FREQUENCY`` or ``PAIR_AUTO``.
    MAC : numpy.ndarray of float, shape ``(T, ≥ nm)``
        MAC of each test mode against the model modes (read only where ``shaped``).
    shaped : numpy.ndarray of bool, shape ``(T,)``
        Whether each test mode has a measured shape.
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Model eigenvalues, ascending.
    lam_e : numpy.ndarray of float, shape ``(T,)``
        Measured eigenvalues.
    nm : int
        The number of model modes available (the lowest ``nm``).
    min_mac : float
        The smallest MAC of a pair of shaped modes (``PAIR_MAC``), or of a pairing that
        correlates (``PAIR_AUTO``).
    pairs : numpy.ndarray of int64, shape ``(T,)``
        Receives the 0-based model mode of each test mode (complete only on ``OK``).
    bad : numpy.ndarray of bool, shape ``(T,)``
        As :func:`pair_by_mac` (``PAIR_MAC`` only).

    Returns
    -------
    code : int
        ``OK``, ``E_NO_PAIR`` (``PAIR_MAC`` only) or ``E_NO_MODE_LEFT``.
    i : int
        As :func:`pair_by_mac`.
    used : int
        The rule that made the pairs: ``PAIR_MAC``, ``PAIR_ORDER`` or ``PAIR_FREQUENCY``.
    """
    if policy == PAIR_MAC:
        code, i = pair_by_mac(MAC, shaped, nm, min_mac, pairs, bad)
        return code, i, PAIR_MAC
    if policy == PAIR_FREQUENCY:
        code, i = pair_by_frequency(MAC, shaped, lam, lam_e, nm, pairs)
        return code, i, PAIR_FREQUENCY
    code, i = pair_by_order(lam, lam_e, nm, pairs)
    if code != OK or policy == PAIR_ORDER:
        return code, i, PAIR_ORDER
    T = shaped.size
    correlated = True
    for k in range(T):
        if shaped[k] and not MAC[k, pairs[k]] >= min_mac:
            correlated = False
    if correlated:
        return OK, 0, PAIR_ORDER
    trial = np.zeros(T, np.int64)
    trial_bad = np.zeros(T, np.bool_)
    code, i = pair_by_mac(MAC, shaped, nm, max(min_mac, AUTO_SWAP_MAC), trial, trial_bad)
    if code != OK:
        return OK, 0, PAIR_ORDER
    for k in range(T):  # every shaped test mode's pair clearly its best match
        if shaped[k]:
            j = trial[k]
            for j2 in range(nm):
                if j2 != j and not MAC[k, j] - MAC[k, j2] >= AUTO_MARGIN:
                    return OK, 0, PAIR_ORDER
    for k in range(T):
        pairs[k] = trial[k]
    return OK, 0, PAIR_MAC


def pairing_rule(policy: str, pairs, lam_e) -> str:
    """The rule that made ``pairs`` under the pairing ``policy`` (a name of :data:`PAIRINGS`):
    the policy itself, or for ``"auto"`` ``"order"`` when the pairs are consecutive model modes
    in the order of the measured eigenvalues (as :func:`pair_by_order` makes them, counted from
    the first elastic mode) and ``"mac"`` otherwise.  Plain Python, not a compiled rule.

    Parameters
    ----------
    policy : str
        ``"auto"``, ``"mac"``, ``"order"`` or ``"frequency"``.
    pairs : array_like of int, shape ``(T,)``
        The 0-based model mode of each test mode.
    lam_e : array_like of float, shape ``(T,)``
        Measured eigenvalues.

    Returns
    -------
    str
        ``"mac"``, ``"order"`` or ``"frequency"``.
    """
    if policy != "auto":
        return policy
    lam_e = np.asarray(lam_e, float)
    ranks = np.empty(lam_e.size, np.int64)
    ordered = np.asarray(pairs, np.int64)[np.argsort(lam_e, kind="mergesort")]
    # by order: consecutive model modes in the order of the measured eigenvalues (counted from the
    # first elastic mode, wherever that is)
    return "order" if ordered.size == 0 or np.array_equal(np.diff(ordered), np.ones(ordered.size - 1)) else "mac"


# ---------------------------------------------------------------------------------------------
# shapes and residuals
# ---------------------------------------------------------------------------------------------
@rule
def shape_scale(scaling, phs, ref):
    """The scale s of a measured shape ``phs`` (n_s,) and the position k of its scaling entry:
    ``UNIT`` s = ±‖φ_s‖ with the sign of the largest entry (k the largest entry); ``REF``
    s = φ_s[ref]; ``MAX`` s = the largest-magnitude entry.  Returns ``(s, k, node)``, ``node``
    True when ``REF``/``MAX`` meets an entry not above 1e-12 of the largest (a node of the mode),
    or when the shape is zero at every measured dof (any scaling).

    The reference-dof scaling is the reference paper's eq. 33.

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`); any other code acts as ``MAX``.
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The shape at its measured dofs.
    ref : int
        0-based position of the reference dof within ``phs``; read only for ``REF``.

    Returns
    -------
    s : float
        The scale (divide the shape by it); 0.0 for a zero shape under ``UNIT``.
    k : int
        0-based position of the scaling entry: ``ref`` for ``REF``, else the first entry of
        largest magnitude.
    node : bool
        True when the shape cannot be scaled (see above).
    """
    amax = 0.0
    kmax = 0
    for i in range(phs.size):
        if abs(phs[i]) > amax:
            amax = abs(phs[i])
            kmax = i
    if scaling == UNIT:
        nrm = math.sqrt(dot(phs, phs))
        s = nrm if phs[kmax] > 0 else (-nrm if phs[kmax] < 0 else 0.0)
        return s, kmax, not nrm > 0  # a shape that is zero at every measured dof cannot be scaled
    k = ref if scaling == REF else kmax
    s = phs[k]
    return s, k, not (abs(s) > 1e-12 * amax)


@rule
def unit_sign(scaling, phs, s, psi_e):
    """−1 when the unit-length model shape φ_s/s points against the test shape ψ_E, else 1
    (always 1 for the other scalings, whose scale fixes the sign).

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`).
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the measured dofs.
    s : float
        Its scale from :func:`shape_scale` (non-zero).
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The scaled test shape.

    Returns
    -------
    float
        −1.0 when ``scaling == UNIT`` and φ_sᵀψ_E / s < 0, else 1.0.
    """
    if scaling != UNIT:
        return 1.0
    return -1.0 if dot(phs, psi_e) / s < 0 else 1.0


@rule
def n_shape_residuals(ns, ref):
    """Residuals of a shape measured at ``ns`` dofs: the reference entry (``ref`` >= 0) is 1 by
    construction and dropped.

    Parameters
    ----------
    ns : int
        The number of measured dofs of the shape.
    ref : int
        0-based position of the reference dof (``"ref"`` scaling), or −1 (other scalings).

    Returns
    -------
    int
        ``ns - 1`` when ``ref >= 0``, else ``ns``.
    """
    return ns - 1 if ref >= 0 else ns


@rule
def eigenvalue_residual(lam, lam_e, w):
    """w (λ_A − λ_E) / λ_E (paper eq. 19, normalised by the measured eigenvalue).

    Parameters
    ----------
    lam : float
        The model eigenvalue λ_A (rad²/s²).
    lam_e : float
        The measured eigenvalue λ_E (rad²/s²), non-zero.
    w : float
        The weight w_λ.

    Returns
    -------
    float
        The residual r_λ (dimensionless).
    """
    return w * (lam - lam_e) / lam_e


@rule
def eigenvalue_gradient(dlam, lam_e, w, dpdx, out):
    """∂r_λ/∂x (L,) from ∂λ/∂p ``dlam`` (L,) into ``out``.

    Parameters
    ----------
    dlam : numpy.ndarray of float, shape ``(L,)``
        ∂λ_A/∂p_j (rad²/s² per unit of each parameter).
    lam_e : float
        The measured eigenvalue λ_E (rad²/s²).
    w : float
        The weight w_λ.
    dpdx : numpy.ndarray of float, shape ``(L,)``
        ∂p/∂x (:func:`dp_dx`).
    out : numpy.ndarray of float, shape ``(L,)``
        Receives ``w · dlam[j] / lam_e · dpdx[j]``.

    Returns
    -------
    None
    """
    for j in range(dlam.size):
        out[j] = w * dlam[j] / lam_e * dpdx[j]


@rule
def shape_residuals(scaling, phs, psi_e, ref, w, out):
    """w (ψ_A − ψ_E) of a measured model shape ``phs`` against the scaled test shape ``psi_e``
    into ``out`` (:func:`n_shape_residuals` entries).  Returns the position of the scaling entry
    when it is a node of the mode (the residual is then undefined), else −1.

    With ψ_A = ±φ_s/s (:func:`shape_scale`, sign from :func:`unit_sign`): paper eq. 19, with the
    reference-dof scaling of eq. 33.

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`).
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the test mode's measured dofs.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The scaled test shape ψ_E.
    ref : int
        0-based position of the reference dof (``REF``; its entry is dropped), or −1.
    w : float
        The weight w_ψ.
    out : numpy.ndarray of float, shape ``(≥ n_shape_residuals(n_s, ref),)``
        Receives ``w (ψ_A[i] − ψ_E[i])`` for every ``i != ref``, in order; untouched on a node.

    Returns
    -------
    int
        The 0-based position of the scaling entry when :func:`shape_scale` reports a node (or a
        zero shape), else −1.
    """
    s, k, node = shape_scale(scaling, phs, ref)
    if node:
        return k
    sign = unit_sign(scaling, phs, s, psi_e)
    o = 0
    for i in range(phs.size):
        if i != ref:
            out[o] = w * (sign * phs[i] / s - psi_e[i])
            o += 1
    return -1


@rule
def shape_jacobian(scaling, phs, dphs, psi_e, ref, w, dpdx, out):
    """∂r_ψ/∂x into ``out`` (n_shape_residuals, L) from the derivatives ``dphs`` (n_s, L) of the
    mass-normalised measured shape: ψ' = φ_s'/s − ψ s'/s, s' = φ_sᵀφ_s'/s for unit length and
    φ_k' for the reference and largest-entry scalings.

    The shape must have passed :func:`shape_residuals` (no node at the scaling entry): no check
    is made here.

    Parameters
    ----------
    scaling : int
        ``UNIT``, ``REF`` or ``MAX`` (:data:`SCALINGS`).
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The mass-normalised model shape at the measured dofs.
    dphs : numpy.ndarray of float, shape ``(n_s, L)``
        ∂φ_s/∂p_j, one column per parameter.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The scaled test shape (for the sign of :func:`unit_sign`).
    ref : int
        0-based position of the reference dof (``REF``; its row is dropped), or −1.
    w : float
        The weight w_ψ.
    dpdx : numpy.ndarray of float, shape ``(L,)``
        ∂p/∂x (:func:`dp_dx`).
    out : numpy.ndarray of float, shape ``(≥ n_shape_residuals(n_s, ref), ≥ L)``
        Receives ∂r_ψ/∂x_j in column j, rows in the order of :func:`shape_residuals`.

    Returns
    -------
    None
    """
    s, k, node = shape_scale(scaling, phs, ref)
    sign = unit_sign(scaling, phs, s, psi_e)
    fct = w * sign / s
    for j in range(dphs.shape[1]):
        ds = dot_col(phs, dphs, j) / s if scaling == UNIT else dphs[k, j]
        o = 0
        for i in range(phs.size):
            if i != ref:
                out[o, j] = fct * (dphs[i, j] - phs[i] / s * ds) * dpdx[j]
                o += 1


@rule
def mac_residuals(phs, psi_e, w, out):
    """The MAC residuals of a measured model shape ``phs`` against the test shape ``psi_e`` into
    ``out`` (n_s entries): w (I − ê êᵀ) â, the part of the unit model shape â = ±φ_s/‖φ_s‖ (its
    sign toward the test shape) orthogonal to the unit test shape ê = ψ_E/‖ψ_E‖.  Their squared
    norm is exactly w² (1 − MAC): the cost ½‖r‖² adds w² (1 − MAC) / 2 per mode, a smooth
    function of the shapes whose Gauss–Newton curvature at a fit is that of the shape differences
    (the scalar residual w (1 − MAC) would add w² (1 − MAC)² / 2, flat to fourth order there).
    Independent of how either shape is scaled.  Returns 0 when the model shape is zero at every
    measured dof (the residual is then undefined), else −1.

    Parameters
    ----------
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the test mode's measured dofs.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The test shape (any scaling, not zero).
    w : float
        The weight w_ψ.
    out : numpy.ndarray of float, shape ``(≥ n_s,)``
        Receives ``w · sign · (φ_s[i]/‖φ_s‖ − c ψ_E[i]/‖ψ_E‖)``, c = φ_sᵀψ_E / (‖φ_s‖‖ψ_E‖) and
        sign = −1 when c < 0 else 1; untouched when the model shape is zero.

    Returns
    -------
    int
        0 when ‖φ_s‖ = 0, else −1.
    """
    nrm = math.sqrt(dot(phs, phs))
    if not nrm > 0:
        return 0
    ee = math.sqrt(dot(psi_e, psi_e))
    c = dot(phs, psi_e) / (nrm * ee)
    sign = -1.0 if c < 0 else 1.0
    for i in range(phs.size):
        out[i] = w * sign * (phs[i] / nrm - c * psi_e[i] / ee)
    return -1


@rule
def mac_jacobian(phs, dphs, psi_e, w, dpdx, out):
    """∂r/∂x of :func:`mac_residuals` into ``out`` (n_s, L) from the derivatives ``dphs``
    (n_s, L) of the model shape at the measured dofs: with u = φ_s/‖φ_s‖,
    ∂u/∂p_j = (φ_s' − u uᵀφ_s') / ‖φ_s‖, and r' = w · sign · (I − ê êᵀ) u'.

    The shape must have passed :func:`mac_residuals` (not zero): no check is made here.

    Parameters
    ----------
    phs : numpy.ndarray of float, shape ``(n_s,)``
        The model shape at the measured dofs (any scaling whose derivatives ``dphs`` are).
    dphs : numpy.ndarray of float, shape ``(n_s, L)``
        ∂φ_s/∂p_j, one column per parameter.
    psi_e : numpy.ndarray of float, shape ``(n_s,)``
        The test shape.
    w : float
        The weight w_ψ.
    dpdx : numpy.ndarray of float, shape ``(L,)``
        ∂p/∂x (:func:`dp_dx`).
    out : numpy.ndarray of float, shape ``(≥ n_s, ≥ L)``
        Receives ∂r/∂x_j in column j, rows in the order of :func:`mac_residuals`.

    Returns
    -------
    None
    """
    n = phs.size
    nrm = math.sqrt(dot(phs, phs))
    ee = math.sqrt(dot(psi_e, psi_e))
    sign = -1.0 if dot(phs, psi_e) < 0 else 1.0
    v = np.empty(n)
    for j in range(dphs.shape[1]):
        t = dot_col(phs, dphs, j) / nrm  # uᵀφ_s'
        s = 0.0
        for i in range(n):
            v[i] = (dphs[i, j] - phs[i] / nrm * t) / nrm
            s += psi_e[i] / ee * v[i]
        for i in range(n):
            out[i, j] = w * sign * (v[i] - psi_e[i] / ee * s) * dpdx[j]


__all__ = [
    "RULES", "rule", "dot", "dot_col", "sumsq_col", "SCALINGS", "PARAMETRISATIONS", "REPEATED_TOL", "RIGID_TOL", "ERRORS", "message",
    "to_p", "dp_dx", "check_spectrum", "check_distinct", "mac_vector", "assign", "pair_by_mac", "shape_scale",
    "unit_sign", "n_shape_residuals", "eigenvalue_residual", "eigenvalue_gradient", "shape_residuals",
    "shape_jacobian", "mac_residuals", "mac_jacobian",
]
