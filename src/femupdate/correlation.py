r"""Correlation of test and model modes: MAC, pairing, frequency errors, COMAC.

:func:`pair` is femupdate's one entry point for pairing test modes with model modes: every
pairing outside the compiled kernels goes through it (``correlate``, ``update``'s
:class:`~femupdate.updating.Problem`, finite-difference sensitivities, reduction metrics, the
report), and it returns a :class:`Pairing` that says what it did.  It and the compiled route
share the rules of :mod:`femupdate.pairing_rules` (the MAC, the assignment, the policies).

All functions that take labelled shapes compare them on the dofs they have in common, by
label, never by index.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ._checks import array_arg, bools_arg, data_arg, flag_arg, modes_arg, real_arg, swapped
from ._errors import InputError, NumericalError
from ._rulebase import OK, message
from .dofs import canonical_all
from .pairing_rules import FREQUENCY_WINDOW, PAIR_MAC, PAIRING_NAMES, PAIRINGS, assign, mac_value, pair_modes as _kernel
from .serialise import RunContext, Serialisable
from .testdata import TestData


def mac(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r"""Modal assurance criterion between the columns of ``A`` (n, ma) and ``B`` (n, mb).

    .. math:: \mathrm{MAC}_{rs} = |a_r^H b_s|^2 / ((a_r^H a_r)(b_s^H b_s))

    Real or complex; independent of each column's scaling.  The inner products are BLAS's, the
    formula (with its 0 for a zero shape and its clipping) the rule
    :func:`femupdate.pairing_rules.mac_value` that the compiled route applies.

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
    A = np.asarray(array_arg(A, "A", "mac", complex_ok=True))
    B = np.asarray(array_arg(B, "B", "mac", complex_ok=True))
    if A.ndim > 2 or B.ndim > 2:
        raise InputError(f"mac: A and B must be shapes (1-D) or shapes in columns (2-D), got shapes {A.shape} and "
                         f"{B.shape}")
    if A.ndim == 1:
        A = A[:, None]
    if B.ndim == 1:
        B = B[:, None]
    if A.shape[0] != B.shape[0]:
        raise InputError(f"MAC: shapes have {A.shape[0]} and {B.shape[0]} dofs (the rows of A and B)")
    num = np.abs(A.conj().T @ B) ** 2
    aa = np.sum(np.abs(A) ** 2, axis=0).tolist()
    bb = np.sum(np.abs(B) ** 2, axis=0).tolist()
    return np.array([[mac_value(n, a, b) for n, b in zip(row, bb)] for row, a in zip(num.tolist(), aa)],
                    float).reshape(num.shape)


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


def check_pairing(rule: str, min_mac) -> float:
    """Check a pairing rule and threshold as the user gave them.

    Parameters
    ----------
    rule : str
        A name of :data:`femupdate.pairing_rules.PAIRINGS`.
    min_mac : float
        The threshold, a number in [0, 1].

    Returns
    -------
    float
        ``min_mac`` as a float.

    Raises
    ------
    InputError
        An unknown ``rule``, or ``min_mac`` not a number in [0, 1] (named as given).
    """
    if isinstance(min_mac, (bool, np.bool_)) or not isinstance(min_mac, numbers.Real) \
            or not 0.0 <= float(min_mac) <= 1.0:
        raise InputError(f"min_mac must be a number between 0 and 1, got {min_mac!r}")
    value = float(min_mac)
    if not isinstance(rule, str) or rule not in PAIRINGS:
        raise InputError(f"unknown pairing {rule!r}: use {', '.join(PAIRINGS)}")
    return value


@dataclass(frozen=True, eq=False)
class Pairing:
    """What :func:`pair` did: the pairs of test modes (the MAC matrix's rows) with model modes
    (its columns), the rule that made them, and the pairs to doubt.

    Parameters
    ----------
    pairs : tuple of (int, int, float)
        ``(test mode, model mode, MAC)``, 0-based, sorted by test mode; the MAC is NaN for a test
        mode without a shape.
    rule : str
        The rule asked for: ``"auto"``, ``"mac"``, ``"order"`` or ``"frequency"``.
    used : str
        The rule that made the pairs: ``"mac"``, ``"order"`` or ``"frequency"``; ``"mac"`` too
        when the rule asked for could not pair every test mode (more test modes than model modes)
        and the pairs are the assignment of largest total MAC of those there are.
    min_mac : float
        The threshold the pairs were held against.
    unpaired : tuple of int
        Test modes left without a model mode.
    unconfirmed : tuple of int
        Paired test modes with a shape whose pair's MAC is below ``min_mac``: the shapes do not
        confirm the pair (under ``strict`` pairing by ``"mac"`` there are none).
    frequency_error : numpy.ndarray of float, shape ``(len(pairs),)``
        Relative error (f_model − f_test) / f_test of each pair; NaN for a test mode at 0 Hz, and
        for every pair when no eigenvalues were given.
    large_change : tuple of int
        Paired test modes whose pair crosses a large frequency change: ``|frequency error|`` above
        ``max_change`` (empty without eigenvalues).
    max_change : float
        The relative frequency change that counts as large.
    """

    pairs: tuple[tuple[int, int, float], ...]
    rule: str
    used: str
    min_mac: float
    unpaired: tuple[int, ...]
    unconfirmed: tuple[int, ...]
    frequency_error: np.ndarray
    large_change: tuple[int, ...]
    max_change: float


def pair(mac_matrix, *, rule: str = "auto", min_mac: float = 0.5, shaped=None, model_eigenvalues=None,
         test_eigenvalues=None, strict: bool = False, max_change: float = FREQUENCY_WINDOW) -> Pairing:
    """Pair test modes (rows of ``mac_matrix``) with model modes (its columns) by ``rule``.

    The rules are those of :func:`femupdate.pairing_rules.pair_modes`, which the compiled route
    calls too: ``"mac"`` the assignment of largest total MAC (Hungarian algorithm), test modes
    without a shape taking the lowest free model modes in order; ``"order"`` by frequency order
    (rigid-body modes only with test modes at 0 Hz); ``"frequency"`` the nearest frequency, MAC
    deciding within 10 %; ``"auto"`` by order unless the shapes show a swap clearly, then by MAC.

    What happens to a test mode that cannot be paired depends on ``strict``.  Strict (as
    ``update`` pairs): every test mode must be paired, by ``"mac"`` at a MAC of at least
    ``min_mac``, or :class:`NumericalError`.  Otherwise (as ``correlate`` pairs): by ``"mac"`` a
    test mode with a shape whose MAC stays below ``min_mac`` is left unpaired; by the other rules
    it is paired and listed as unconfirmed; and when the rule cannot pair every test mode (more
    test modes than model modes) the pairs are the assignment of largest total MAC of those there
    are.

    Parameters
    ----------
    mac_matrix : array_like of float, shape ``(n_test, n_model)``
        MAC of each test mode with each model mode (:func:`mac`), read only where ``shaped``.
    rule : {"auto", "mac", "order", "frequency"}, default ``"auto"``
        The pairing rule; all but ``"mac"`` need the eigenvalues.
    min_mac : float, default 0.5
        The threshold in [0, 1]: the smallest MAC of a pair by ``"mac"``, or of a pair the shapes
        confirm.
    shaped : array_like of bool, shape ``(n_test,)``, optional
        Which test modes have a shape (default: all).
    model_eigenvalues : array_like of float, shape ``(≥ n_model,)``, optional
        The model modes' eigenvalues (rad²/s²), ascending, rigid-body ones exactly 0.
    test_eigenvalues : array_like of float, shape ``(n_test,)``, optional
        The measured eigenvalues (rad²/s²).
    strict : bool, default False
        Fail rather than leave a test mode unpaired (see above).
    max_change : float, default 0.1
        The relative frequency error above which a pair is listed in ``large_change``.

    Returns
    -------
    Pairing

    Raises
    ------
    InputError
        An unknown ``rule``; ``min_mac`` not in [0, 1]; a MAC matrix that is not 2-D; ``shaped``
        or the eigenvalues of the wrong length, or missing where ``rule`` needs them.
    NumericalError
        ``strict`` and a test mode cannot be paired (the message names it); a non-finite MAC of a
        test mode with a shape.
    """
    array_arg(mac_matrix, "mac_matrix", "pair", finite=False)
    bools_arg(shaped, "shaped", "pair")
    array_arg(model_eigenvalues, "model_eigenvalues", "pair", ndim=1, optional=True)
    array_arg(test_eigenvalues, "test_eigenvalues", "pair", ndim=1, optional=True)
    flag_arg(strict, "strict", "pair")
    real_arg(max_change, "max_change", "pair", low=0.0)
    min_mac = check_pairing(rule, min_mac)
    M = np.asarray(mac_matrix, dtype=float)
    if M.ndim != 2:
        raise InputError(f"pair: the MAC matrix (mac_matrix) must be 2-D (test modes x model modes), got shape "
                         f"{M.shape}")
    T, nm = M.shape
    shaped = np.ones(T, bool) if shaped is None else np.asarray(shaped, bool)
    if shaped.shape != (T,):
        raise InputError(f"pair: shaped has {shaped.size} entries for {T} test modes")
    lam, lam_e = _eigenvalues(rule, model_eigenvalues, test_eigenvalues, T, nm)
    bad_rows = np.flatnonzero(shaped & ~np.isfinite(M).all(axis=1))
    if bad_rows.size:
        raise NumericalError(f"pair: non-finite MAC of test mode(s) {[int(k) + 1 for k in bad_rows]} (mac_matrix)")
    if nm == 0:  # the rules read a first column
        M = np.zeros((T, 1))
    policy = PAIRINGS[rule]
    cols, bad = np.zeros(T, np.int64), np.zeros(T, bool)
    code, i, used = _kernel(policy, M, shaped, np.zeros(nm) if lam is None else lam,
                            np.zeros(T) if lam_e is None else lam_e, nm,
                            0.0 if policy == PAIR_MAC and not strict else min_mac, cols, bad)
    if code != OK:
        if strict:
            raise NumericalError(message(code, i, modes=np.flatnonzero(bad), min_mac=min_mac))
        # the assignment of largest total MAC of those there are (a mode without shape at MAC 0)
        assign(-np.where(shaped[:, None], M, 0.0), T, nm, cols)
        used = PAIR_MAC
    pairs = [(k, int(cols[k]), float(M[k, cols[k]]) if shaped[k] else math.nan) for k in range(T) if cols[k] >= 0]
    if policy == PAIR_MAC and not strict:
        pairs = [p for p in pairs if not (shaped[p[0]] and p[2] < min_mac)]
    err = np.full(len(pairs), np.nan)
    if lam is not None and lam_e is not None:
        f_t = np.sqrt(np.clip(lam_e, 0.0, None)) / (2 * np.pi)
        f_a = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
        err = np.array([(f_a[j] - f_t[k]) / f_t[k] if f_t[k] > 0 else np.nan for k, j, _ in pairs], float)
    paired = {k for k, _, _ in pairs}
    return Pairing(tuple(pairs), rule, PAIRING_NAMES[used], min_mac,
                   unpaired=tuple(k for k in range(T) if k not in paired),
                   unconfirmed=tuple(k for k, _, m in pairs if shaped[k] and m < min_mac),
                   frequency_error=err, max_change=float(max_change),
                   large_change=tuple(k for (k, _, _), e in zip(pairs, err) if abs(e) > max_change))


def _eigenvalues(rule, model_eigenvalues, test_eigenvalues, T: int, nm: int):
    """The eigenvalues :func:`pair` was given, as float arrays (the model's lowest ``nm``), or None."""
    if model_eigenvalues is None or test_eigenvalues is None:
        if rule != "mac":
            raise InputError(f"pairing {rule!r} needs the eigenvalues of the model and of the test modes "
                             "(model_eigenvalues, test_eigenvalues)")
        return None, None
    lam = np.asarray(model_eigenvalues, dtype=float).ravel()
    lam_e = np.asarray(test_eigenvalues, dtype=float).ravel()
    if lam.size < nm or lam_e.size != T:
        raise InputError(f"pair: {lam.size} model and {lam_e.size} test eigenvalues (model_eigenvalues, "
                         f"test_eigenvalues) for a MAC matrix (mac_matrix) of {T} test and {nm} model modes")
    return lam[:nm], lam_e


def pair_modes(mac_matrix: np.ndarray, min_mac: float = 0.5) -> list[tuple[int, int, float]]:
    """Pair test modes (rows) with model modes (columns) by MAC alone: a thin alias of
    :func:`pair`, ``list(pair(mac_matrix, rule="mac", min_mac=min_mac).pairs)``.

    The assignment maximises the total MAC (Hungarian algorithm), so one model mode is never
    paired twice; with more rows than columns the rows of largest MAC take the columns; pairs
    whose MAC is below ``min_mac`` are dropped.

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
    return list(pair(mac_matrix, rule="mac", min_mac=min_mac).pairs)


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
class Correlation(Serialisable):
    """Result of :func:`correlate`; a result of kind ``correlate`` (:mod:`femupdate.serialise`:
    ``to_json()`` is what ``femupdate correlate --json`` writes, ``to_frame()`` one row per pair).

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
    pairing : Pairing or None
        What :func:`pair` did (the rule asked for and used, frequency changes); None when built
        by hand or read back from JSON.
    context : RunContext, optional
        The test data correlated (:func:`correlate`; their notes, units and damping ratios go
        into the JSON, not the data themselves) and the model's damping they are compared with
        (``corr.with_context(damping=...)``, as ``--damping``).
    """

    kind: ClassVar[str] = "correlate"

    dofs: tuple[str, ...]
    mac: np.ndarray
    pairs: list[tuple[int, int, float]]
    test_frequencies_hz: np.ndarray
    model_frequencies_hz: np.ndarray
    frequency_error: np.ndarray
    comac: np.ndarray
    unpaired_test: list[int]
    unconfirmed: list[int] = field(default_factory=list)
    pairing: Pairing | None = None
    context: RunContext | None = field(default=None, compare=False, repr=False)

    def payload(self) -> dict:
        from .modal_record import correlate_kind

        return correlate_kind(self, self.run_context)

    @classmethod
    def from_payload(cls, obj):
        from .modal_record import correlate_from

        return correlate_from(obj)

    def records(self) -> list[dict]:
        """One record per pair (0-based ``test`` and ``model`` modes, their frequencies in Hz, the
        relative ``frequency_error`` and the ``mac``), then one per unpaired test mode (``model``
        None): :meth:`to_frame`'s rows."""
        out = [{"test": i, "model": j, "test_hz": float(self.test_frequencies_hz[i]),
                "model_hz": float(self.model_frequencies_hz[j]), "frequency_error": float(e), "mac": float(m)}
               for (i, j, m), e in zip(self.pairs, self.frequency_error)]
        return out + [{"test": i, "model": None, "test_hz": float(self.test_frequencies_hz[i]), "model_hz": None,
                       "frequency_error": None, "mac": None} for i in self.unpaired_test]


def correlate(test, model_modes, min_mac: float = 0.5, pairing: str = "auto", close_modes: float = 0.01) -> Correlation:
    """Correlate :class:`~femupdate.TestData` modes with :class:`~femupdate.Modes`.

    Test and model modes are paired by :func:`pair` with the rule that :func:`femupdate.update`
    uses (the policy ``pairing``), on each test mode's MAC over its own measured dofs: the same
    data and model give the same pairs here as in ``update``.  Model modes closer than
    ``close_modes`` (relative eigenvalue gap) form groups, paired as ``update`` pairs them
    (:mod:`femupdate.close_modes`): the MAC of a pair into a group is that of the best combination
    of the group's shapes (``mac`` itself keeps every model mode's own; real test shapes only).
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
    close_modes : float, default 0.01
        The relative eigenvalue gap of a group of repeated or close model modes (as ``update``'s;
        0: none).

    Returns
    -------
    Correlation
        With the test data as its context (their notes, units and damping ratios in its JSON).

    Raises
    ------
    InputError
        An unknown ``pairing``; ``min_mac`` not in [0, 1]; a test shape with no dof in common with
        the model.
    """
    swapped("correlate", ("test", test, "TestData"), ("model_modes", model_modes, "Modes"))
    data_arg(test, "test", "correlate")
    modes_arg(model_modes, "model_modes", "correlate")
    min_mac = check_pairing(pairing, min_mac)
    modes = test.modes
    T = len(modes)
    f_t = test.frequencies_hz
    f_a = model_modes.frequencies_hz
    nm = len(f_a)
    pos = {d: i for i, d in enumerate(canonical_all(model_modes.dofs))}
    shaped = np.zeros(T, bool)
    M = np.zeros((T, nm))
    measured = {}
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
        measured[k] = (np.asarray(m.shape)[rt], model_modes.shapes[ra])
    from .close_modes import assign_inside, group_columns, mode_groups

    groups = mode_groups(model_modes.eigenvalues, close_modes) if close_modes > 0 else []
    real = all(np.isrealobj(psi) for psi, _ in measured.values())
    M_pair, combos = group_columns(M, groups, measured) if groups and real else (M, {})
    pg = pair(M_pair, rule=pairing, min_mac=min_mac, shaped=shaped, model_eigenvalues=model_modes.eigenvalues,
              test_eigenvalues=[m.eigenvalue for m in modes])
    pairs = assign_inside(pg.pairs, groups, combos) if combos else list(pg.pairs)
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
    err = pg.frequency_error if not combos else np.array(
        [(f_a[j] - f_t[k]) / f_t[k] if f_t[k] > 0 else np.nan for k, j, _ in pairs], float)
    return Correlation(common, M, pairs, f_t, f_a, err, cm, list(pg.unpaired), list(pg.unconfirmed), pg,
                       context=RunContext(data=test if isinstance(test, TestData) else None))
