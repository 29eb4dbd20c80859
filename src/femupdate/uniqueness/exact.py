r"""Every parameter set that reproduces measured eigenvalues: exact solution sets (eqs. 11-12 generalised).

The paper's two-dof example (eqs. 11-12) equates the coefficients of the characteristic
polynomial :math:`\det(K - \lambda M) = a_2\lambda^2 - a_1\lambda + a_0` with those implied by
the measured eigenvalues and finds two stiffness pairs, (8, 6) and (9, 16/3).  Generalised to an
affine model :math:`K(p) = K_0 + \sum_j p_j K_j`, :math:`M(p) = M_0 + \sum_j p_j M_j`:

* **all N eigenvalues measured** — with :math:`\det(K - \lambda M) = \det M \prod_i (\lambda_i - \lambda)
  = \sum_k c_k(p)\lambda^k`, the N equations

  .. math:: c_k(p) - \det M(p)\; q_k = 0, \qquad k = 0, \dots, N-1,

  where :math:`\prod_i(\lambda_i - \lambda) = \sum_k q_k \lambda^k` (the :math:`q_k` are signed
  elementary symmetric functions of the measured eigenvalues; :math:`k = N` holds identically).
  With M fixed and :math:`\det M` factored out, these are exactly eqs. 11-12's
  ":math:`a_1` and :math:`a_0` define the uniqueness of the problem".
* **m < N eigenvalues measured** — :math:`\det(K(p) - \lambda_i M(p)) = 0` for each measured
  :math:`\lambda_i`; a solution whose measured eigenvalues are not its *lowest* m is flagged
  (``lowest_modes`` False), since the data are the lowest modes.

The polynomial system is solved over the rationals with SymPy: a Gröbner basis (grevlex), converted
to lex order by FGLM; for a zero-dimensional, radical system in general position the lex basis has
the "shape" :math:`\{x_1 - g_1(x_L), \dots, x_{L-1} - g_{L-1}(x_L), h(x_L)\}`, so every complex
solution is a root of the univariate :math:`h` and the **real** solutions are its real roots
(isolated exactly, :meth:`sympy.Poly.real_roots`), each giving :math:`x_i = g_i(x_L)` exactly.
When the basis is not in shape position for any variable order, a separating variable
:math:`t = \sum_i c_i x_i` is added.  Rational data (rational parameter values, or eigenvalues
given as rationals) give exact rational or algebraic solutions; decimal data are converted to
rationals from their shortest decimal representation.

Size limit: at most :data:`MAX_PARAMETERS` unknown parameters and :data:`MAX_DOFS` dofs.  The
Gröbner basis of this system has degree up to N!/(N−L)! and its computation grows doubly
exponentially: a four-spring chain takes about a second, a five-spring chain did not finish in
15 minutes.  Larger problems are refused with a clear message — use the Monte Carlo study
(:func:`femupdate.uniqueness.study.run_study`), which finds the solutions the starts reach.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .._checks import count_arg, flag_arg, model_arg, params_arg, shown, values_arg
from .._errors import InputError, NumericalError

MAX_PARAMETERS = 4  #: most unknown parameters the exact (Gröbner) solver accepts
MAX_DOFS = 8  #: most model dofs the exact solver accepts (symbolic determinant)
EIG_RTOL = 1e-8  #: relative agreement of a solution's eigenvalues with the measured ones


@dataclass(frozen=True, eq=False)
class ExactSolution:
    """One real parameter set reproducing the measured eigenvalues.

    Built by :func:`exact_solutions`; each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    parameters : dict of str to float
        The unknowns' values.
    exact : dict of str to str
        The same exactly: a rational such as ``"16/3"``, or an algebraic number to 30 digits.
    rational : bool
        Every value is rational.
    within_bounds : bool
        Within the parameters' bounds (always True when :func:`exact_solutions` ignores bounds).
    physical : bool
        M positive definite and K positive semi-definite (no negative eigenvalue) at the solution.
    lowest_modes : bool
        The measured eigenvalues are the model's lowest ones at this solution (relative
        tolerance ``EIG_RTOL``).
    eigenvalues : ndarray, shape ``(N,)``
        Every eigenvalue of the model at the solution (rad²/s², numerical check); NaN when M is not
        positive definite.
    """

    parameters: dict[str, float]
    exact: dict[str, str]
    rational: bool
    within_bounds: bool
    physical: bool
    lowest_modes: bool
    eigenvalues: np.ndarray

    @property
    def valid(self) -> bool:
        """Within the bounds, physical, and reproducing the measured (lowest) eigenvalues."""
        return self.within_bounds and self.physical and self.lowest_modes


@dataclass(frozen=True, eq=False)
class ExactSolutionSet:
    """Result of :func:`exact_solutions`.

    Each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    names : tuple of str
        The unknown parameters.
    measured_eigenvalues : ndarray, shape ``(m,)``
        The measured eigenvalues (rad²/s²), ascending.
    solutions : list of ExactSolution
        The valid real solutions (:attr:`ExactSolution.valid`), sorted.
    rejected : list of ExactSolution
        Real solutions outside the bounds, unphysical, or placing a measured eigenvalue above an
        unmeasured one.
    n_complex : int or None
        Number of distinct complex solutions (None when infinite).
    zero_dimensional : bool
        False when the data leave a continuum of (complex) solutions.
    exact_data : bool
        The data were rational, so the solutions are exact.
    equations : list of str
        The polynomial equations solved, in the parameters' names.
    method : str
        Which system was solved and how.
    notes : list of str, default ``[]``
    """

    names: tuple[str, ...]
    measured_eigenvalues: np.ndarray
    solutions: list[ExactSolution]
    rejected: list[ExactSolution]
    n_complex: int | None
    zero_dimensional: bool
    exact_data: bool
    equations: list[str]
    method: str
    notes: list[str] = field(default_factory=list)

    @property
    def unique(self) -> bool | None:
        """True for exactly one valid solution, False for several or a continuum, None for none."""
        if not self.zero_dimensional:
            return False
        return None if not self.solutions else len(self.solutions) == 1


def _rational(x, what: str):
    import sympy as sp

    if isinstance(x, sp.Basic):
        v = sp.nsimplify(x) if not x.is_Rational else x
        if not v.is_Rational:
            raise InputError(f"{what}: {x} is not a rational number")
        return v
    if isinstance(x, str):
        try:
            return sp.Rational(x.strip())
        except (TypeError, ValueError):
            raise InputError(f"{what}: {x!r} is not a number") from None
    if isinstance(x, (int, np.integer)):
        return sp.Integer(int(x))
    v = float(x)
    if not math.isfinite(v):
        raise InputError(f"{what}: {x!r} is not finite")
    return sp.Rational(repr(v))  # the shortest decimal that round-trips: 0.1 -> 1/10


def _symbolic(model, names, p_values):
    """K(p), M(p) as SymPy matrices in the unknowns (others fixed at ``p_values``)."""
    import sympy as sp

    syms = sp.symbols(" ".join(f"x{j}" for j in range(len(names))), seq=True)
    idx = [model.parameter_index(n) for n in names]
    N = model.n_dofs

    def mat(A):
        out = sp.zeros(N, N)
        if A is None:
            return out
        A = A.tocoo()
        for i, j, v in zip(A.row, A.col, A.data):
            out[i, j] += _rational(v, "model matrix entry")
        return out

    K, M = mat(model.K0), mat(model.M0)
    for j in range(len(model.parameters)):
        coef = syms[idx.index(j)] if j in idx else _rational(p_values[j], f"value of {model.parameter_names[j]}")
        if model.dK[j] is not None:
            K += coef * mat(model.dK[j])
        if model.dM[j] is not None:
            M += coef * mat(model.dM[j])
    return syms, K, M


def _shape_form(G, gens):
    """``({x_i: g_i(x_last)}, h)`` if the lex basis ``G`` (in ``gens``) has the shape form, else None."""
    import sympy as sp

    last = gens[-1]
    polys = [sp.Poly(g, *gens) for g in G.exprs]
    if len(polys) != len(gens):
        return None
    h = polys[-1]
    if any(h.degree(v) > 0 for v in gens[:-1]):
        return None
    subs = {}
    for v, P in zip(gens[:-1], polys[:-1]):
        if P.degree(v) != 1 or any(P.degree(w) > 0 for w in gens[:-1] if w != v):
            return None
        a1, a0 = sp.Poly(P.as_expr(), v).all_coeffs()
        if a1.free_symbols:
            return None
        subs[v] = sp.expand(-a0 / a1)
    return subs, sp.Poly(h.as_expr(), last)


def _solve_system(eqs, syms):
    """All complex solutions of a zero-dimensional system in shape form: ``(gens, subs, h)``;
    ``(None, None, None)`` for a positive-dimensional system; h = 1 when there is no solution."""
    import sympy as sp

    G = sp.groebner(eqs, *syms, order="grevlex")
    if G.exprs == [1]:
        return syms, {}, sp.Poly(1, syms[-1])
    if not G.is_zero_dimensional:
        return None, None, None
    for last in reversed(syms):  # try each variable as the last one of the lex order
        gens = tuple(v for v in syms if v != last) + (last,)
        Gl = sp.groebner(eqs, *gens, order="grevlex").fglm("lex") if gens != tuple(syms) else G.fglm("lex")
        form = _shape_form(Gl, gens)
        if form is not None:
            return gens, form[0], form[1]
    t = sp.Symbol("t_sep")
    for c in itertools.islice(itertools.product(range(1, 6), repeat=len(syms)), 20):
        gens = tuple(syms) + (t,)
        Gl = sp.groebner(list(eqs) + [t - sum(ci * v for ci, v in zip(c, syms))], *gens, order="grevlex").fglm("lex")
        form = _shape_form(Gl, gens)
        if form is not None:
            return gens, form[0], form[1]
    raise NumericalError("the polynomial system is not in shape position for any separating variable tried "
                         "(repeated solutions?); the exact solution set could not be isolated")


def _door(model, eigenvalues, values, n_modes, params, bounds) -> None:
    """:func:`exact_solutions`'s arguments by type (:mod:`femupdate._checks`)."""
    model_arg(model, "model", "exact_solutions")
    if eigenvalues is not None and (isinstance(eigenvalues, (str, bytes))
                                    or not isinstance(eigenvalues, (Sequence, np.ndarray))):
        raise TypeError(f"exact_solutions: eigenvalues must be a list of numbers (or rationals such as '16/3'), got "
                        f"{shown(eigenvalues)}")
    values_arg(model, values, "values", "exact_solutions")
    count_arg(n_modes, "n_modes", "exact_solutions", optional=True)
    params_arg(params, "params", "exact_solutions")
    flag_arg(bounds, "bounds", "exact_solutions")


def _measured(model, eigenvalues, n_modes, p_values) -> tuple[np.ndarray, list | None, int]:
    """:func:`exact_solutions`'s data: the m measured eigenvalues as floats and, when given, as
    rationals (None when they are the model's own at ``p_values``), and m."""
    from scipy.linalg import eigh

    N = model.n_dofs
    if eigenvalues is None:
        m = N if n_modes is None else int(n_modes)
        if not 1 <= m <= N:
            raise InputError(f"exact solutions: n_modes must be between 1 and {N}, got {n_modes}")
        lam_num = eigh(model.K(p_values).toarray(), model.M(p_values).toarray(), eigvals_only=True)[:m]
        return lam_num, None, m
    lam_q = [_rational(v, f"eigenvalue {k + 1}") for k, v in enumerate(eigenvalues)]
    m = len(lam_q)
    if not 1 <= m <= N:
        raise InputError(f"exact solutions: give between 1 and {N} eigenvalues, got {m}")
    if any(v <= 0 for v in lam_q):
        raise InputError("exact solutions: measured eigenvalues must be positive")
    lam_num = np.array([float(v) for v in lam_q])
    if np.any(np.diff(lam_num) < 0):
        raise InputError("exact solutions: give the eigenvalues in ascending order (the lowest modes)")
    return lam_num, lam_q, m


def exact_solutions(model, eigenvalues: Sequence | None = None, *, values=None, n_modes: int | None = None,
                    params: Sequence[str] | None = None, bounds: bool = True) -> ExactSolutionSet:
    """All real parameter sets giving the measured eigenvalues (frequencies alone).

    Parameters
    ----------
    model : Model
        At most :data:`MAX_DOFS` dofs.
    eigenvalues : sequence of float, str or sympy.Rational, optional
        Measured eigenvalues (rad²/s²) of the lowest modes, ascending, as numbers or rationals
        (``sympy.Rational`` or strings such as ``"16/3"``); default: those of the model at
        ``values`` — then with all N modes the data are the characteristic polynomial's rational
        coefficients and the solutions are exact (eq. 11: a1 = 68, a0 = 48 for the paper's example).
    values : None, mapping of str to float, or array_like, optional
        Parameter values: the truth when ``eigenvalues`` is None, and the values of the
        parameters that are not unknowns (default: the model's).
    n_modes : int, optional
        With ``eigenvalues`` None, the number of lowest modes measured (default all N).
    params : sequence of str, optional
        Unknown parameters (default: every parameter not fixed); at most :data:`MAX_PARAMETERS`.
    bounds : bool, default True
        Keep only solutions within the parameters' bounds (others go to ``rejected``).

    Returns
    -------
    ExactSolutionSet

    Raises
    ------
    InputError
        No unknown parameter or an unknown name; more than ``MAX_PARAMETERS`` unknowns or
        ``MAX_DOFS`` dofs; ``n_modes`` or the number of eigenvalues not between 1 and N; an
        eigenvalue that is not a (positive) number, or eigenvalues not ascending; with fewer than
        N eigenvalues, repeated ones.
    """
    from ..coefficients import route_refusal
    route_refusal(model, 'the exact-solution algebra (exact_solutions, uniqueness --exact)')
    _door(model, eigenvalues, values, n_modes, params, bounds)
    import sympy as sp
    from scipy.linalg import eigh

    names = tuple(params) if params is not None else tuple(model.parameter_names[j] for j in model.free)
    if not names:
        raise InputError("exact solutions: no unknown parameters (every parameter is fixed)")
    for n in names:
        model.parameter_index(n)
    N, L = model.n_dofs, len(names)
    if L > MAX_PARAMETERS or N > MAX_DOFS:
        raise InputError(
            f"exact solution sets are limited to {MAX_PARAMETERS} unknown parameters and {MAX_DOFS} dofs "
            f"(this problem: {L} unknowns, {N} dofs): the Gröbner basis grows doubly exponentially; "
            "use the Monte Carlo study (femupdate uniqueness) instead")
    p_values = model.resolve(values)
    notes: list[str] = []
    lam_num, lam_q, m = _measured(model, eigenvalues, n_modes, p_values)
    syms, K, M = _symbolic(model, names, p_values)
    lam = sp.Symbol("lam")
    detM = sp.expand(M.det(method="berkowitz"))
    if m == N:
        P = sp.Poly(sp.expand((K - lam * M).det(method="berkowitz")), lam)
        c = [P.coeff_monomial(lam**k) for k in range(N + 1)]
        if lam_q is None:  # the data: q_k = c_k(p_true) / det M(p_true), rational
            sub = {s: _rational(p_values[model.parameter_index(n)], n) for s, n in zip(syms, names)}
            dm = detM.subs(sub)
            q = [sp.nsimplify(ck.subs(sub) / dm) for ck in c]
        else:
            q = sp.Poly(sp.prod([v - lam for v in lam_q]), lam).all_coeffs()[::-1]
        exact_data = True
        eqs = [sp.expand(c[k] - detM * q[k]) for k in range(N)]
        method = "coefficients of det(K - λM) = det M Π(λ_i - λ), Gröbner basis (grevlex, FGLM to lex)"
    else:
        if lam_q is None:
            lam_q = [_rational(v, f"eigenvalue {k + 1}") for k, v in enumerate(lam_num)]
            exact_data = False
            notes.append(f"{m} of {N} eigenvalues: they are irrational in general and enter as decimals "
                         "(16 significant digits); the solutions are exact for those decimals")
        else:
            exact_data = True
        if len(set(lam_q)) < m:
            raise InputError("exact solutions: with fewer than all eigenvalues, the measured eigenvalues must be distinct")
        eqs = [sp.expand((K - v * M).det(method="berkowitz")) for v in lam_q]
        method = "det(K - λ_i M) = 0 at each measured eigenvalue, Gröbner basis (grevlex, FGLM to lex)"
    eqs = [e for e in eqs if e != 0]
    equations = [str(e.subs(dict(zip(syms, sp.symbols(names))))) for e in eqs]
    if not eqs:
        return ExactSolutionSet(names, lam_num, [], [], None, False, exact_data, equations, method,
                                notes + ["every equation holds identically: the eigenvalues do not depend on the unknowns"])
    gens, subs, h = _solve_system(eqs, syms)
    if gens is None:
        notes.append(f"the equations leave a continuum of solutions ({m} eigenvalue equations for {L} unknowns "
                     "or dependent equations): the parameters are not identifiable from these eigenvalues")
        return ExactSolutionSet(names, lam_num, [], [], None, False, exact_data, equations, method, notes)
    last = gens[-1]
    n_complex = 0 if h.degree() <= 0 else int(sp.Poly(sp.sqf_part(h.as_expr()), last).degree())
    roots = [] if h.degree() <= 0 else sorted(set(h.real_roots()), key=lambda r: float(sp.N(r, 30)))
    lo, hi = model.bounds
    idx = np.array([model.parameter_index(n) for n in names])
    good: list[ExactSolution] = []
    rejected: list[ExactSolution] = []
    for r in roots:
        exact_vals = {}
        for s in syms:
            v = r if s == last else subs[s].subs(last, r)
            exact_vals[s] = sp.nsimplify(v) if getattr(v, "is_Rational", False) else v
        vals = np.array([float(sp.N(exact_vals[s], 30)) for s in syms])
        p = p_values.copy()
        p[idx] = vals
        within = bool(np.all((vals >= lo[idx]) & (vals <= hi[idx]))) if bounds else True
        Kn, Mn = model.K(p).toarray(), model.M(p).toarray()
        physical = bool(np.all(np.linalg.eigvalsh(Mn) > 0))
        ev = eigh(Kn, Mn, eigvals_only=True) if physical else np.full(N, np.nan)
        physical = physical and bool(ev[0] >= -1e-12 * max(abs(ev[-1]), 1e-300))
        lowest = physical and bool(np.allclose(ev[:m], lam_num, rtol=EIG_RTOL, atol=0))
        rational = all(v.is_Rational for v in exact_vals.values())
        sol = ExactSolution(
            parameters=dict(zip(names, map(float, vals))),
            exact={n: (str(exact_vals[s]) if exact_vals[s].is_Rational else str(sp.N(exact_vals[s], 30)))
                   for n, s in zip(names, syms)},
            rational=rational, within_bounds=within, physical=physical, lowest_modes=lowest, eigenvalues=ev)
        (good if sol.valid else rejected).append(sol)
    good.sort(key=lambda x: tuple(x.parameters.values()))
    rejected.sort(key=lambda x: tuple(x.parameters.values()))
    return ExactSolutionSet(names, lam_num, good, rejected, n_complex, True, exact_data, equations, method, notes)


__all__ = ["MAX_DOFS", "MAX_PARAMETERS", "ExactSolution", "ExactSolutionSet", "exact_solutions"]
