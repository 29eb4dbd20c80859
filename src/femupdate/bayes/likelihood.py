r"""The posterior density of the updated parameters: the updating core's residuals as a Gaussian
likelihood, times the parameters' priors.

The residuals are exactly those :func:`femupdate.update` minimises — the same
:class:`~femupdate.updating.Problem` (or :class:`~femupdate.updating.CombinedProblem` for FRFs,
static deflections and mixes), the same pairing, weights and stated standard deviations — so that
with stated standard deviations every residual is a standard normal variable at the truth:

.. math::  \log L(\theta) = -\tfrac12 Q(\theta) - \tfrac m2 \log 2\pi, \qquad Q = \lVert r(\theta)\rVert^2

(``noise="stated"``; m residuals).  When the data do not state a standard deviation for every
residual, the blocks without one get a noise scale per kind of data (eigenvalues, shapes, FRFs,
static deflections), each with Jeffreys' prior p(s_b) ∝ 1/s_b, integrated out analytically
(:mod:`femupdate.bayes.noise`; ``noise="estimate"`` estimates every block's):

.. math::  L_b(\theta) = \int_0^\infty (2\pi s^2)^{-n_b/2} e^{-Q_b/(2s^2)} \frac{ds}{s}
           = \tfrac12\,\Gamma(\tfrac{n_b}2)\,(\pi Q_b)^{-n_b/2},

and given θ, s_b² is inverse-gamma with shape n_b/2 and scale Q_b/2; the stated blocks keep their
Gaussian.  The likelihood is the density of
the weighted residuals: a log-evidence built on it compares models (parametrisations) of the
*same* data and standard deviations; the data's own scaling adds the same constant to both.

Several data sets — repeated tests of the same structure — multiply their likelihoods (their
residuals are stacked).  Priors (:mod:`femupdate.priors`) come from the model's parameters or the
caller, truncated to the bounds; the density is that of the sampler's variables x (the
problem's parametrisation: relative, log or absolute), the Jacobian ``|dp/dx|`` included.

Evaluation takes the compiled route (:meth:`femupdate.updating.batched.BatchedProblem.residuals`,
many points at once, the same rules) for modal data of small models, as multi-start does; the
local route evaluates the problems point by point otherwise.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._errors import FemupdateError, InputError
from ..priors import Prior, parse_prior
from ..testdata import TestData
from ..options import FRFOptions, UpdateOptions
from ..options.choices import LIKELIHOOD_ROUTES, NOISE_BASES
from ..updating.combined import CombinedProblem, combined_problem, data_kinds
from ..updating.problem import Problem

log = logging.getLogger(__name__)

#: how the noise is treated: from the stated standard deviations, or a scale estimated with them
NOISE = NOISE_BASES
#: evaluation routes: compiled (many points at once), local (one problem evaluation per point)
ROUTES = LIKELIHOOD_ROUTES
#: fewer points than this are evaluated on one thread (the threads' start-up costs more than they gain)
PARALLEL_POINTS = 96


def data_sets(data) -> list[TestData]:
    """``data`` as a list of test data sets: one :class:`~femupdate.TestData`, or several (repeated
    tests of the same structure, whose likelihoods multiply).

    Raises
    ------
    InputError
        No data set, or an entry that is not test data.
    """
    sets = [data] if isinstance(data, TestData) else list(data)
    if not sets:
        raise InputError("no test data given")
    for k, d in enumerate(sets, start=1):
        if not isinstance(d, TestData):
            raise InputError(f"test data set {k}: expected TestData, got {type(d).__name__}")
    return sets


class Posterior:
    """The log posterior density of the updated parameters of ``model`` given ``data``.

    Parameters
    ----------
    model : Model or DampedModel
        The model; its parameters' ``prior`` (and bounds) give the priors not given in ``priors``.
        A :class:`~femupdate.damping.DampedModel` (or its view): the damping parameters are
        parameters too, the residuals those of :func:`~femupdate.updating.damped_run.damped_problem`,
        the route local.
    data : TestData or sequence of TestData
        The test data (several sets: repeated tests, likelihoods multiplied).
    params : sequence of str, optional
        The updated parameters (default: every parameter not ``fixed``).
    priors : mapping of str to Prior or str, optional
        Priors that replace the model's, by parameter name (``"normal(8, 1)"``, ...).
    values : optional
        Values of the parameters that are not updated (default nominal).
    x0 : mapping, optional
        The reference values of the updated parameters (the parametrisation's scale; default
        nominal).
    route : {"auto", "compiled", "local"}, default ``"auto"``
        How likelihoods are evaluated: ``"auto"`` compiled when the batched route supports the
        model and options (modal data, at most 200 dofs, formulation ``shapes``), else local.
    threads : int, optional
        Threads of the compiled route (default: the cores this process may use).
    options : UpdateOptions, optional
        The updating problem whose residuals make the likelihood (as :func:`femupdate.update`
        takes it; its solver's parametrisation gives the sampler's variables x).  Its
        ``noise.basis``: ``"stated"``: every residual is divided by a stated standard deviation
        (an :class:`InputError` otherwise); ``"estimate"``: a scale per kind of data on the
        residuals as weighted, Jeffreys' prior, integrated out; ``"auto"``: the blocks with
        stated standard deviations as stated, a scale per kind estimated for the others (with a
        note).
    **shorthand
        Fields of its option objects as keywords (``noise="estimate"``, ``min_mac=0.8``, ...).

    Attributes
    ----------
    names : tuple of str
        The updated parameters.
    n_residuals : int
        m, the residuals of all data sets together.
    noise : str
        ``"stated"`` or ``"estimate"`` (resolved).
    route : str
        ``"compiled"`` or ``"local"``.
    priors : list of Prior or None
        Per updated parameter; None: flat (uniform within finite bounds, improper otherwise).
    improper : list of str
        Parameters with an improper flat prior (an infinite bound and no declared prior).
    lo, hi : numpy.ndarray, shape ``(L,)``
        Their bounds.
    notes : list of str
        What the user should know (how the noise is treated, improper priors, ...).
    evaluations : int
        Likelihood evaluations so far; ``failures`` counts those that failed, by message.

    Raises
    ------
    InputError
        Bad options or data (as :func:`femupdate.update`); a prior for a parameter that is not
        updated; ``noise="stated"`` without a standard deviation for every residual; a noise scale
        to estimate from no more residuals than parameters.
    """

    def __init__(self, model, data, params: Sequence[str] | None = None, *, priors: Mapping | None = None,
                 values=None, x0: Mapping | None = None, route: str = "auto", threads: int | None = None,
                 options: UpdateOptions | None = None, **shorthand):
        o = UpdateOptions.of("Posterior", shorthand, options=options)
        noise = o.noise.basis
        if route not in ROUTES:
            raise InputError(f"unknown route {route!r}: use {', '.join(ROUTES)}")
        from ..damping.view import as_view

        #: a damped model's engine view (:class:`~femupdate.damping.view.DampedView`), else None
        self.damped = as_view(model)
        model = self.damped or model
        self.model = model
        self.sets = data_sets(data)
        self._held: list[str] = []  # a damped model's note on the damping parameters held (no damping data)
        #: the keyword arguments that rebuild this posterior from (model, data) — on a Dask worker
        self.definition = dict(params=params, priors=priors, values=values, x0=x0, route=route, options=o)
        names = list(params) if params is not None else self._default_names(o, values, x0)
        if not names:
            raise InputError("no parameters to update: every parameter is fixed")
        idx = model.parameter_indices(names, "updated parameters (--params)")
        given = {}
        for name, spec in dict(priors or {}).items():
            if name not in names:
                raise InputError(f"prior given for {name!r}, which is not an updated parameter (updated: "
                                 f"{', '.join(names)})")
            given[name] = parse_prior(spec, f"prior of {name}")
        self.lo = np.array([model.parameters[j].bounds[0] for j in idx], float)
        self.hi = np.array([model.parameters[j].bounds[1] for j in idx], float)
        self.priors: list[Prior | None] = []
        self.improper: list[str] = []
        for j, (name, k) in enumerate(zip(names, idx)):
            pr = given.get(name, model.parameters[k].prior)
            if pr is not None:
                pr.check(name, (self.lo[j], self.hi[j]))
            elif not (math.isfinite(self.lo[j]) and math.isfinite(self.hi[j])):
                self.improper.append(name)
            self.priors.append(pr)
        informative = all(p is not None and p.kind != "uniform" for p in self.priors)
        self.kinds = data_kinds(self.sets[0], o.use)
        #: what the search for solutions passes to :func:`femupdate.update` besides the names
        self.options = dict(values=values, x0=x0, options=o)
        self.problems: list[CombinedProblem] = []
        for k, d in enumerate(self.sets, start=1):
            try:
                self.problems.append(self._problem(d, names, x0, values, o.replace(use=self.kinds), informative))
            except InputError as exc:
                raise InputError(f"test data set {k}: {exc}" if len(self.sets) > 1 else str(exc)) from None
        first = self.problems[0]
        self.param = first  # the parametrisation (names, idx, scale, maps)
        self.names = tuple(first.names)
        self.L = len(self.names)
        self.n_residuals = int(sum(p.n_residuals for p in self.problems))
        from ..updating.run import undamped_notes

        self.notes: list[str] = self._held + ([] if self.damped else undamped_notes(self.sets[0], o))
        for p in self.problems:
            for n in [*p.notes, *(p.modal.notes if p.modal is not None else [])]:
                if n not in self.notes:
                    self.notes.append(n)
        stated = all(_stated(p) for p in self.problems)
        if noise == "stated" and not stated:
            raise InputError("noise 'stated' (--noise stated) needs a standard deviation for every residual: state "
                             "the eigenvalues' and, when shapes are compared, the shapes' (--std-eigenvalue, --std-shape; "
                             "std_frequency, std_shape in the test data), and --std-frf / --std-static for FRFs and "
                             "static deflections; or use --noise estimate")
        from .noise import noise_pools

        #: the noise pools: the stated blocks, and one estimated scale per kind of data (:mod:`femupdate.bayes.noise`)
        self.pools, pool_notes = noise_pools(self.problems, noise, self.L)
        self.noise = "stated" if all(p.basis == "stated" for p in self.pools) else "estimate"
        if self.noise == "estimate":
            n_est = sum(p.n for p in self.pools if p.basis == "estimated")
            if n_est <= self.L:
                raise InputError(f"{n_est} residuals for {self.L} parameters: a noise scale cannot be "
                                 "estimated from the fit; state the measurement standard deviations (--std-eigenvalue, "
                                 "--std-shape, ...; std_frequency, std_shape in the test data)")
            est = [p.label for p in self.pools if p.basis == "estimated"]
            self.notes.append(
                (f"the noise of {', '.join(est)} is estimated" + (", every block's, as asked (noise 'estimate')"
                                                                 if noise == "estimate" else
                                                                 " (no standard deviation stated for it)"))
                + ": one noise scale per kind of data on the residuals as weighted, each with Jeffreys' prior "
                  "p(s) ∝ 1/s, integrated out (the likelihood is ∝ Π ‖r_b‖^-n_b)"
                + ("; the blocks with stated standard deviations use them as stated" if any(
                    p.basis == "stated" for p in self.pools) else "")
                + "; state the test's standard deviations to use its own uncertainty")
            self.notes.extend(pool_notes)
        if self.improper:
            self.notes.append(f"improper flat prior on {', '.join(self.improper)} (an infinite bound and no prior "
                              "declared): the posterior is proper only if the data confine them, and the evidence is "
                              "not defined")
        self.route = self._choose_route(route, o)
        self.threads = max(1, int(threads)) if threads else _cores()
        self._pool: ThreadPoolExecutor | None = None
        self.evaluations = 0
        self.failures: Counter = Counter()
        self._log_prior_const = self._prior_constant()
        #: the parameters without a declared prior, and their flat density's log (uniform within finite
        #: bounds; an improper prior's constant is taken as 1)
        self._flat = np.array([j for j, pr in enumerate(self.priors) if pr is None], dtype=np.intp)
        self._log_flat = -float(sum(math.log(self.hi[j] - self.lo[j]) for j in self._flat
                                    if math.isfinite(self.lo[j]) and math.isfinite(self.hi[j])))

    # ------------------------------------------------------------------ setup
    def _default_names(self, o: UpdateOptions, values, x0) -> list[str]:
        """The parameters not ``fixed``; of a damped model those its update moves (the damping
        parameters only when the data hold damping ratios, complex shapes or FRFs, with a note)."""
        if self.damped is None:
            return [self.model.parameter_names[j] for j in self.model.free]
        from ..updating.damped_run import damped_problem

        prob = damped_problem(self.damped, self.sets[0], o, None, x0=x0, values=values)
        self._held = [n for n in prob.notes if "are not updated" in n]
        return list(prob.names)

    def _problem(self, d: TestData, names, x0, values, o: UpdateOptions, informative: bool) -> CombinedProblem:
        """The updating problem of one data set: :func:`~femupdate.updating.combined.combined_problem`,
        or for a damped model :func:`~femupdate.updating.damped_run.damped_problem` (its damped
        modes and damped FRF blocks, the residuals its update minimises)."""
        if self.damped is None:
            return combined_problem(self.model, d, names, x0=x0, values=values, options=o, regularized=informative)
        from ..updating.damped_run import damped_problem

        return damped_problem(self.damped, d, o, names, x0=x0, values=values)

    def _choose_route(self, route: str, o: UpdateOptions) -> str:
        from ..updating.batched import unsupported

        reason = None
        if self.damped is not None:
            reason = "the model is damped (a [damping] table: its complex modes are evaluated point by point)"
        elif self.kinds != ("modes",):
            reason = f"the data used are {', '.join(self.kinds)} (the compiled route takes modal data only)"
        else:
            reason = unsupported(self.model, o.replace(frf=FRFOptions()), explicit=route == "compiled")
        first = self.problems[0].modal
        if reason is None and first is not None and first.close_modes > 0:
            # groups of repeated or close modes are compared by the local route only (femupdate.updating.groups)
            from ..modal import model_modes
            from ..close_modes import mode_groups

            lam = model_modes(self.model, first.to_p(first.x_start), n_modes=first.n_modes).eigenvalues
            if mode_groups(lam, first.close_modes):
                reason = (f"the model has repeated or close modes at the start (relative gap below "
                          f"{first.close_modes:g}), which the compiled route does not compare as groups")
                log.info("posterior: local route: %s", reason)
        if route == "compiled" and reason:
            raise InputError(f"route 'compiled': {reason}; use route 'local'")
        if route == "local" or reason:
            return "local"
        from ..updating.batched import BatchedProblem

        assert first is not None
        starts = np.tile(first.start, (len(self.problems), 1))
        targets = []
        for p in self.problems:
            assert p.modal is not None
            targets.append(p.modal.targets)
        self.batched = BatchedProblem(self.model, self.names, starts, targets, np.arange(len(targets)),
                                      values=first.p_base.copy(), parametrisation=first.param,
                                      shape_scaling=first.scaling, min_mac=first.min_mac, pairing=first.pairing)
        return "compiled"

    def _prior_constant(self) -> float:
        """Σ log |dp/dx| of a linear parametrisation (constant), 0 for ``log`` (it varies)."""
        if self.param.param == "relative":
            return float(np.sum(np.log(self.param.scale)))
        return 0.0

    def close(self) -> None:
        """Release the compiled route's threads (a later evaluation starts them again)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_pool"] = None
        return state

    # ------------------------------------------------------------------ variables
    def to_p(self, X) -> np.ndarray:
        """The updated parameters' values (S, L) at the variables X (S, L)."""
        X = np.asarray(X, float)
        kind = self.param.param
        if kind == "relative":
            return X * self.param.scale
        if kind == "log":
            with np.errstate(over="ignore"):
                return np.exp(X)
        return X.copy()

    def from_p(self, P) -> np.ndarray:
        """The variables X of the updated parameters' values P (S, L)."""
        from ..updating.parametrisation import x_of_p

        return x_of_p(self.param.param, np.asarray(P, float), self.param.scale)

    def bounds_x(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the variables x (L,)."""
        return self.param.bounds_x(self.lo, self.hi)

    # ------------------------------------------------------------------ prior
    def log_prior(self, X) -> np.ndarray:
        """log prior density of the variables X (S, L) (−inf outside the bounds or support),
        the Jacobian ``|dp/dx|`` included; (S,)."""
        X = np.atleast_2d(np.asarray(X, float))
        P = self.to_p(X)
        out = np.full(X.shape[0], self._log_prior_const + self._log_flat)
        if self.param.param == "log":
            out += X.sum(axis=1)
        flat = self._flat
        if flat.size:  # the parameters without a declared prior: flat within the bounds, all at once
            Pf = P[:, flat]
            out[~np.all((Pf >= self.lo[flat]) & (Pf <= self.hi[flat]), axis=1)] = -np.inf
        for j, pr in enumerate(self.priors):
            if pr is not None:
                out += pr.logpdf(P[:, j], self.lo[j], self.hi[j])
        out[~np.all(np.isfinite(X), axis=1)] = -np.inf
        return out

    def prior_derivatives(self, x) -> tuple[float, np.ndarray, np.ndarray]:
        """The log prior density at x (L,), its gradient (L,) and its Hessian (L, L; diagonal) in x."""
        x = np.asarray(x, float)
        lp = float(self.log_prior(x[None, :])[0])
        p = self.to_p(x[None, :])[0]
        dpdx = self.param.dp_dx(x)
        d2pdx2 = p if self.param.param == "log" else np.zeros(self.L)
        g = np.ones(self.L) if self.param.param == "log" else np.zeros(self.L)
        h = np.zeros(self.L)
        for j, pr in enumerate(self.priors):
            if pr is None:
                continue
            d1, d2 = pr.derivatives(p[j:j + 1])
            g[j] += d1[0] * dpdx[j]
            h[j] += d2[0] * dpdx[j] ** 2 + d1[0] * d2pdx2[j]
        return lp, g, np.diag(h)

    def sample_prior(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` draws of the variables x from the prior (n, L).

        Raises
        ------
        InputError
            A parameter with an improper prior.
        """
        if self.improper:
            raise InputError(f"drawing from the prior needs a proper prior for every parameter; "
                             f"{', '.join(self.improper)} have an infinite bound and no prior: give bounds or a "
                             "normal / lognormal prior (--prior NAME=normal(MEAN,STD))")
        P = np.empty((n, self.L))
        for j, pr in enumerate(self.priors):
            P[:, j] = (pr or Prior("uniform")).sample(rng, n, self.lo[j], self.hi[j])
        return self.from_p(P)

    # ------------------------------------------------------------------ likelihood
    def sum_of_squares(self, X) -> tuple[np.ndarray, list]:
        """Q = ‖r‖² over every data set at the variables X (S, L): (S,) (NaN where the model
        cannot be evaluated), and per point None or the failure's message."""
        Qp, messages = self.pool_squares(X)
        return Qp.sum(axis=1), messages

    def pool_squares(self, X) -> tuple[np.ndarray, list]:
        """Q_b = ‖r_b‖² of each noise pool (:attr:`pools`) over every data set at the variables X
        (S, L): (S, P) (NaN rows where the model cannot be evaluated), and per point None or the
        failure's message."""
        X = np.atleast_2d(np.asarray(X, float))
        S, P = X.shape[0], len(self.pools)
        Qp = np.zeros((S, P))
        messages: list = [None] * S
        if not S:
            return Qp, messages
        if self.route == "compiled":
            n = len(self.problems)
            rows = np.repeat(np.arange(n, dtype=np.int64), S)
            threads = self.threads if n * S >= PARALLEL_POINTS else 1
            if self._pool is None and threads > 1:
                self._pool = ThreadPoolExecutor(self.threads)
            ev = self.batched.residuals(np.tile(X, (n, 1)), rows, pool=self._pool if threads > 1 else None,
                                        threads=threads)
            for i in range(n):
                fun = ev.fun[i * S:(i + 1) * S]
                for b, pool in enumerate(self.pools):
                    sub = fun[:, pool.rows[i]] * pool.w(i)[None, :]
                    Qp[:, b] += np.einsum("ij,ij->i", sub, sub)
            for i, msg in enumerate(ev.messages):
                if msg is not None and messages[i % S] is None:
                    messages[i % S] = msg
        else:
            from .noise import pool_squares

            for i, x in enumerate(X):
                try:
                    Qp[i] = pool_squares(self.pools, lambda k: self.problems[k].residuals(x))
                except FemupdateError as exc:
                    messages[i] = f"{type(exc).__name__}: {exc}"
        bad = [i for i, m in enumerate(messages) if m is not None]
        Qp[bad] = np.nan
        self.evaluations += S
        for i in bad:
            self.failures[messages[i]] += 1
        return Qp, messages

    def log_likelihood_of(self, Qp) -> np.ndarray:
        """log L from the pools' sums of squares Qp (S, P) (a single pool: also Q (S,)), by the
        noise treatment (module docstring, :mod:`femupdate.bayes.noise`); NaN: −inf."""
        from .noise import log_likelihood

        Qp = np.asarray(Qp, float)
        if Qp.ndim == 1:
            Qp = Qp[:, None]
        return log_likelihood(self.pools, Qp)

    def log_likelihood(self, X) -> np.ndarray:
        """log L at the variables X (S, L); −inf where the model cannot be evaluated."""
        Qp, _ = self.pool_squares(X)
        return self.log_likelihood_of(Qp)

    def log_posterior(self, X, with_likelihood: bool = False):
        """log prior + log likelihood at X (S, L) — the likelihood evaluated only where the prior is
        positive; with ``with_likelihood`` also the log likelihoods (−inf where not evaluated)."""
        X = np.atleast_2d(np.asarray(X, float))
        lp = self.log_prior(X)
        ll = np.full(X.shape[0], -np.inf)
        ok = np.isfinite(lp)
        if ok.any():
            ll[ok] = self.log_likelihood(X[ok])
        out = lp + ll
        return (out, ll) if with_likelihood else out

    # ------------------------------------------------------------------ exact local derivatives
    def residuals_and_jacobian(self, x) -> tuple[np.ndarray, np.ndarray]:
        """The stacked residuals r (m,) and exact Jacobian ∂r/∂x (m, L) of every data set at x (local
        route: the problems' own derivative routes)."""
        rs, Js = [], []
        for prob in self.problems:
            rs.append(prob.residuals(x))
            Js.append(prob.jacobian(x))
        return np.concatenate(rs), np.vstack(Js)

    def objective(self, x, exact_hessian: bool = False,
                  restricted: bool = False) -> tuple[float, np.ndarray, np.ndarray, float]:
        """f = −log posterior at x, its gradient and Gauss–Newton Hessian in x, and Q = ‖r‖².

        Per noise pool (:mod:`femupdate.bayes.noise`): stated, Q_b/2 + n_b/2 log 2π with
        Hessian J_bᵀJ_b; estimated, n_b/2 log(πQ_b) − log Γ(n_b/2) + log 2 with gradient
        (n_b/Q_b) J_bᵀr_b and Hessian (n_b/Q_b) J_bᵀJ_b, and with ``exact_hessian`` the term
        −(2n_b/Q_b²)(J_bᵀr_b)(J_bᵀr_b)ᵀ of the Gauss–Newton Hessian of n_b/2 log Q_b, which
        vanishes where J_bᵀr_b = 0; less the log prior's derivatives.  ``restricted``: each
        estimated pool's Gauss–Newton term with n_b less its share of the parameters (the REML
        scale, :func:`femupdate.bayes.noise.objective_terms`) — the Laplace covariance's Hessian.

        Raises
        ------
        NumericalError
            The model cannot be evaluated at x.
        """
        from .noise import objective_terms

        r, J = self.residuals_and_jacobian(x)
        lp, gp, hp = self.prior_derivatives(x)
        offsets = np.cumsum([0] + [int(p.n_residuals) for p in self.problems])[:-1]
        f, g, H, Q = objective_terms(self.pools, r, J, offsets, exact_hessian, -hp if restricted else None)
        return f - lp, g - gp, H - hp, Q

    # ------------------------------------------------------------------ noise scale and predictions
    def noise_scale(self, Qp, rng: np.random.Generator) -> dict:
        """Draws of each estimated pool's noise scale given each sample's pool sums of squares
        Qp (S, P): s_b² = Q_b / (2 g), g ~ Gamma(n_b/2, 1), its conditional posterior under
        Jeffreys' prior; {pool label: draws} (empty when every pool is stated)."""
        from .noise import scale_draws

        return scale_draws(self.pools, Qp, rng)

    def modal_problem(self) -> Problem | None:
        """The first data set's modal problem (None without measured modes)."""
        return self.problems[0].modal

    def predict(self, X) -> dict | None:
        """The paired modes' frequencies (Hz) and MACs of the first data set at the variables X
        (S, L): ``{"frequencies_hz": (S, T), "mac": (S, T), "eigenvalue_std": (T,)}`` (NaN where
        the model cannot be evaluated; ``eigenvalue_std`` the relative standard deviation of a new
        measurement of each eigenvalue in the likelihood's units, before the noise scale);
        None without measured modes."""
        if self.damped is not None:
            from .damped import predict_damped

            return predict_damped(self, X)
        modal = self.modal_problem()
        if modal is None:
            return None
        X = np.atleast_2d(np.asarray(X, float))
        tg = modal.targets
        S, T = X.shape[0], tg.n_test
        freq = np.full((S, T), np.nan)
        macs = np.full((S, T), np.nan)
        if self.route == "compiled":
            ev = self.batched.residuals(X, np.zeros(S, np.int64))
            for i in range(S):
                if ev.messages[i] is None:
                    lam = ev.eigenvalues[i, ev.pairs[i, :T]]
                    freq[i] = np.sqrt(np.clip(lam, 0, None)) / (2 * math.pi)
                    macs[i] = ev.macs[i, :T]
        else:
            for i, x in enumerate(X):
                try:
                    _, modes, pairs = modal.evaluate(x)
                except FemupdateError:
                    continue
                for k, j, mac in pairs:
                    freq[i, k] = modes.frequencies_hz[j]
                    macs[i, k] = mac if np.isfinite(mac) else modal.mac_of_pair(modes, k, j)
        with np.errstate(divide="ignore"):
            std = np.where(tg.w_lam > 0, 1.0 / tg.w_lam, np.inf)
        return {"frequencies_hz": freq, "mac": macs, "eigenvalue_std": std}


def _stated(prob: CombinedProblem) -> bool:
    """Whether every residual of ``prob`` is divided by a stated standard deviation."""
    for b in prob.blocks:
        if isinstance(b.problem, Problem):
            if b.problem.sigma is None:
                return False
        elif b.weighting != "stated std":
            return False
    return True


def _cores() -> int:
    from ..updating.batched.driver import _cores as cores

    return cores()


__all__ = ["Posterior", "data_sets", "NOISE", "ROUTES"]
