r"""Monte Carlo uniqueness studies (the paper's 6-dof simulation, for any small model).

For every case — a set of measured dofs and a number of measured (lowest) modes — the model at
its parameter values (the truth) gives noise-free test data; :func:`femupdate.updating.update`'s
problem is then solved from R random starts drawn uniformly within the parameters' bounds (one
seeded draw, the same starts for every case).  The converged solutions are clustered: one
distinct solution, the truth, is a **unique** case; several are **non-unique**; none is **not
converging**.  Each case also carries the counting criteria (:mod:`.criteria`) and the
condition number of the normalised sensitivity matrix :math:`\partial r/\partial(p/p_{true})` at
the truth.  Optional noise levels re-solve every case from the same starts with noisy data (one
noise realisation per start), showing how conditioning turns into scatter.

How it runs.  All rows (case × noise level × start) of a study are split, in a fixed order, into
work units of at most ``unit_rows`` rows; each unit is solved as ONE batch
(:func:`.problem.study_problem`: all its cases together, every row run to the end in compiled
code, the rows spread over the process's CPU cores).  A unit's result is a pure function of (study, unit number), so units run
in process by default or as tasks of a Dask cluster (``scheduler`` address, or ``workers`` for a
local cluster) with identical results; a task lost with its worker is simply recomputed.  With a
checkpoint path every finished unit is written to disk (:mod:`.checkpoint`) and a re-run of the
same study skips it.

A start **converges** when the solver reports success with a cost ½‖r‖² at most ``cost_tol``
(the data are reproduced); success with a larger cost is a **local minimum**; running out of
evaluations is **not converged**; an evaluation failure (a test mode that pairs with no model
mode, repeated or rigid modes, K indefinite) is **failed**.  With a single sensor the measured
shapes carry no information (a one-entry shape scaled to unit length is ±1), so those cases use
the frequencies only, as :func:`~femupdate.updating.update` does.  Cases with fewer independent
data than parameters (mn < L) are solved too — their converged starts spread over a continuum
of solutions, which the clustering shows.

"Unique" means that every converged start reached the truth: it is the verdict of R samples, as
in the paper's simulation, not a proof — another solution with a small basin of attraction can
be missed (a two-dof chain with an unknown mass has a second solution in a corner of the box
that 20 starts miss).  For small models, :func:`femupdate.uniqueness.exact.exact_solutions`
gives the complete set from the frequencies.
"""

from __future__ import annotations

import hashlib
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from .._errors import FemupdateError, InputError
from ..updating.batched import FAILED
from ..dofs import canonical_all
from ..model import Model
from ..updating.clustering import cluster
from ..updating.starts import connect
from ..updating.results import Solution as _MultiStartSolution
from .checkpoint import Checkpoint
from .criteria import counting_criteria

log = logging.getLogger(__name__)

ALGORITHM = "femupdate-uniqueness-1"  # part of the study key: bump when raw results change meaning
DEFAULT_UNIT_ROWS = 4096


# ====================================================================== definition
@dataclass(frozen=True)
class Case:
    """One measurement plan: the measured dofs and the number of measured (lowest) modes."""

    measured_dofs: tuple[str, ...]
    n_modes: int

    @property
    def n_measured(self) -> int:
        return len(self.measured_dofs)


def parse_measured_dofs(text: str) -> list[tuple[str, ...]]:
    """``"1:x,2:x;1:x"`` -> [("1:x", "2:x"), ("1:x",)]: dof sets separated by ``;``."""
    sets = []
    for k, part in enumerate(str(text).split(";"), start=1):
        labels = [d.strip() for d in part.split(",") if d.strip()]
        if not labels:
            raise InputError(f"--measured-dofs: set {k} of {text!r} is empty")
        sets.append(canonical_all(labels, f"--measured-dofs set {k}"))
    return sets


def parse_modes(text: str) -> list[int]:
    """``"1,2,3"`` or ``"1-6"`` (or a mix, ``"1-3,6"``) -> sorted distinct mode counts."""
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
    """The paper's 6-dof simulation plans: the first n model dofs, n = 1 .. n_max (default N)."""
    N = model.n_dofs if n_max is None else min(int(n_max), model.n_dofs)
    return [tuple(model.dofs[:n]) for n in range(1, N + 1)]


@dataclass(frozen=True, eq=False)
class Study:
    """A uniqueness study, fully determined (see :func:`define_study`)."""

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


def define_study(model, cases: Sequence, *, starts: int = 100, seed: int = 0, values=None,
                 params: Sequence[str] | None = None, noise: Sequence[float] = (), min_mac: float = 0.5,
                 max_nfev: int = 200, tol: float = 1e-10, unit_rows: int = DEFAULT_UNIT_ROWS,
                 log_uniform: bool = False) -> Study:
    """Check and fix a study: the cases, the truth and the random starts.

    Parameters
    ----------
    model : Model (small: at most :data:`femupdate.modal.DENSE_LIMIT` dofs, solved densely).
    cases : :class:`Case` objects or ``(measured_dofs, n_modes)`` pairs.
    starts, seed : R random starts within the bounds, drawn once by
        :func:`femupdate.updating.draw_starts` (uniform, or log-uniform).
    values : the truth, as {name: value} (default: the model's values).
    params : the unknown parameters (default: every parameter not fixed).
    noise : relative noise levels (> 0): eigenvalues × (1 + σε), unit-length shapes + σε.
    min_mac, max_nfev, tol : solver options, as :func:`femupdate.updating.update`.
    unit_rows : rows (case × level × start) per work unit.
    """
    from ..updating.batched import unsupported
    from ..modal import model_modes
    from ..updating import draw_starts

    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
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


# ====================================================================== data of a case
def _unit(shape):
    """Unit length, sign of the largest entry positive (``scaled_shape(..., "unit")``)."""
    k = np.argmax(np.abs(shape), axis=0)
    s = np.sign(shape[k, np.arange(shape.shape[1])]) * np.linalg.norm(shape, axis=0)
    return shape / s


def case_data(study: Study, c: int, level: int = 0, starts=slice(None), modes=None):
    """Test data of case ``c`` for the starts ``starts`` at noise level ``level``.

    Returns ``lam`` (R', m) eigenvalues and ``psi`` (R', n, m) unit-length shapes at the case's
    measured dofs (identical rows when noise-free).  ``modes``: the truth's modes, if at hand.
    """
    from ..modal import model_modes

    case = study.cases[c]
    mm = modes if modes is not None else model_modes(study.model, study.truth)
    pos = study.model.dof_index(case.measured_dofs)
    m, n = case.n_modes, case.n_measured
    lam0 = mm.eigenvalues[:m]
    psi0 = _unit(mm.shapes[pos][:, :m])
    idx = np.arange(study.n_starts)[starts]
    if level == 0:
        return np.tile(lam0, (idx.size, 1)), np.tile(psi0, (idx.size, 1, 1))
    sigma = study.levels[level]
    eps = np.random.default_rng([study.seed, c, level]).standard_normal((study.n_starts, m * (1 + n)))[idx]
    lam = lam0 * (1.0 + sigma * eps[:, :m])
    psi = psi0[None] + sigma * eps[:, m:].reshape(idx.size, n, m)
    k = np.argmax(np.abs(psi), axis=1)
    s = np.sign(np.take_along_axis(psi, k[:, None, :], axis=1)) * np.linalg.norm(psi, axis=1, keepdims=True)
    return lam, psi / s


def case_testdata(study: Study, c: int, level: int = 0, start: int = 0, modes=None):
    """The :class:`~femupdate.testdata.TestData` of case ``c`` as seen by start ``start``
    (``modes``: the truth's modes, if at hand)."""
    from ..testdata import MeasuredMode, TestData

    lam, psi = case_data(study, c, level, slice(start, start + 1), modes)
    dofs = study.cases[c].measured_dofs
    return TestData(modes=tuple(MeasuredMode(float(lam[0, k]), dofs, psi[0, :, k]) for k in range(lam.shape[1])))


def _row_data(study: Study, pieces):
    """RowData and starts (B, L) of the rows of ``pieces``."""
    from ..modal import model_modes
    from .problem import RowData

    model = study.model
    modes = model_modes(model, study.truth)
    sensors = np.unique(np.concatenate([model.dof_index(study.cases[c].measured_dofs) for c, *_ in pieces]))
    u = sensors.size
    T = max(study.cases[c].n_modes for c, *_ in pieces)
    B = sum(b - a for _, _, a, b in pieces)
    lam_e = np.ones((B, T))
    psi_e = np.zeros((B, u, T))
    smask = np.zeros((B, u), bool)
    n_test = np.zeros(B, np.intp)
    X0 = np.zeros((B, len(study.names)))
    r = 0
    for c, lv, a, b in pieces:
        case = study.cases[c]
        k = b - a
        lam, psi = case_data(study, c, lv, slice(a, b), modes)
        at = np.searchsorted(sensors, model.dof_index(case.measured_dofs))
        lam_e[r:r + k, :case.n_modes] = lam
        if case.n_measured >= 2:
            psi_e[r:r + k, at, :case.n_modes] = psi
            smask[r:r + k, at] = True
        n_test[r:r + k] = case.n_modes
        X0[r:r + k] = study.starts[a:b]
        r += k
    return RowData(lam_e, psi_e, smask, n_test, sensors), X0


def solve_unit(study: Study, unit: int, progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Solve work unit ``unit`` of ``study`` as one batch: a pure function of its arguments.

    Returns one dict per piece: ``case``, ``level``, ``start`` (first start), and per start
    ``x`` (final values of the unknowns), ``cost``, ``status`` (SciPy's codes, or -3 failed),
    ``nfev``, and ``messages`` {start: message} of the failed ones.
    """
    from .problem import study_problem

    pieces = study.units()[unit]
    rows, X0 = _row_data(study, pieces)
    prob = study_problem(study.model, study.names, rows, X0, values=study.truth, min_mac=study.min_mac,
                         max_nfev=study.max_nfev, ftol=study.tol, xtol=study.tol, gtol=study.tol)
    res = prob.solve(progress=progress, history=False)
    X = prob.to_p(res.x, np.arange(X0.shape[0]))
    out, r = [], 0
    for c, lv, a, b in pieces:
        sl = slice(r, r + b - a)
        failed = {str(a + k): res.message[r + k] for k in range(b - a) if res.status[r + k] == FAILED}
        out.append({"case": c, "level": lv, "start": a, "x": X[sl].tolist(), "cost": res.cost[sl].tolist(),
                    "status": res.status[sl].tolist(), "nfev": res.nfev[sl].tolist(), "messages": failed})
        r += b - a
    return out


def reference_unit(study: Study, c: int, level: int = 0, starts: Sequence[int] | None = None) -> dict:
    """The per-start route: one :func:`femupdate.updating.update` (SciPy least squares, exact
    Nelson Jacobian) per start of case ``c``, in the raw format of :func:`solve_unit`.

    A case with fewer independent data than unknowns is solved with ``regularization=0`` (the
    same unregularised problem; ``update`` otherwise refuses it as underdetermined).
    """
    from ..modal import model_modes
    from ..updating import update

    idx = list(range(study.n_starts)) if starts is None else [int(k) for k in starts]
    case = study.cases[c]
    L = len(study.names)
    n_data = case.n_modes * (case.n_measured if case.n_measured >= 2 else 1)
    out: dict[str, Any] = {"case": c, "level": level, "start": idx[0] if idx else 0, "x": [], "cost": [], "status": [],
                           "nfev": [], "messages": {}, "starts": idx}
    truth_modes = model_modes(study.model, study.truth)  # the data of every start derive from them
    for k in idx:
        data = case_testdata(study, c, level, k, truth_modes)
        try:
            res = update(study.model, data, params=list(study.names), x0=dict(zip(study.names, study.starts[k])),
                         values=study.truth, min_mac=study.min_mac, max_nfev=study.max_nfev, ftol=study.tol,
                         xtol=study.tol, gtol=study.tol, regularization=0.0 if n_data < L else None)
            out["x"].append(list(map(float, res.x)))
            out["cost"].append(float(res.cost))
            out["status"].append(int(res.status))
            out["nfev"].append(int(res.nfev))
        except FemupdateError as exc:
            out["x"].append([math.nan] * L)
            out["cost"].append(math.nan)
            out["status"].append(FAILED)
            out["nfev"].append(0)
            out["messages"][str(k)] = f"{type(exc).__name__}: {exc}"
    return out


# ====================================================================== results
@dataclass(frozen=True, eq=False)
class Solution(_MultiStartSolution):
    """A distinct solution of a case (:class:`femupdate.updating.Solution`: the representative's
    values, its cost, how many starts and which) and its distance from the truth."""

    max_rel_error: float = math.nan  #: largest |p / p_true − 1| over the unknowns
    is_truth: bool = False


@dataclass(frozen=True, eq=False)
class NoiseResult:
    """One noise level of a case: scatter of the converged solutions around the truth."""

    level: float
    starts: int
    converged: int  #: solver success with a cost within twice the noise floor, ½ m σ² (m residuals)
    rms_rel_error: dict[str, float]  #: per unknown, RMS of p / p_true − 1 over the converged starts
    median_max_rel_error: float
    predicted_std: dict[str, float]  #: σ √diag((SᵀS)⁻¹), the linearised scatter (inf if S is singular)


@dataclass(frozen=True, eq=False)
class CaseResult:
    """Outcome of one case (see the module notes for the classification of starts)."""

    case: Case
    criteria: dict
    starts: int
    converged: int
    local_minima: int
    not_converged: int
    failed: int
    solutions: list[Solution]
    condition_number: float
    singular_values: np.ndarray
    rank: int
    n_residuals: int
    noise: list[NoiseResult] = field(default_factory=list)
    failure_examples: list[str] = field(default_factory=list)

    @property
    def truth_found(self) -> bool:
        return any(s.is_truth for s in self.solutions)

    @property
    def unique(self) -> bool | None:
        """True: every converged start reached the truth; False: another solution reproduces the
        data too; None: no start converged."""
        if not self.solutions:
            return None
        return len(self.solutions) == 1 and self.solutions[0].is_truth

    @property
    def verdict(self) -> str:
        return {True: "unique", False: "non-unique", None: "not converging"}[self.unique]

    def to_dict(self, names) -> dict:
        return {
            "measured_dofs": list(self.case.measured_dofs), "n_measured": self.case.n_measured,
            "n_modes": self.case.n_modes,
            "criteria": {k: c.satisfied for k, c in self.criteria.items()},
            "criteria_counts": {k: {"count": c.count, "threshold": c.threshold, "formula": c.formula,
                                    "equation": c.equation} for k, c in self.criteria.items()},
            "starts": self.starts, "converged": self.converged, "local_minima": self.local_minima,
            "not_converged": self.not_converged, "failed": self.failed,
            "solutions": [{"parameters": s.parameters, "count": s.count, "cost": s.cost,
                           "max_rel_error": s.max_rel_error, "is_truth": s.is_truth} for s in self.solutions],
            "unique": self.unique, "verdict": self.verdict, "truth_found": self.truth_found,
            "condition_number": self.condition_number, "singular_values": self.singular_values,
            "rank": self.rank, "n_parameters": len(names), "n_residuals": self.n_residuals,
            "underdetermined": not self.criteria["data_count"].satisfied,
            "noise": [{"level": z.level, "starts": z.starts, "converged": z.converged,
                       "rms_rel_error": z.rms_rel_error, "median_max_rel_error": z.median_max_rel_error,
                       "predicted_std": z.predicted_std} for z in self.noise],
            "failure_examples": self.failure_examples,
        }


@dataclass(frozen=True, eq=False)
class StudyResult:
    """Result of :func:`run_study`: one :class:`CaseResult` per case, in the study's order."""

    study: Study
    cases: list[CaseResult]
    seconds: float
    units_computed: int
    units_resumed: int
    route: str
    rel_tol: float
    cost_tol: float
    raw: list = field(default_factory=list)  #: per-start results of every piece (see :func:`solve_unit`)

    def to_dict(self) -> dict:
        """The JSON result of ``femupdate uniqueness`` (docs/interfaces.md, plus extras)."""
        st = self.study
        return {
            "model": st.model.name, "parameters": list(st.names),
            "truth": dict(zip(st.names, st.truth[[st.model.parameter_index(n) for n in st.names]])),
            "n_dofs": st.model.n_dofs, "starts": st.n_starts, "seed": st.seed, "noise_levels": list(st.noise),
            "rel_tol": self.rel_tol, "cost_tol": self.cost_tol, "max_nfev": st.max_nfev, "min_mac": st.min_mac,
            "route": self.route, "units": {"total": len(st.units()), "computed": self.units_computed,
                                           "resumed": self.units_resumed},
            "seconds": self.seconds, "study_key": st.key(),
            "cases": [c.to_dict(st.names) for c in self.cases],
        }


def truth_sensitivities(study: Study) -> list[tuple[np.ndarray, int]]:
    """Per case the normalised sensitivity matrix S = ∂r/∂(p/p_true) at the truth, noise-free
    (its own rows only), and its number of residuals."""
    from .problem import study_problem

    C = len(study.cases)
    pieces = [(c, 0, 0, 1) for c in range(C)]
    rows, _ = _row_data(study, pieces)
    idx = [study.model.parameter_index(n) for n in study.names]
    X0 = np.tile(study.truth[idx], (C, 1))
    prob = study_problem(study.model, study.names, rows, X0, values=study.truth, min_mac=study.min_mac)
    ev = prob.evaluate(prob.x_start)
    m = prob.n_residuals
    out = []
    for c in range(C):
        if ev.messages[c] is not None:
            raise InputError(f"case {c + 1}: the model cannot be differentiated at the truth: {ev.messages[c]}")
        out.append((ev.jac[c, :m[c]], int(m[c])))
    return out


def conditioning(S: np.ndarray, m: int):
    """Condition number (inf when numerically rank-deficient), singular values and numerical
    rank of a sensitivity matrix S with m residuals."""
    s = np.linalg.svd(S, compute_uv=False) if S.size else np.zeros(0)
    L = S.shape[1]
    rank = int(np.sum(s > max(S.shape) * np.finfo(float).eps * s[0])) if s.size else 0
    # a numerically rank-deficient matrix has no finite condition number: its smallest singular
    # value is round-off, and so would be any figure computed from it
    cond = float(s[0] / s[-1]) if s.size == L and rank == L and m >= L else math.inf
    return cond, s, rank


def summarise(study: Study, raw: Sequence[dict], *, rel_tol: float = 1e-4, cost_tol: float = 1e-12,
              sensitivities=None) -> list[CaseResult]:
    """Case results from raw unit results (any split, any order)."""
    C, R, L = len(study.cases), study.n_starts, len(study.names)
    x = np.full((C, len(study.levels), R, L), np.nan)
    cost = np.full((C, len(study.levels), R), np.nan)
    status = np.full((C, len(study.levels), R), FAILED)
    have = np.zeros((C, len(study.levels), R), bool)
    messages: dict = {}
    for piece in raw:
        c, lv = piece["case"], piece["level"]
        ks = piece.get("starts") or list(range(piece["start"], piece["start"] + len(piece["status"])))
        x[c, lv, ks] = np.array(piece["x"], dtype=float).reshape(len(ks), L)
        cost[c, lv, ks] = np.array(piece["cost"], dtype=float)
        status[c, lv, ks] = np.array(piece["status"], dtype=int)
        have[c, lv, ks] = True
        for k, msg in piece.get("messages", {}).items():
            messages.setdefault((c, lv), []).append(msg)
    idx = [study.model.parameter_index(n) for n in study.names]
    p_true = study.truth[idx]
    scale = np.where(p_true != 0, np.abs(p_true), 1.0)
    sens = sensitivities if sensitivities is not None else truth_sensitivities(study)
    out = []
    for c, case in enumerate(study.cases):
        h = have[c, 0]
        st, cs, xs = status[c, 0][h], cost[c, 0][h], x[c, 0][h]
        ks = np.flatnonzero(h)
        conv = (st > 0) & (cs <= cost_tol)
        sols = []
        if conv.any():
            pts, costs, who = xs[conv], cs[conv], ks[conv]
            for g in cluster(pts, costs, rel_tol):
                rep = pts[g[0]]
                err = float(np.max(np.abs(rep - p_true) / scale))
                sols.append(Solution(dict(zip(study.names, map(float, rep))), float(costs[g[0]]), len(g),
                                     sorted(int(who[i]) for i in g), err, err <= rel_tol))
            sols.sort(key=lambda s: (-s.count, s.cost))
        S, m_own = sens[c]
        cond, sv, rank = conditioning(S, m_own)
        noise = []
        for lv in range(1, len(study.levels)):
            hz = have[c, lv]
            sigma = study.levels[lv]
            # fits the noisy data: success with a cost within twice the expected noise floor ½ m σ²
            ok = hz & (status[c, lv] > 0) & (cost[c, lv] <= cost_tol + m_own * sigma**2)
            rel = (x[c, lv][ok] - p_true) / scale
            if rank == L and m_own >= L:
                pred = sigma * np.sqrt(np.diag(np.linalg.pinv(S.T @ S)))
            else:
                pred = np.full(L, math.inf)
            noise.append(NoiseResult(
                sigma, int(hz.sum()), int(ok.sum()),
                dict(zip(study.names, map(float, np.sqrt(np.mean(rel**2, axis=0)) if ok.any() else [math.nan] * L))),
                float(np.median(np.max(np.abs(rel), axis=1))) if ok.any() else math.nan,
                dict(zip(study.names, map(float, pred)))))
        crit = counting_criteria(case.n_measured, case.n_modes, L, study.model.n_dofs)
        out.append(CaseResult(
            case=case, criteria=crit, starts=int(h.sum()), converged=int(conv.sum()),
            local_minima=int(np.sum((st > 0) & ~(cs <= cost_tol))), not_converged=int(np.sum(st == 0)),
            failed=int(np.sum(st == FAILED)), solutions=sols, condition_number=cond, singular_values=sv, rank=rank,
            n_residuals=m_own, noise=noise, failure_examples=sorted(set(messages.get((c, 0), [])))[:3]))
    return out


# ====================================================================== running
def _dask_client(scheduler: str | None, workers: int | None, timeout: float):
    if scheduler:
        return connect(scheduler, timeout, "--scheduler / --workers"), None
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise InputError("--scheduler / --workers need dask.distributed: pip install 'femupdate[dask]'") from None
    if workers is None:  # run_study starts a local cluster only when workers is given
        raise TypeError("int() argument must be a string, a bytes-like object or a real number, not 'NoneType'")
    cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    return Client(cluster), cluster


def run_study(study: Study, *, scheduler: str | None = None, workers: int | None = None, checkpoint=None,
              progress: Callable[[int, int], None] | None = None, rel_tol: float = 1e-4, cost_tol: float = 1e-12,
              connect_timeout: float = 10.0) -> StudyResult:
    """Run (or resume) ``study`` and summarise it.

    Parameters
    ----------
    scheduler : address of an existing Dask scheduler (``tcp://host:port``): units run there.
    workers : without ``scheduler``, start a local Dask cluster of this many worker processes;
        neither: everything runs in this process.
    checkpoint : path of the checkpoint file (created, or resumed when it holds this study).
    progress : ``progress(rows_done, rows_total)``.
    rel_tol : two solutions are the same when every unknown agrees within this (relative).
    cost_tol : a converged start reproduces the data when its cost ½‖r‖² is at most this.
    connect_timeout : seconds to wait for the scheduler (then an InputError).
    """
    t0 = time.perf_counter()
    units = study.units()
    ck = Checkpoint(checkpoint, study.key(), study.describe())
    resumed = [i for i in range(len(units)) if i in ck]
    todo = [i for i in range(len(units)) if i not in ck]
    size = [sum(b - a for _, _, a, b in u) for u in units]
    done = sum(size[i] for i in resumed)
    total = sum(size)
    if progress:
        progress(done, total)
    route = "local"
    if todo and (scheduler or workers):
        client, cluster = _dask_client(scheduler, workers, connect_timeout)
        route = f"dask:{scheduler}" if scheduler else f"dask:local cluster of {workers} workers"
        try:
            from dask.distributed import as_completed

            # the study travels inside each task (not scattered): a task lost with its worker can
            # always be recomputed, even if every copy of a scattered object were lost with it
            key = study.key()[:16]
            futures = {client.submit(solve_unit, study, i, key=f"femupdate-uniqueness-{key}-unit-{i}", retries=2): i
                       for i in todo}
            for fut in as_completed(list(futures)):
                i = futures[fut]
                ck.add(i, fut.result())
                done += size[i]
                if progress:
                    progress(done, total)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    else:
        for i in todo:
            base = done
            # cast: mypy cannot infer a lambda with a default argument against Callable[[int, int], None]
            unit_progress = (cast("Callable[[int, int], None]", lambda k, _n, b=base: progress(b + k, total))
                             if progress else None)
            ck.add(i, solve_unit(study, i, progress=unit_progress))
            done = base + size[i]
    raw = [p for i in range(len(units)) for p in ck.units[i]]
    cases = summarise(study, raw, rel_tol=rel_tol, cost_tol=cost_tol)
    log.info("uniqueness study: %d cases, %d rows in %d units (%d resumed), %.2f s", len(study.cases), total,
             len(units), len(resumed), time.perf_counter() - t0)
    return StudyResult(study, cases, time.perf_counter() - t0, len(todo), len(resumed), route, rel_tol, cost_tol, raw)


__all__ = [
    "Case", "CaseResult", "NoiseResult", "Solution", "Study", "StudyResult", "case_data", "case_testdata",
    "define_study", "nested_dof_sets", "parse_measured_dofs", "parse_modes", "reference_unit",
    "run_study", "solve_unit", "summarise", "truth_sensitivities", "conditioning",
]
