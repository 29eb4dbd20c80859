r"""The pairing of test modes with model modes, written once: the MAC, the assignment, the
pairing policies.  Rules of the modal updating problem (:mod:`femupdate.rules` hands them all
on): plain Python on NumPy arrays and numbers, error codes instead of exceptions, called as
Python by the local route and compiled by the compiled route
(:mod:`femupdate.updating.batched.kernel`).  Every pairing in femupdate goes through them; the
entry point for everything but the compiled kernels is :func:`femupdate.correlation.pair`,
which says what it did.

* the MAC: :func:`mac_value` from two shapes' inner products (the formula, its zero and its
  clipping, once), :func:`mac_vector` of one shape against the columns of a matrix (the
  compiled inner products; :func:`femupdate.correlation.mac` takes the matrix of every pair with
  BLAS, real or complex, and this same formula);
* the assignment of largest total MAC (least total cost): :func:`assign`, the Hungarian
  algorithm with shortest augmenting paths, rectangular either way;
* the policies (:data:`PAIRINGS`, :func:`pair_modes`): by MAC over each test mode's measured
  dofs (:func:`pair_by_mac`), by frequency order (:func:`pair_by_order`), by frequency with MAC
  breaking ties (:func:`pair_by_frequency`), or ``auto``, by order until the shapes show a swap;
  and :func:`pairing_rule`, which tells from a compiled result's pairs the rule that made them;
* the groups of repeated or close model modes (:func:`group_bounds`), which the modal problem pairs
  and compares as a whole (:mod:`femupdate.updating.groups`).
"""

from __future__ import annotations

import math

import numpy as np

from ._rulebase import E_NO_MODE_LEFT, E_NO_PAIR, OK, dot, dot_col, rule, sumsq_col

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


@rule
def mac_value(ab2, aa, bb):
    """The modal assurance criterion of two shapes a and b from their inner products:
    |aᴴb|² / (aᴴa · bᴴb), clipped to [0, 1]; 0 where the denominator is 0 (a zero shape).

    Parameters
    ----------
    ab2 : float
        |aᴴb|², the squared magnitude of the shapes' inner product.
    aa, bb : float
        aᴴa and bᴴb, the shapes' squared norms.

    Returns
    -------
    float
        The MAC, in [0, 1].
    """
    den = aa * bb
    v = ab2 / den if den > 0 else 0.0
    return min(max(v, 0.0), 1.0)


@rule
def mac_vector(psi, B, out):
    """MAC of the shape ``psi`` (n_s,) against the columns of ``B`` (n_s, nm) into ``out`` (nm,),
    each in [0, 1] (0 where a column is zero): :func:`mac_value` of the inner products.

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
        out[j] = mac_value(num * num, ee, sumsq_col(B, j))


@rule
def assign(C, nr, nc, out):
    """Rows 0..nr-1 of the cost matrix C to distinct columns 0..nc-1, minimising the total cost
    (the Hungarian algorithm with potentials and shortest augmenting paths, as
    :func:`scipy.optimize.linear_sum_assignment`); ``out[i]`` the column of row i.  With more
    rows than columns every column takes a distinct row (the transposed problem, as SciPy solves
    it) and the rows left over get −1.  Where several assignments share the least total cost,
    which one is returned is the algorithm's choice (SciPy's may differ).

    Parameters
    ----------
    C : numpy.ndarray of float, shape ``(≥ nr, ≥ nc)``
        Finite costs; only ``C[:nr, :nc]`` is read.
    nr, nc : int
        The numbers of rows and columns to assign.
    out : numpy.ndarray of int64, shape ``(≥ nr,)``
        Receives the 0-based column of each row, −1 for a row left over (``nr > nc``).

    Returns
    -------
    None
    """
    if nr <= nc:
        assign_rows(C, nr, nc, out)
        return
    Ct = np.empty((nc, nr))
    for i in range(nr):
        for j in range(nc):
            Ct[j, i] = C[i, j]
    row = np.empty(nc, np.int64)
    assign_rows(Ct, nc, nr, row)
    for i in range(nr):
        out[i] = -1
    for j in range(nc):
        out[row[j]] = j


@rule
def assign_rows(C, nr, nc, out):
    """:func:`assign` with no more rows than columns (``nr <= nc``, not checked): every row
    assigned.

    Parameters
    ----------
    C : numpy.ndarray of float, shape ``(≥ nr, ≥ nc)``
        Finite costs; only ``C[:nr, :nc]`` is read.
    nr, nc : int
        The numbers of rows and columns, ``nr <= nc``.
    out : numpy.ndarray of int64, shape ``(≥ nr,)``
        Receives the 0-based column of each row.

    Returns
    -------
    None
    """
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
    MAC, shaped, lam, lam_e
        As :func:`pair_by_frequency`.
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
    ordered = np.asarray(pairs, np.int64)[np.argsort(lam_e, kind="mergesort")]
    # by order: consecutive model modes in the order of the measured eigenvalues (counted from the
    # first elastic mode, wherever that is)
    return "order" if ordered.size == 0 or np.array_equal(np.diff(ordered), np.ones(ordered.size - 1)) else "mac"


@rule
def group_bounds(lam, nm, t, tol):
    """The group of close modes around mode ``t``: the run of consecutive computed modes whose
    neighbouring eigenvalues lie within ``tol`` (relative) of each other.

    Modes are chained: ``i`` and ``i + 1`` belong together when
    ``|λ_{i+1} − λ_i| <= tol · max(|λ_i|, |λ_{i+1}|)``, a relative gap however large the other
    eigenvalues of the pencil (a penalty stiffness does not make low modes "close"); a rigid-body
    mode (λ exactly 0) joins no group.  The
    pairing compares a test mode paired into such a group with the group as a whole
    (:mod:`femupdate.updating.groups`).

    Parameters
    ----------
    lam : numpy.ndarray of float, shape ``(≥ nm,)``
        Eigenvalues (rad²/s²), ascending, rigid-body ones exactly 0 (:func:`femupdate.rules.check_spectrum`).
    nm : int
        The number of computed eigenvalues.
    t : int
        The 0-based mode, ``0 <= t < nm``.
    tol : float
        The relative gap (:data:`femupdate.rules.CLOSE_TOL` by default in updating).

    Returns
    -------
    first : int
        The group's first mode (0-based).
    stop : int
        One past its last mode: the group is ``first .. stop - 1``, ``stop - first == 1`` for a
        mode alone (or a rigid-body mode).
    """
    first = t
    stop = t + 1
    if lam[t] == 0.0:
        return first, stop
    while first > 0 and lam[first - 1] != 0.0 and \
            abs(lam[first] - lam[first - 1]) <= tol * max(abs(lam[first - 1]), abs(lam[first])):
        first -= 1
    while stop < nm and lam[stop] != 0.0 and \
            abs(lam[stop] - lam[stop - 1]) <= tol * max(abs(lam[stop - 1]), abs(lam[stop])):
        stop += 1
    return first, stop



__all__ = ["PAIR_MAC", "PAIR_ORDER", "PAIR_FREQUENCY", "PAIR_AUTO", "PAIRINGS", "PAIRING_NAMES", "FREQUENCY_WINDOW",
           "AUTO_MARGIN", "AUTO_SWAP_MAC", "mac_value", "mac_vector", "assign", "assign_rows", "pair_by_mac",
           "pair_by_order", "pair_by_frequency", "pair_modes", "pairing_rule", "group_bounds"]
