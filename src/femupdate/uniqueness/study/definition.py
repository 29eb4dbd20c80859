"""Definition of a uniqueness study: the cases (measurement plans), the truth, the random starts
and the split of the study's rows into work units."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..._budget import STUDY_ROW_BYTES, check_memory
from ..._checks import count_arg, flag_arg, model_arg, params_arg, real_arg, shown, strings_arg, values_arg
from ..._errors import InputError
from ...dofs import canonical_all, resolve_all
from ...model import Model

ALGORITHM = "femupdate-uniqueness-2"  # part of the study key: bump when raw results change meaning (2: auto pairing)
DEFAULT_UNIT_ROWS = 4096


# ====================================================================== definition
@dataclass(frozen=True)
class Case:
    """One measurement plan: the measured dofs and the number of measured (lowest) modes.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    measured_dofs : tuple of str
        Measured dofs, ``"node:dir"`` labels (canonical when built by :func:`define_study`).
    n_modes : int
        Number of measured modes: the lowest ``n_modes`` of the truth.
    """

    measured_dofs: tuple[str, ...]
    n_modes: int

    @property
    def n_measured(self) -> int:
        return len(self.measured_dofs)


def parse_measured_dofs(text: str, dofs: Sequence[str] | None = None) -> list[tuple[str, ...]]:
    """Dof sets separated by ``;``: ``"1:x,2:x;1:x"`` -> ``[("1:x", "2:x"), ("1:x",)]``.

    Parameters
    ----------
    text : str
        Sets separated by ``;``, dofs within a set by ``,`` (the ``--measured-dofs`` option): labels,
        or ``#N`` for the N-th entry of ``dofs``.
    dofs : sequence of str, optional
        The model's dof list that ``#N`` counts in (without it, ``#N`` is refused).

    Returns
    -------
    list of tuple of str
        Canonical ``"node:dir"`` labels per set.

    Raises
    ------
    InputError
        An empty set, an invalid dof label, an index out of range or malformed, or a dof given
        twice in one set.
    """
    sets = []
    for k, part in enumerate(str(text).split(";"), start=1):
        labels = [d.strip() for d in part.split(",") if d.strip()]
        if not labels:
            raise InputError(f"--measured-dofs: set {k} of {text!r} is empty")
        what = f"--measured-dofs set {k}"
        try:
            sets.append(resolve_all(labels, dofs, what))
        except InputError as exc:
            msg = str(exc)
            raise InputError(msg if msg.startswith(what) else f"{what}: {msg}") from None
    return sets


def parse_modes(text: str) -> list[int]:
    """Mode counts ``"1,2,3"`` or ``"1-6"`` (or a mix, ``"1-3,6"``), sorted and distinct.

    Parameters
    ----------
    text : str
        Comma-separated positive integers or ranges ``low-high`` (the ``--modes`` option).

    Returns
    -------
    list of int

    Raises
    ------
    InputError
        An item that is not a number or range, a count below 1, a range with ``high < low``, or no
        count at all.
    """
    out: set[int] = set()
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            continue
        lo, dash, hi = item.partition("-")
        try:
            a = int(lo)
            b = int(hi) if dash else a
        except ValueError:
            raise InputError(f"--modes: {item!r} is not a number or a range such as 1-6") from None
        if a < 1 or b < a:
            raise InputError(f"--modes: {item!r} must be positive, ranges low-high")
        out.update(range(a, b + 1))
    if not out:
        raise InputError(f"--modes: no mode counts in {text!r}")
    return sorted(out)


def nested_dof_sets(model, n_max: int | None = None) -> list[tuple[str, ...]]:
    """The paper's 6-dof simulation plans: the first n model dofs, n = 1 .. n_max.

    Parameters
    ----------
    model : Model
        The model (its dof order).
    n_max : int, optional
        Largest set (default, and at most, the number of model dofs N).

    Returns
    -------
    list of tuple of str
        ``model.dofs[:1]``, ``model.dofs[:2]``, ..., ``model.dofs[:n_max]``.
    """
    N = model.n_dofs if n_max is None else min(int(n_max), model.n_dofs)
    return [tuple(model.dofs[:n]) for n in range(1, N + 1)]


@dataclass(frozen=True, eq=False)
class Study:
    """A uniqueness study, fully determined (built and checked by :func:`define_study`).

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    model : Model
        The model.
    names : tuple of str
        The unknown parameters (L of them).
    truth : ndarray, shape ``(n_parameters,)``
        Full parameter vector the test data are simulated from (the model's values, or ``values``).
    cases : tuple of Case
        The measurement plans.
    starts : ndarray, shape ``(R, L)``
        The random starts (physical values of ``names``), shared by every case and noise level.
    seed : int
        Seed of the starts and of the noise.
    noise : tuple of float, default ``()``
        Relative noise levels besides the noise-free study.
    min_mac : float, default 0.5
        Smallest MAC of a mode pair.
    max_nfev : int, default 200
        Most residual evaluations per start.
    tol : float, default 1e-10
        ``ftol = xtol = gtol`` of the least-squares solver (:func:`femupdate.update`'s defaults).
    unit_rows : int, default ``DEFAULT_UNIT_ROWS``
        Rows (case x level x start) per work unit.
    """

    model: Model
    names: tuple[str, ...]
    truth: np.ndarray  #: full parameter vector (the model's values, or ``values``)
    cases: tuple[Case, ...]
    starts: np.ndarray  #: (R, L) the random starts, shared by every case and noise level
    seed: int
    noise: tuple[float, ...] = ()
    min_mac: float = 0.5
    max_nfev: int = 200
    tol: float = 1e-10  #: ftol = xtol = gtol of the least-squares solver (update()'s defaults)
    unit_rows: int = DEFAULT_UNIT_ROWS

    @property
    def n_starts(self) -> int:
        return self.starts.shape[0]

    @property
    def levels(self) -> tuple[float, ...]:
        """Noise levels with 0 (the noise-free study) first."""
        return (0.0,) + tuple(self.noise)

    @property
    def n_rows(self) -> int:
        return len(self.cases) * len(self.levels) * self.n_starts

    def key(self) -> str:
        """SHA-256 of everything that determines the raw results (the checkpoint's identity)."""
        h = hashlib.sha256(ALGORITHM.encode())
        m = self.model

        def arr(a):
            a = np.ascontiguousarray(a)
            h.update(str((a.dtype.str, a.shape)).encode())
            h.update(a.tobytes())

        def mat(A):
            if A is None:
                h.update(b"none")
                return
            A = A.tocsr()
            A.sort_indices()
            for part in (A.data, A.indices.astype(np.int64), A.indptr.astype(np.int64)):
                arr(part)

        h.update(repr((m.dofs, m.parameter_names, [p.bounds for p in m.parameters])).encode())
        for A in (m.K0, m.M0, *m.dK, *m.dM):
            mat(A)
        arr(np.asarray(self.truth, float))
        arr(np.asarray(self.starts, float))
        h.update(repr((self.names, [(c.measured_dofs, c.n_modes) for c in self.cases], self.seed,
                       [float(v) for v in self.noise], float(self.min_mac), int(self.max_nfev), float(self.tol),
                       int(self.unit_rows))).encode())
        return h.hexdigest()

    def describe(self) -> dict:
        return {"model": self.model.name, "parameters": list(self.names), "cases": len(self.cases),
                "starts": self.n_starts, "seed": self.seed, "noise": list(self.noise), "rows": self.n_rows,
                "units": len(self.units())}

    # -------------------------------------------------------------- the split into work units
    def pieces(self) -> list[tuple[int, int, int, int]]:
        """(case, level, first start, end start) of every piece, in the fixed order of the study."""
        R, step = self.n_starts, max(1, int(self.unit_rows))
        return [(c, lv, a, min(a + step, R)) for c in range(len(self.cases)) for lv in range(len(self.levels))
                for a in range(0, R, step)]

    def units(self) -> list[list[tuple[int, int, int, int]]]:
        """Pieces packed in order into units of at most ``unit_rows`` rows."""
        out: list[list] = []
        rows = 0
        for p in self.pieces():
            n = p[3] - p[2]
            if not out or rows + n > self.unit_rows:
                out.append([])
                rows = 0
            out[-1].append(p)
            rows += n
        return out


def _door(model, cases, starts, seed, values, params, noise, min_mac, max_nfev, tol, unit_rows, log_uniform) -> None:
    """:func:`define_study`'s arguments by type (:mod:`femupdate._checks`), and its rows (cases x
    noise levels x starts) against the available memory."""
    where = "define_study"
    model_arg(model, "model", where)
    if not isinstance(cases, Sequence) or isinstance(cases, (str, bytes)):
        raise TypeError(f"{where}: cases must be a list of Case or (measured dofs, number of modes) pairs, got "
                        f"{shown(cases)}")
    for k, case in enumerate(cases):
        if not isinstance(case, Case) and not (isinstance(case, (Sequence, np.ndarray)) and len(case) == 2
                                               and not isinstance(case, str)):
            raise TypeError(f"{where}: cases[{k}] must be a Case or a (measured dofs, number of modes) pair, got "
                            f"{shown(case)}")
        if not isinstance(case, Case):
            strings_arg(case[0], f"cases[{k}] measured dofs", where, optional=False, what="dof label")
            count_arg(case[1], f"cases[{k}] number of modes", where)
    count_arg(starts, "starts", where, low=None)  # the values: below, as the study has always said them
    count_arg(seed, "seed", where, low=None)
    values_arg(model, values, "values", where)
    params_arg(params, "params", where)
    if isinstance(noise, (str, bytes)) or not isinstance(noise, (Sequence, np.ndarray)):
        raise TypeError(f"{where}: noise must be a list of relative noise levels, got {shown(noise)}")
    for v in noise:
        real_arg(v, "noise", where, low=0.0, low_open=True)
    real_arg(min_mac, "min_mac", where, low=0.0, high=1.0)
    count_arg(max_nfev, "max_nfev", where, low=None)
    real_arg(tol, "tol", where)
    count_arg(unit_rows, "unit_rows", where, low=None)
    flag_arg(log_uniform, "log_uniform", where)
    rows = len(cases) * max(starts, 0) * (1 + len(noise))
    check_memory(f"starts={starts} ({len(cases)} cases x {1 + len(noise)} noise levels: {rows} updates)",
                 float(rows) * STUDY_ROW_BYTES, f"the study's rows ({STUDY_ROW_BYTES} bytes each)")


def define_study(model, cases: Sequence, *, starts: int = 100, seed: int = 0, values=None,
                 params: Sequence[str] | None = None, noise: Sequence[float] = (), min_mac: float = 0.5,
                 max_nfev: int = 200, tol: float = 1e-10, unit_rows: int = DEFAULT_UNIT_ROWS,
                 log_uniform: bool = False) -> Study:
    """Check and fix a study: the cases, the truth and the random starts.

    Parameters
    ----------
    model : Model
        Small: at most :data:`femupdate.modal.DENSE_LIMIT` dofs, solved densely.
    cases : sequence of Case or of (sequence of str, int)
        :class:`Case` objects or ``(measured_dofs, n_modes)`` pairs.
    starts : int, default 100
        Number R of random starts within the bounds, drawn once by
        :func:`femupdate.updating.draw_starts`.
    seed : int, default 0
        Seed of the starts (a non-negative integer).
    values : None, mapping of str to float, or array_like, optional
        The truth (default: the model's values); within the bounds.
    params : sequence of str, optional
        The unknown parameters (default: every parameter not fixed).
    noise : sequence of float, default ()
        Relative noise levels (> 0): eigenvalues × (1 + σε), unit-length shapes + σε.
    min_mac : float, default 0.5
        Solver option, as :func:`femupdate.updating.update`; in [0, 1].
    max_nfev : int, default 200
        Solver option, as :func:`femupdate.updating.update`; at least 1.
    tol : float, default 1e-10
        Solver tolerance, as :func:`femupdate.updating.update`; positive.
    unit_rows : int, default ``DEFAULT_UNIT_ROWS``
        Rows (case × level × start) per work unit.
    log_uniform : bool, default False
        Draw the starts log-uniformly (needs positive lower bounds) instead of uniformly.

    Returns
    -------
    Study

    Raises
    ------
    InputError
        No unknown parameter or an unknown name; a model the batched solver does not support; a
        true value outside its bounds; ``starts``, ``seed``, ``unit_rows``, ``max_nfev``, ``tol``,
        ``min_mac`` or a noise level out of range; no cases, a case listed twice, a case with no or
        unknown dofs, or with more modes than dofs or with rigid-body modes; bounds that are not
        finite (or not positive for ``log_uniform``).
    """
    from ...updating.batched import unsupported
    from ...modal import model_modes
    from ...updating import draw_starts

    _door(model, cases, starts, seed, values, params, noise, min_mac, max_nfev, tol, unit_rows, log_uniform)
    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    model.parameter_indices(names, "unknown parameters (--params)")
    if not names:
        raise InputError("uniqueness study: no unknown parameters (every parameter is fixed)")
    idx = [model.parameter_index(n) for n in names]
    reason = unsupported(model, {}, explicit=True)
    if reason:
        raise InputError(f"uniqueness study: {reason}")
    truth = model.resolve(values)
    lo, hi = model.bounds
    outside = [n for n, j in zip(names, idx) if not lo[j] <= truth[j] <= hi[j]]
    if outside:
        raise InputError(f"uniqueness study: the true value(s) lie outside the bounds for: {', '.join(outside)}")
    if int(starts) < 1:
        raise InputError("uniqueness study: the number of starts must be at least 1")
    if seed is None or int(seed) != seed or seed < 0:
        raise InputError(f"uniqueness study: the seed must be a non-negative integer, got {seed!r}")
    if int(unit_rows) < 1:
        raise InputError("uniqueness study: unit_rows must be at least 1")
    if int(max_nfev) < 1 or not tol > 0 or not 0 <= min_mac <= 1:
        raise InputError("uniqueness study: max_nfev >= 1, tol > 0 and 0 <= min_mac <= 1 are required")
    levels = tuple(float(v) for v in noise)
    bad = [v for v in levels if not (math.isfinite(v) and v > 0)]
    if bad:
        raise InputError(f"uniqueness study: noise levels must be positive numbers, got {bad}")
    if not cases:
        raise InputError("uniqueness study: no cases (give measured dof sets and numbers of modes)")
    mm = model_modes(model, truth)
    out = []
    for k, cs in enumerate(cases, start=1):
        dofs, m = (cs.measured_dofs, cs.n_modes) if isinstance(cs, Case) else cs
        dofs = canonical_all(dofs, f"case {k} measured dofs")
        if not dofs:
            raise InputError(f"case {k}: no measured dofs")
        model.dof_index(dofs, f"case {k} measured dofs")
        m = int(m)
        if not 1 <= m <= model.n_dofs:
            raise InputError(f"case {k}: {m} modes asked for, the model has {model.n_dofs} dofs")
        if np.any(mm.eigenvalues[:m] <= 0):
            raise InputError(f"case {k}: the lowest {m} modes include rigid-body modes, which cannot be updating targets")
        out.append(Case(dofs, m))
    if len(set(out)) != len(out):
        raise InputError("uniqueness study: a case is listed twice")
    X0 = draw_starts(model, names, int(starts), int(seed), log_uniform)
    return Study(model, names, truth, tuple(out), X0, int(seed), levels, float(min_mac), int(max_nfev), float(tol),
                 int(unit_rows))


__all__ = ["ALGORITHM", "DEFAULT_UNIT_ROWS", "Case", "Study", "define_study", "nested_dof_sets", "parse_measured_dofs",
           "parse_modes"]
