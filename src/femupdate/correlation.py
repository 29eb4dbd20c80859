r"""Correlation of test and model modes: MAC, pairing, frequency errors, COMAC.

All functions that take labelled shapes compare them on the dofs they have in common, by
label, never by index.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from ._errors import InputError
from .dofs import canonical_all


def mac(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r"""Modal assurance criterion between the columns of ``A`` (n, ma) and ``B`` (n, mb).

    .. math:: \mathrm{MAC}_{rs} = |a_r^H b_s|^2 / ((a_r^H a_r)(b_s^H b_s))

    Real or complex; independent of each column's scaling.

    Parameters
    ----------
    A : array_like, shape ``(n_dofs, ma)`` or ``(n_dofs,)``
        First set of shapes, one per column (a vector is one shape).
    B : array_like, shape ``(n_dofs, mb)`` or ``(n_dofs,)``
        Second set, on the same dofs in the same order.

    Returns
    -------
    numpy.ndarray, shape ``(ma, mb)``
        MAC values in [0, 1]; 0 where either shape is zero.

    Raises
    ------
    InputError
        ``A`` and ``B`` have different numbers of rows.
    """
    A = np.asarray(A)
    B = np.asarray(B)
    if A.ndim == 1:
        A = A[:, None]
    if B.ndim == 1:
        B = B[:, None]
    if A.shape[0] != B.shape[0]:
        raise InputError(f"MAC: shapes have {A.shape[0]} and {B.shape[0]} dofs")
    num = np.abs(A.conj().T @ B) ** 2
    den = np.outer(np.sum(np.abs(A) ** 2, axis=0), np.sum(np.abs(B) ** 2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return np.clip(out.real, 0.0, 1.0)


def common_dofs(dofs_a: Sequence[str], dofs_b: Sequence[str]) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """Positions in ``a`` and ``b`` of their common labels (in ``a``'s order).

    Parameters
    ----------
    dofs_a, dofs_b : sequence of str
        Dof labels ``"node:dir"`` (compared in canonical form).

    Returns
    -------
    ia : numpy.ndarray of int, shape ``(n_common,)``
        Positions of the common labels in ``dofs_a``.
    ib : numpy.ndarray of int, shape ``(n_common,)``
        Positions of the same labels in ``dofs_b``.
    common : tuple of str
        The common labels, canonical, in ``dofs_a``'s order.

    Raises
    ------
    InputError
        No label in common (or an invalid label).
    """
    a = canonical_all(dofs_a)
    pos_b = {d: i for i, d in enumerate(canonical_all(dofs_b))}
    ia = [i for i, d in enumerate(a) if d in pos_b]
    if not ia:
        raise InputError("the test and model shapes have no dof in common (check the dof labels)")
    common = tuple(a[i] for i in ia)
    return np.array(ia), np.array([pos_b[d] for d in common]), common


def pair_modes(mac_matrix: np.ndarray, min_mac: float = 0.5) -> list[tuple[int, int, float]]:
    """Pair test modes (rows) with model modes (columns) by MAC.

    An optimal assignment (Hungarian algorithm, :func:`scipy.optimize.linear_sum_assignment`)
    maximises the total MAC, so one model mode is never paired twice; pairs whose MAC is below
    ``min_mac`` are dropped.

    Parameters
    ----------
    mac_matrix : array_like, shape ``(n_test, n_model)``
        MAC of each test mode (row) with each model mode (column), as :func:`mac` gives it.
    min_mac : float, default 0.5
        Smallest MAC of a kept pair.

    Returns
    -------
    list of (int, int, float)
        ``[(test, model, mac)]`` with 0-based mode indices, sorted by test mode.
    """
    mm = np.asarray(mac_matrix, dtype=float)
    rows, cols = linear_sum_assignment(mm, maximize=True)
    pairs = [(int(r), int(c), float(mm[r, c])) for r, c in zip(rows, cols) if mm[r, c] >= min_mac]
    return sorted(pairs)


def modal_scale_factor(test: np.ndarray, model: np.ndarray) -> np.ndarray:
    """Per-column factor ``s`` minimising ``||test - s * model||`` (the modal scale factor).

    Parameters
    ----------
    test, model : numpy.ndarray, shape ``(n_dofs, n_modes)``
        Paired shapes, column by column, on the same dofs (real or complex).

    Returns
    -------
    numpy.ndarray, shape ``(n_modes,)``
        ``s_r = model_rᴴ test_r / model_rᴴ model_r``.
    """
    num = np.sum(np.conj(model) * test, axis=0)
    den = np.sum(np.abs(model) ** 2, axis=0)
    return num / den


def comac(test: np.ndarray, model: np.ndarray) -> np.ndarray:
    r"""Coordinate MAC per dof over paired modes (Lieven & Ewins 1988).

    Columns of ``test`` and ``model`` are paired modes.  Each model shape is first scaled to its
    test shape by the modal scale factor and each pair to unit test norm, so that the result
    does not depend on the shapes' scaling and every mode weighs alike:

    .. math:: \mathrm{COMAC}_i = (\sum_r |t_{ir} a_{ir}|)^2 / (\sum_r |t_{ir}|^2 \sum_r |a_{ir}|^2)

    A low value marks a dof whose measured motion does not follow the model across the modes
    (a bad sensor, a wrong label, local modelling error).  A factor common to all modes at a
    dof (a calibration error, even a reversed sensor) is invisible to it.

    Parameters
    ----------
    test, model : array_like, shape ``(n_dofs, n_pairs)``
        Test shapes and the model shapes paired with them, column by column, on the same dofs.

    Returns
    -------
    numpy.ndarray, shape ``(n_dofs,)``
        COMAC per dof, in [0, 1]; 1 at a dof where both are zero in every mode.
    """
    test = np.asarray(test)
    model = np.asarray(model) * modal_scale_factor(test, np.asarray(model))
    nrm = np.linalg.norm(test, axis=0)
    test, model = test / nrm, model / nrm
    num = np.sum(np.abs(test * np.conj(model)), axis=1) ** 2
    den = np.sum(np.abs(test) ** 2, axis=1) * np.sum(np.abs(model) ** 2, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0).real


@dataclass(frozen=True, eq=False)
class Correlation:
    """Result of :func:`correlate`.

    ``mac`` (n_test, n_model) on the common ``dofs``; ``pairs`` [(test, model, mac)];
    ``frequency_error`` relative (model - test) / test per pair; ``comac`` per common dof.

    Parameters
    ----------
    dofs : tuple of str
        The dofs of the COMAC: those every paired test shape was measured at and the model has
        (empty when no test mode has a shape).
    mac : numpy.ndarray, shape ``(n_test, n_model)``
        MAC of each test mode over its own measured dofs (as ``update`` pairs them); rows of
        test modes without a shape are 0.
    pairs : list of (int, int, float)
        ``(test mode, model mode, MAC)``, 0-based, sorted by test mode (MAC NaN when paired by
        frequency order).
    test_frequencies_hz : numpy.ndarray, shape ``(n_test,)``
        Measured natural frequencies, Hz.
    model_frequencies_hz : numpy.ndarray, shape ``(n_model,)``
        Model natural frequencies, Hz.
    frequency_error : numpy.ndarray, shape ``(n_pairs,)``
        Relative error (f_model − f_test) / f_test per pair (dimensionless).
    comac : numpy.ndarray, shape ``(len(dofs),)``
        COMAC per dof over the shaped pairs (empty without shapes).
    unpaired_test : list of int
        Test modes left without a model mode.
    unconfirmed : list of int
        Paired test modes whose pair's MAC is below ``min_mac`` (the shapes do not confirm it).
    """

    dofs: tuple[str, ...]
    mac: np.ndarray
    pairs: list[tuple[int, int, float]]
    test_frequencies_hz: np.ndarray
    model_frequencies_hz: np.ndarray
    frequency_error: np.ndarray
    comac: np.ndarray
    unpaired_test: list[int]
    unconfirmed: list[int] = field(default_factory=list)


def correlate(test, model_modes, min_mac: float = 0.5, pairing: str = "auto") -> Correlation:
    """Correlate :class:`~femupdate.TestData` modes with :class:`~femupdate.Modes`.

    Test and model modes are paired by the rule that :func:`femupdate.update` uses
    (:func:`femupdate.rules.pair_modes`, the policy ``pairing``), on each test mode's MAC over
    its own measured dofs: the same data and model give the same pairs here as in ``update``.
    With ``pairing="mac"`` a shaped test mode whose best MAC stays below ``min_mac`` is left
    unpaired; with the other policies every test mode is paired and such a pair is listed in
    ``unconfirmed``.  COMAC is computed on the dofs every paired shape was measured at.

    Parameters
    ----------
    test : TestData
        The measured modes (frequencies in Hz, shapes at labelled dofs).
    model_modes : Modes
        Model modes, e.g. from :func:`femupdate.model_modes`.
    min_mac : float, default 0.5
        The pairing threshold (as ``update``'s ``min_mac``).
    pairing : {"auto", "mac", "order", "frequency"}, default ``"auto"``
        The pairing policy (as ``update``'s).

    Returns
    -------
    Correlation

    Raises
    ------
    InputError
        An unknown ``pairing``; a test shape with no dof in common with the model.
    """
    from . import rules

    if pairing not in rules.PAIRINGS:
        raise InputError(f"unknown pairing {pairing!r}: use {', '.join(rules.PAIRINGS)}")
    modes = test.modes
    T = len(modes)
    f_t = test.frequencies_hz
    f_a = model_modes.frequencies_hz
    nm = len(f_a)
    pos = {d: i for i, d in enumerate(canonical_all(model_modes.dofs))}
    shaped = np.zeros(T, bool)
    M = np.zeros((T, nm))
    for k, m in enumerate(modes):
        if not m.has_shape:
            continue
        rows = [(i, pos[d]) for i, d in enumerate(canonical_all(m.dofs)) if d in pos]
        if not rows:
            raise InputError(f"test mode {k + 1} ({m.label or 'unlabelled'}): its shape has no dof in common with the "
                             "model (check the dof labels)")
        rt, ra = map(list, zip(*rows))
        M[k] = mac(np.asarray(m.shape)[rt], model_modes.shapes[ra])[0]
        shaped[k] = True
    lam_e = np.array([m.eigenvalue for m in modes], float)
    pairs_arr, bad = np.zeros(T, np.int64), np.zeros(T, bool)
    policy = rules.PAIRINGS[pairing]
    code, _, _ = rules.pair_modes(rules.PAIR_ORDER if policy == rules.PAIR_AUTO and not shaped.any() else policy,
                                  M, shaped, np.asarray(model_modes.eigenvalues, float), lam_e, nm,
                                  0.0 if policy == rules.PAIR_MAC else float(min_mac), pairs_arr, bad)
    if code != rules.OK:  # more test modes than model modes: the best assignment of those there are
        pairs = [(k, j, float(M[k, j]) if shaped[k] else math.nan) for k, j, _ in pair_modes(M, 0.0)]
    else:
        pairs = [(k, int(pairs_arr[k]), float(M[k, pairs_arr[k]]) if shaped[k] else math.nan) for k in range(T)]
    if policy == rules.PAIR_MAC:
        pairs = [p for p in pairs if not (shaped[p[0]] and p[2] < min_mac)]
    unconfirmed = [k for k, _, m in pairs if shaped[k] and m < min_mac]
    err = np.array([(f_a[j] - f_t[i]) / f_t[i] if f_t[i] > 0 else np.nan for i, j, _ in pairs])
    tdofs, Phi_t = test.shape_matrix()
    common: tuple[str, ...] = ()
    cm = np.zeros(0)
    shaped_pairs = [(i, j) for i, j, _ in pairs if shaped[i]]
    if tdofs and shaped_pairs:
        it, ia, common = common_dofs(tdofs, model_modes.dofs)
        ti = [i for i, _ in shaped_pairs]
        Pt = Phi_t[it][:, ti]
        keep = ~np.isnan(Pt.real if np.iscomplexobj(Pt) else Pt).any(axis=1)  # dofs every paired shape has
        common = tuple(d for d, k in zip(common, keep) if k)
        cm = comac(Pt[keep], model_modes.shapes[ia][keep][:, [j for _, j in shaped_pairs]]) if keep.any() else cm
    unpaired = sorted(set(range(T)) - {p[0] for p in pairs})
    return Correlation(common, M, pairs, f_t, f_a, err, cm, unpaired, unconfirmed)
