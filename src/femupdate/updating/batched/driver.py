r"""The batched route: many starts (and data sets) of one small model solved at once, compiled.

:func:`femupdate.updating.multistart` runs :func:`femupdate.update` once per random start.  For
a small model (tens to a few hundred dofs) each run is dominated by Python overhead around tiny
LAPACK calls.  Here every start of a :class:`~femupdate.updating.Problem` — or every row of a
uniqueness study, each with its own data set — is run to the end in compiled code
(:mod:`.kernel`): the problem's own rules (:mod:`femupdate.rules`) on its own
:class:`~femupdate.updating.problem.Targets`, exact Jacobians from all modes of a dense
eigen-solution, and SciPy's trust-region-reflective method transcribed decision for decision
(:mod:`.trf`), so that a start lands where :func:`femupdate.update` lands from it.  Starts run
in parallel over the CPU cores.

A start whose evaluation fails — repeated or rigid-body paired modes, a test mode that pairs
with no model mode, a mass matrix that is not positive definite, non-finite residuals — is marked
failed with the message the local route gives; the rest carry on.  Groups of repeated or close
modes (:mod:`femupdate.updating.groups`) are the local route's: with ``close_modes`` set, a start
that reaches a point where the computed modes hold such a group fails as repeated, and
:func:`~femupdate.updating.batched.starts.batched_runs` solves it again on the local route.

The compiled code is built by numba on first use and cached on disk beside the package (or in
numba's user cache when that is read-only); later processes load it.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from concurrent.futures import ThreadPoolExecutor

from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..._errors import InputError
from ...correlation import check_pairing
from ...modal import DENSE_LIMIT
from ..parametrisation import Parametrisation, start_error, x_bounds, x_of_p
from ..problem import Problem, check_determined
from .lsq import FAILED, BatchLSQResult, prepare, result_of
from .spec import DataSets, ModelArrays, Spec, concatenate, error_message, new_report

from ...options import SolverOptions, UpdateOptions, gather

log = logging.getLogger(__name__)

AUTO_MAX_DOFS = 200  #: models up to this size take the batched route by default
# ====================================================================== options
def unsupported(model, options: UpdateOptions | Mapping | None = None, explicit: bool = False) -> str | None:
    """Why the batched route cannot run this study (None when it can).

    ``options``: the update's (:class:`~femupdate.options.UpdateOptions`, or a mapping of its
    shorthand keywords).  ``explicit``: the caller asked for the batched route, so only hard
    limits apply (dense models up to :data:`femupdate.modal.DENSE_LIMIT` dofs); otherwise the
    automatic choice also requires at most :data:`AUTO_MAX_DOFS` dofs.
    """
    if not isinstance(options, UpdateOptions):
        options = UpdateOptions.of("unsupported", {k: v for k, v in dict(options or {}).items() if k != "values"})
    o = options
    if getattr(model, "terms", ()):
        t = model.terms[0]
        return (f"parameter {t.parameters[0]!r} enters model {model.name!r} through {t.describe()}: the batched route "
                "assumes the parameters enter linearly (K = K0 + sum p_j K_j)")
    if o.frf.changed():
        return f"FRF option(s) {', '.join(o.frf.changed())} are not implemented by the batched route"
    if o.solver.method != "trf":
        return f"method={o.solver.method!r}: the batched route implements trf only"
    if o.solver.regularization is not None:
        return "regularization: the batched route solves the unregularised problem only"
    if o.modal.sensitivity != "auto":
        return f"sensitivity={o.modal.sensitivity!r}: the batched route uses exact derivatives (sensitivity='auto')"
    if o.modal.formulation != "shapes":
        return (f"formulation={o.modal.formulation!r}: the batched route implements the 'shapes' formulation only "
                "(the other formulations run one start at a time)")
    limit = DENSE_LIMIT if explicit else AUTO_MAX_DOFS
    if model.n_dofs > limit:
        return f"the model has {model.n_dofs} dofs; the batched (dense) route takes at most {limit}"
    from ...modal import massless_dofs

    if massless_dofs(model.M(model.values)).any():
        return "the model has massless dofs (the batched route needs a positive definite mass matrix)"
    return None


def supports(model, options: UpdateOptions | Mapping | None = None) -> bool:
    """True when :func:`femupdate.updating.multistart` should take the batched route by itself."""
    return unsupported(model, options) is None


# ====================================================================== results
# ====================================================================== the batched problem
@dataclass(eq=False)
class Evaluation:
    """:meth:`BatchedProblem.evaluate` at S points."""

    fun: np.ndarray  #: (S, m)
    jac: np.ndarray  #: (S, m, L)
    eigenvalues: np.ndarray  #: (S, n) all eigenvalues, ascending
    pairs: np.ndarray  #: (S, T) model mode of each test mode
    macs: np.ndarray  #: (S, T) MAC of each pair (NaN without shape)
    messages: list  #: (S,) None or the failure



class BatchedProblem:
    """One small model, R starts, each row with its data set: the input of the compiled route.

    Parameters
    ----------
    model : Model
    names : the updated parameters.
    starts : (R, L) starting values of ``names`` (physical units).
    data : the data sets, a list of :class:`~femupdate.updating.problem.Targets` or the
        ``(DataSets, Targets)`` pair of :func:`.spec.concatenate`.
    row_dataset : (R,) the data set of each row (default: all the first).
    values : values of the parameters that are not updated (default nominal).
    shape_scaling, min_mac, pairing : the problem's rules, as
        :class:`~femupdate.updating.Problem` holds them.
    close_modes : the relative gap of a group of close modes: a row whose accepted point has one
        among its computed modes fails as repeated (0, the default: only modes repeated to
        :data:`femupdate.rules.REPEATED_TOL` and paired fail).
    solver : :class:`~femupdate.options.SolverOptions`, optional
        The parametrisation and the limits ``max_nfev``, ``ftol``, ``xtol``, ``gtol``; its fields
        are also accepted as keywords (``parametrisation="log"``).  The compiled route is the
        ``"trf"`` method without regularization.

    :meth:`from_problem` builds it for the starts of a :class:`~femupdate.updating.Problem`.

    Attributes
    ----------
    x_start, lb, ub : (R, L) starting points and bounds in the solver's variables.
    start_errors : (R,) None, or why the local route would refuse that start.
    """

    def __init__(self, model, names: Sequence[str], starts, data, row_dataset=None, *, values=None,
                 shape_scaling: str = "unit", min_mac: float = 0.5, pairing: str = "auto", close_modes: float = 0.0,
                 solver: SolverOptions | None = None, **shorthand):
        from ...coefficients import route_refusal
        route_refusal(model, 'the compiled batched route')
        solver = gather("BatchedProblem", shorthand, solver=(SolverOptions, solver))["solver"]
        if solver.method != "trf" or solver.regularization is not None:
            raise InputError(f"batched updating: the compiled route runs the 'trf' solver without regularization, "
                             f"got method={solver.method!r}, regularization={solver.regularization!r}")
        parametrisation = solver.parametrisation
        names = list(names)
        if not names:
            raise InputError("no parameters to update: every parameter is fixed")
        starts = np.array(starts, dtype=float, ndmin=2)
        if starts.shape[1] != len(names):
            raise InputError(f"starts has shape {starts.shape}, expected (R, {len(names)}) for {', '.join(names)}")
        if model.n_dofs > DENSE_LIMIT:
            raise InputError(f"batched updating: the model has {model.n_dofs} dofs; the batched (dense) route "
                             f"takes at most {DENSE_LIMIT}")
        R = starts.shape[0]
        self.model = model
        self.names = tuple(names)
        self.R = R
        self.starts = starts
        self.options = dict(max_nfev=solver.max_nfev, ftol=solver.ftol, xtol=solver.xtol, gtol=solver.gtol)
        self.p_fixed = model.resolve(values)
        self.param = parametrisation
        self.scaling = shape_scaling
        self.min_mac = check_pairing(pairing, min_mac)
        self.pairing = pairing
        self.close_modes = float(close_modes)
        # per start: the parametrisation of the local route from that start
        self.idx = Parametrisation(model, names, parametrisation, self.p_fixed).idx
        self.scale = np.where(starts != 0, np.abs(starts), 1.0)
        lo, hi = model.bounds
        lo, hi = lo[self.idx], hi[self.idx]
        if parametrisation == "log" and np.any(lo < 0):
            raise InputError("log parametrisation needs positive starting values and non-negative lower bounds")
        self.start_errors = [None if (e := start_error(names, starts[r], lo, hi, parametrisation)) is None
                             else f"InputError: {e}" for r in range(R)]
        # (a refused start keeps a harmless placeholder; it fails at its first evaluation)
        self.x_start = x_of_p(parametrisation, np.where(starts > 0, starts, 1.0) if parametrisation == "log"
                              else starts, self.scale)
        xl, xh = x_bounds(parametrisation, np.broadcast_to(lo, starts.shape), np.broadcast_to(hi, starts.shape),
                          self.scale)
        self.lb, self.ub = np.array(xl, float), np.array(xh, float)
        if isinstance(data, tuple) and len(data) == 2 and isinstance(data[0], DataSets):
            self.sets, self.targets = data
        else:
            self.sets, self.targets = concatenate(list(data), np.zeros(R, np.int64) if row_dataset is None
                                                  else row_dataset)
        self._model_setup()

    @classmethod
    def from_problem(cls, problem: Problem, starts, **solver_options) -> BatchedProblem:
        """The starts ``starts`` (R, L) of ``problem``: each row is the problem that
        :func:`femupdate.update` solves from that start (the ``"shapes"`` formulation only)."""
        if problem.formulation != "shapes":
            raise InputError(f"batched updating: formulation={problem.formulation!r}: the batched route implements the "
                             "'shapes' formulation only")
        check_determined(problem)
        p_fixed = problem.p_base.copy()
        return cls(problem.model, problem.names, starts, [problem.targets], values=p_fixed,
                   parametrisation=problem.param, shape_scaling=problem.scaling,
                   min_mac=problem.min_mac, pairing=problem.pairing, close_modes=problem.close_modes,
                   **solver_options)

    def to_p(self, X, rows) -> np.ndarray:
        """Updated parameters' values (S, L) at solver variables X (S, L) of the starts ``rows``."""
        from ... import rules

        code = rules.PARAMETRISATIONS[self.param]
        X = np.atleast_2d(np.asarray(X, float))
        rows = np.asarray(rows)
        with np.errstate(over="ignore"):
            return np.array([rules.to_p(code, X[i], self.scale[rows[i]]) for i in range(X.shape[0])]).reshape(X.shape)

    def full_p(self, X, rows) -> np.ndarray:
        """Full parameter vectors (S, n_parameters)."""
        P = np.broadcast_to(self.p_fixed, (len(rows), self.p_fixed.size)).copy()
        P[:, self.idx] = self.to_p(X, rows)
        return P

    # ------------------------------------------------------------------ the model's arrays
    def _model_setup(self) -> None:
        model, n = self.model, self.model.n_dofs
        self.n = n
        fixed = np.setdiff1d(np.arange(len(model.parameters)), self.idx)
        zero = sp.csr_array((n, n))

        def const(base, derivs):
            c = base.toarray()
            for j in fixed:
                if derivs[j] is not None:
                    c = c + self.p_fixed[j] * derivs[j].toarray()
            return c

        self.K_const = const(model.K0, model.dK)
        self.M_const = const(model.M0, model.dM)
        self.dK = [model.dK[j] if model.dK[j] is not None else zero for j in self.idx]
        self.dM = [model.dM[j] if model.dM[j] is not None else zero for j in self.idx]
        self.M_varies = any(d.nnz for d in self.dM)
        self._spec = None
        self.mass_error: str | None = None
        self.Cinv = np.eye(n)
        if not self.M_varies:
            if np.any(~(np.diag(self.M_const) > 0)):
                self.mass_error = "InputError: the mass matrix is not positive definite (a dof has no mass)"
            else:
                try:
                    self.Cinv = np.linalg.inv(np.linalg.cholesky(self.M_const))
                except np.linalg.LinAlgError:
                    self.mass_error = ("NumericalError: the least-squares solver failed: the mass matrix is not "
                                       "positive definite (its Cholesky factorisation failed)")

    def spec(self):
        """The :data:`~.spec.Spec` of this batch (compiles nothing; built once, then kept)."""
        if self._spec is None:
            self._spec = self._build_spec()
        return self._spec

    def _build_spec(self):
        from ... import rules

        def coo(mats):
            ptr, ri, ci, vv = [0], [], [], []
            for d in mats:
                c = sp.coo_array(d)
                ri.append(c.row)
                ci.append(c.col)
                vv.append(c.data)
                ptr.append(ptr[-1] + c.nnz)
            cat = (lambda a, t: np.concatenate(a).astype(t) if a else np.zeros(0, t))
            return np.array(ptr, np.int64), cat(ri, np.int64), cat(ci, np.int64), cat(vv, float)

        kp, ki, kj, kv = coo(self.dK)
        mp, mi, mj, mv = coo(self.dM)
        supp = [np.union1d(sp.coo_array(a).row, sp.coo_array(b).row) for a, b in zip(self.dK, self.dM)]
        sptr = np.cumsum([0] + [len(s) for s in supp]).astype(np.int64)
        sidx = np.concatenate(supp).astype(np.int64) if supp else np.zeros(0, np.int64)
        arrays = ModelArrays(np.ascontiguousarray(self.K_const), kp, ki, kj, kv, bool(self.M_varies),
                             np.ascontiguousarray(self.M_const), mp, mi, mj, mv, np.ascontiguousarray(self.Cinv),
                             sptr, sidx, rules.PARAMETRISATIONS[self.param], np.ascontiguousarray(self.scale))
        return Spec(arrays, self.sets, self.targets, rules.SCALINGS[self.scaling], float(self.min_mac),
                    rules.PAIRINGS[self.pairing], self.close_modes)

    @property
    def n_residuals(self) -> np.ndarray:
        """(R,) the residual count of each row."""
        return np.asarray(self.sets.m)[np.asarray(self.sets.row_ds)]

    # ------------------------------------------------------------------ compiled evaluation and solution
    def evaluate(self, X, rows=None):
        """The compiled evaluation at solver variables X (S, L) of ``rows``: residuals F (S, m)
        (each row's own first, zeros after), exact Jacobians J (S, m, L), all eigenvalues
        (S, n), the pairs and their MAC (S, T), and the messages (None where fine)."""
        from . import kernel

        X = np.array(X, dtype=float, ndmin=2)
        rows = np.arange(X.shape[0]) if rows is None else np.asarray(rows, dtype=np.int64)
        S, L = X.shape
        m, T = int(self.n_residuals.max(initial=1)), int(np.max(self.sets.T, initial=1))
        out = Evaluation(np.zeros((S, m)), np.zeros((S, m, L)), np.zeros((S, self.n)), np.zeros((S, T), np.int64),
                         np.full((S, T), np.nan), [None] * S)
        if self.mass_error:
            out.messages[:] = [self.mass_error] * S
            return out
        err = new_report(S, T)
        _announce_first_use()
        kernel.evaluate_rows(self.spec(), rows.astype(np.int64), X, out.fun, out.jac, out.eigenvalues, out.pairs,
                             out.macs, err)
        out.messages[:] = [None if err.code[i] == 0 else error_message(err, i, self.min_mac) for i in range(S)]
        return out

    def residuals(self, X, rows=None, pool: ThreadPoolExecutor | None = None, threads: int = 1) -> Evaluation:
        """The compiled residuals at solver variables X (S, L) of ``rows`` — :meth:`evaluate`
        without the Jacobians (``jac`` is empty, shape (S, 0, L)): what a likelihood needs at many
        points (:mod:`femupdate.bayes`).  Each point's residuals depend on that point alone (not
        on the others, their order or the threads).

        Parameters
        ----------
        X : array_like, shape ``(S, L)``
            The points.
        rows : array_like of int, shape ``(S,)``, optional
            The row (start and data set) of each point (default ``0 .. S-1``).
        pool : concurrent.futures.ThreadPoolExecutor, optional
            Threads to spread the points over (``threads`` contiguous parts; the kernel releases
            the GIL); None: this thread.
        threads : int, default 1
            Number of parts with ``pool``.

        Returns
        -------
        Evaluation
        """
        from . import kernel

        X = np.array(X, dtype=float, ndmin=2)
        rows = np.arange(X.shape[0], dtype=np.int64) if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
        S, L = X.shape
        m, T = int(self.n_residuals.max(initial=1)), int(np.max(self.sets.T, initial=1))
        out = Evaluation(np.zeros((S, m)), np.zeros((S, 0, L)), np.zeros((S, self.n)), np.zeros((S, T), np.int64),
                         np.full((S, T), np.nan), [None] * S)
        if self.mass_error:
            out.messages[:] = [self.mass_error] * S
            return out
        err = new_report(S, T)
        if not S:
            return out
        _announce_first_use()
        spec = self.spec()

        def part(ab):
            a, b = ab
            kernel.residual_rows(spec, rows[a:b], X[a:b], out.fun[a:b], out.eigenvalues[a:b], out.pairs[a:b],
                                 out.macs[a:b], type(err)(*(f[a:b] for f in err)))

        cuts = np.linspace(0, S, max(1, min(threads if pool is not None else 1, S)) + 1).astype(int)
        ranges = [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
        if pool is None or len(ranges) == 1:
            for ab in ranges:
                part(ab)
        else:
            list(pool.map(part, ranges))
        bad = np.flatnonzero(err.code)
        for i in map(int, bad):
            out.messages[i] = error_message(err, i, self.min_mac)
        return out

    def solve(self, progress: Callable[[int, int], None] | None = None, history: bool = True,
              chunk: int = 256) -> BatchLSQResult:
        """Run every start to the end in compiled code (:func:`.kernel.solve_rows`).

        Rows go in a fixed shuffled order, ``chunk`` at a time (the rows of a chunk split over
        one thread per core; progress reported and Ctrl-C taken between chunks); the result does
        not depend on the order or the number of threads.
        """
        from . import kernel, trf

        o = self.options
        x0, x, lb, ub, max_nfev, message = prepare(self.x_start, (self.lb, self.ub), o["max_nfev"])
        R, L = x0.shape
        refused = np.array([m is not None for m in message], bool)
        early = [None if refused[r] else (self.start_errors[r] or self.mass_error) for r in range(R)]
        m_row = self.n_residuals if not self.mass_error else np.zeros(R, np.int64)
        m = int(max(m_row.max(initial=0), 1))
        st = trf.new_state(x, lb, ub, m, m_row, m_row, max_nfev + 1 if history else 0)
        st.status[refused] = FAILED
        for r, e in enumerate(early):
            if e is not None:
                st.status[r], message[r] = FAILED, e
                st.nfev[r] = 1
        err = new_report(R, int(np.max(self.sets.T, initial=1)))
        todo = np.random.default_rng(0).permutation(np.flatnonzero(st.status == trf.RUNNING)).astype(np.int64)
        done = int(R - todo.size)
        if progress and done:
            progress(done, R)
        if todo.size:
            building = _announce_first_use()
            t_build = time.perf_counter()
            spec = self.spec()
            kernel.build(spec, _cores())
            threads = max(1, min(_cores(), todo.size))
            with ThreadPoolExecutor(threads) as pool:
                for a in range(0, todo.size, chunk):
                    parts = np.array_split(todo[a:a + chunk], threads)
                    list(pool.map(lambda rows: kernel.solve_rows(spec, st, rows, o["gtol"], o["ftol"], o["xtol"],
                                                                 max_nfev, err), [p for p in parts if p.size]))
                    if building:  # the first chunk waited for the build: that is its time
                        _record_build(time.perf_counter() - t_build)
                        building = False
                    done += int(sum(p.size for p in parts))
                    if progress:
                        progress(done, R)
        for r in map(int, np.flatnonzero(err.code)):
            message[r] = error_message(err, r, self.min_mac)
        return dataclasses.replace(result_of(st, message), pairs=err.pairs, macs=err.macs,
                                   pair_eigenvalues=err.eigenvalues, codes=err.code.copy())


def _cores() -> int:
    """CPU cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


_ANNOUNCED = False
#: seconds the first build took on an idle two-core machine (benchmarks/bench_first_use.py)
BUILD_SECONDS_IDLE = 13.0
#: the file in numba's cache folder where the last build's measured time is kept
BUILD_RECORD = "femupdate-build.json"


def _announce_first_use() -> bool:
    """Say once per process, before the compiled solver is first needed, whether it is loaded
    from numba's disk cache or built — which, once after installation, takes a while — with the
    time it is expected to take (:func:`build_estimate`).  True when a build is coming."""
    global _ANNOUNCED
    if _ANNOUNCED:
        return False
    _ANNOUNCED = True
    from . import kernel

    if kernel.cached():
        log.info("loading the compiled batched solver from numba's cache")
        return False
    log.warning("femupdate: building the compiled batched solver with numba - once after installation, %s; later "
                "runs load it from the cache", build_estimate())
    return True


def _load() -> float:
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):  # pragma: no cover - not on Unix
        return 0.0


def _record_path() -> Path | None:
    from . import kernel

    cache = getattr(getattr(kernel.solve_rows, "_cache", None), "_cache_path", None)
    return Path(str(cache)) / BUILD_RECORD if cache else None


def build_estimate(cores: int | None = None, load: float | None = None) -> str:
    """How long the build should take here: the last build's measured time on this machine where
    one is recorded, else :data:`BUILD_SECONDS_IDLE` (idle, two cores) scaled by the machine's
    load — the build's two processes get about C / (L + C) of C cores under a load L (at load 6 on
    two cores: about 52 s; 50-72 s were measured)."""
    cores = _cores() if cores is None else cores
    load = _load() if load is None else load
    path = _record_path()
    try:
        last = json.loads(path.read_text()) if path is not None and path.is_file() else None
    except (OSError, ValueError):
        last = None
    if isinstance(last, dict) and isinstance(last.get("seconds"), (int, float)):
        return (f"the last build here took {last['seconds']:.0f} s (at load {last.get('load', 0):.1f} on "
                f"{last.get('cores', '?')} cores)")
    base = BUILD_SECONDS_IDLE * 2 / max(1, min(cores, 2))
    expected = base * (load + max(cores, 1)) / max(cores, 1)
    return (f"about {base:.0f} s on an idle machine, about {expected:.0f} s at the current load ({load:.1f} on {cores} "
            f"core{'s' if cores != 1 else ''})")


def _record_build(seconds: float) -> None:
    """Keep the measured build time beside numba's cache (for the next notice)."""
    path = _record_path()
    if path is None:
        return
    try:
        path.write_text(json.dumps({"seconds": round(seconds, 1), "cores": _cores(), "load": round(_load(), 2)}))
    except OSError:
        log.debug("cannot record the build time in %s", path)


__all__ = ["AUTO_MAX_DOFS", "BatchedProblem",
           "concatenate", "supports", "unsupported", "Evaluation"]
