r"""A :class:`~femupdate.Model` from probes of an external code.

Around a centre :math:`c` (the nominal values first) with steps :math:`s_j` (``step`` × :math:`|c_j|`),
the code runs at :math:`c` and at :math:`c + t\,s_j e_j` for :math:`t = 1, -1, 2, -2, \dots` (``degree``
points a parameter).  A parameter is **affine** when the second difference along its axis, and its
changes at ``checks`` random points within ``spread`` × :math:`|c_j|` of the centre (inside the
bounds), agree with the straight line through :math:`c \pm s_j e_j` to ``affine_tol`` (relative to the
largest entry of K, and of M): then :math:`\partial K / \partial p_j` is the central difference,
exact.  Otherwise its matrices are a polynomial of degree ``degree`` in :math:`(p_j - c_j)/s_j`,
interpolated through the probes (exact at the centre), and enter the model as terms with
:class:`~femupdate.coefficients.Polynomial` coefficients.  At each random point the run of the code
must equal the sum of each parameter's own change (each run on its axis): parameters that interact
(a product E·h³ of two parameters) are refused by name.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from math import comb

import numpy as np
import scipy.sparse as sp

from .._errors import InputError
from ..coefficients import Polynomial, Term
from ..model import Model, Parameter
from .runs import Cache, Command, Function, Run, run_all, shown_values


@dataclass(frozen=True)
class ProbeOptions:
    """How a black box is probed and its fitted model checked (module docstring).

    Parameters
    ----------
    degree : int
        Degree of the polynomial of a non-affine parameter (1 to 4).
    step : float
        Probe step, relative to the parameter's value (absolute for a value of 0).
    spread : float
        Half-width of the box of random check points, relative to the values.
    checks : int
        Random points of the affinity and interaction check (0: none).
    affine_tol : float
        Relative agreement that makes a parameter affine (default 1e-8: matrices written with at
        least ten significant digits).
    tolerance : float
        Relative agreement, in the paired frequencies and the matrices, between a run of the code
        at the updated values and the fitted model there (default 1e-6).
    rounds : int
        Re-probings near the solution before the update is given up.
    seed : int
        Seed of the random check points (the same points, so the same cached runs, every time).
    """

    degree: int = 2
    step: float = 0.05
    spread: float = 0.2
    checks: int = 2
    affine_tol: float = 1e-8
    tolerance: float = 1e-6
    rounds: int = 8
    seed: int = 0

    def __post_init__(self):
        def number(name, lo, hi, integer=False):
            v = getattr(self, name)
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and (not integer or float(v).is_integer())
            if not ok or not (lo <= v <= hi) or (not integer and not math.isfinite(v)):
                raise InputError(f"black box: {name} must be {'an integer' if integer else 'a number'} in "
                                 f"[{lo:g}, {hi:g}], got {v!r}")

        number("degree", 1, 4, True)
        number("step", 1e-8, 0.5)
        number("spread", 0.0, 0.9)
        number("checks", 0, 50, True)
        number("affine_tol", 1e-15, 1e-2)
        number("tolerance", 1e-14, 1e-1)
        number("rounds", 1, 50, True)
        number("seed", 0, 2**32 - 1, True)


@dataclass
class BlackBox:
    """An external code (a :class:`~femupdate.blackbox.Command` or :class:`~femupdate.blackbox.Function`)
    and the parameters it takes.

    Parameters
    ----------
    runner : Command or Function
    parameters : sequence of Parameter
        Names, nominal values (the first centre) and bounds (probes and updates stay inside).
    name : str
        The model's name.
    cache : Cache, optional
        Finished runs (:class:`~femupdate.blackbox.Cache`; a folder keeps them between sessions).
    jobs : int
        Local worker processes for the runs.
    scheduler : str, optional
        A Dask scheduler's address: the runs go there.
    options : ProbeOptions
    connect_timeout : float
        Seconds to wait for the scheduler and its workers.
    """

    runner: Command | Function
    parameters: tuple
    name: str = "black box"
    cache: Cache = field(default_factory=Cache)
    jobs: int = 1
    scheduler: str | None = None
    options: ProbeOptions = field(default_factory=ProbeOptions)
    connect_timeout: float = 30.0

    def __post_init__(self):
        self.parameters = tuple(self.parameters)
        bad = [p for p in self.parameters if not isinstance(p, Parameter)]
        if bad or not self.parameters:
            raise InputError(f"black box: parameters must be a non-empty list of Parameter, got {self.parameters!r}")
        self.runner.check_placeholders(self.names)
        if isinstance(self.jobs, bool) or not isinstance(self.jobs, int) or self.jobs < 1:
            raise InputError(f"black box: jobs must be a positive integer, got {self.jobs!r}")
        self.first: Run | None = None
        self.first_values: dict | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in declaration order."""
        return tuple(p.name for p in self.parameters)

    def run(self, points) -> list[Run]:
        """Runs at ``points`` (arrays of values in declaration order), each on the first run's dofs."""
        batch = [dict(zip(self.names, map(float, x))) for x in points]
        runs = run_all(self.runner, batch, self.cache, self.jobs, self.scheduler, self.connect_timeout)
        for values, r in zip(batch, runs):
            if self.first is None:
                self.first, self.first_values = r, values
            elif r.dofs != self.first.dofs:
                a, b = self.first.dofs, r.dofs
                if len(a) != len(b):
                    why = f"{len(b)} dofs where the run at {shown_values(self.first_values or {})} gave {len(a)}"
                else:
                    i = next(i for i, (x, y) in enumerate(zip(a, b)) if x != y)
                    why = f"dof {b[i]} in position {i + 1} where the run at {shown_values(self.first_values or {})} had {a[i]}"
                raise InputError(f"the black-box run at {shown_values(values)} gave {why}: the code's dofs (matrix size "
                                 "and order) must not change with the parameters")
        return runs


def _steps(box: BlackBox, center: np.ndarray, wanted: np.ndarray | None = None) -> np.ndarray:
    """The probe steps: ``wanted`` (default ``step`` × |value|), shortened so that every probe
    (up to ±2 steps for degree 3 and 4) stays inside the bounds."""
    s = box.options.step * np.where(center != 0, np.abs(center), 1.0) if wanted is None else wanted
    lo, hi = (np.array([p.bounds[k] for p in box.parameters]) for k in (0, 1))
    room = np.minimum(center - lo, hi - center) / np.abs(_offsets(box.options.degree)).max()
    if np.any(room <= 0):
        j = int(np.flatnonzero(room <= 0)[0])
        raise InputError(f"black box: parameter {box.names[j]!r} = {center[j]:g} lies on its bound: no room to probe "
                         "on both sides")
    return np.minimum(s, room)


def _offsets(degree: int) -> np.ndarray:
    return np.array([1, -1, 2, -2][:degree], dtype=float)


def _rel(A, B, scale: float) -> float:
    D = sp.csr_array(A - B)
    return float(np.abs(D.data).max() / scale) if D.nnz else 0.0


@dataclass(frozen=True)
class Probed:
    """What probing found: the model, the centre, steps, which parameters are affine, the check."""

    model: Model
    center: dict
    steps: dict
    affine: dict
    deviation: dict
    runs: int


def probe_model(box: BlackBox, center: Mapping[str, float] | None = None, steps=None) -> Probed:
    """The fitted model of ``box`` around ``center`` (default: nominal values) (module docstring).

    Returns
    -------
    Probed

    Raises
    ------
    InputError
        A failing run (its command and output named), a run without its files, matrices whose size
        or dofs change between runs, NaN, parameters that interact.
    """
    names, opt = box.names, box.options
    c = np.array([p.value for p in box.parameters]) if center is None else np.array([float(center[n]) for n in names])
    s = _steps(box, c, None if steps is None else np.array([float(steps[n]) for n in names]))
    n, t = len(names), _offsets(opt.degree)
    runs_before = box.cache.runs
    axis = [c] + [c + tk * s[j] * np.eye(n)[j] for j in range(n) for tk in t]
    got = box.run(axis)
    R0 = got[0]
    scaleK = float(np.abs(R0.K.data).max()) if R0.K.nnz else 1.0
    scaleM = float(np.abs(R0.M.data).max()) if R0.M.nnz else 1.0
    on_axis = {j: got[1 + j * len(t): 1 + (j + 1) * len(t)] for j in range(n)}
    slope = {j: ((on_axis[j][0].K - on_axis[j][1].K) / (2 * s[j]), (on_axis[j][0].M - on_axis[j][1].M) / (2 * s[j]))
             for j in range(n)} if opt.degree >= 2 else \
        {j: ((on_axis[j][0].K - R0.K) / s[j], (on_axis[j][0].M - R0.M) / s[j]) for j in range(n)}
    idle = [names[j] for j in range(n) if all(_rel(r.K, R0.K, 1.0) == 0 and _rel(r.M, R0.M, 1.0) == 0
                                                for r in on_axis[j])]
    if idle:
        hint = f" (is {{{idle[0]}}} in the command?)" if isinstance(box.runner, Command) else ""
        raise InputError(f"black box {box.name!r}: the code's matrices do not change with parameter(s) "
                         f"{', '.join(idle)}{hint}")
    dev = {j: 0.0 for j in range(n)}
    for j in range(n):
        for tk, r in zip(t, on_axis[j]):
            dev[j] = max(dev[j], _rel(r.K, R0.K + tk * s[j] * slope[j][0], scaleK),
                         _rel(r.M, R0.M + tk * s[j] * slope[j][1], scaleM))
    rng = np.random.default_rng(opt.seed)
    lo, hi = (np.array([p.bounds[k] for p in box.parameters]) for k in (0, 1))
    half = opt.spread * np.where(c != 0, np.abs(c), 1.0)
    pts = np.clip(c + rng.uniform(-1, 1, (opt.checks, n)) * half, lo, hi)
    checks = box.run([q for x in pts for q in [x] + [c + (x[j] - c[j]) * np.eye(n)[j] for j in range(n)]])
    for i, x in enumerate(pts):
        whole, parts = checks[i * (n + 1)], checks[i * (n + 1) + 1:(i + 1) * (n + 1)]
        for j, r in enumerate(parts):
            dev[j] = max(dev[j], _rel(r.K, R0.K + (x[j] - c[j]) * slope[j][0], scaleK),
                         _rel(r.M, R0.M + (x[j] - c[j]) * slope[j][1], scaleM))
        sumK = R0.K + sum((r.K - R0.K for r in parts), sp.csr_array(R0.K.shape))
        sumM = R0.M + sum((r.M - R0.M for r in parts), sp.csr_array(R0.M.shape))
        joint = max(_rel(whole.K, sumK, scaleK), _rel(whole.M, sumM, scaleM))
        if joint > opt.affine_tol and n > 1:
            raise InputError(f"black box {box.name!r}: the parameters interact: at {shown_values(dict(zip(names, x)))} "
                             f"the code's matrices differ from the sum of each parameter's own change by {joint:.3g} "
                             f"(relative; affine_tol {opt.affine_tol:g}); a product such as E*h^3 of two parameters "
                             "is not separable: keep one of them fixed, or make the product one parameter")
    affine = {names[j]: dev[j] <= opt.affine_tol for j in range(n)}
    model = _build(box, c, s, R0, slope, on_axis, affine)
    return Probed(model, dict(zip(names, c.tolist())), dict(zip(names, s.tolist())), affine,
                  {names[j]: dev[j] for j in range(n)}, box.cache.runs - runs_before)


def _chop(A, scale: float):
    A = sp.csr_array((A + A.T) / 2)
    A.data[np.abs(A.data) <= 1e-13 * scale] = 0.0
    A.eliminate_zeros()
    return A if A.nnz else None


def _shifted_power(c: float, s: float, d: int) -> tuple[float, ...]:
    """Coefficients in rising powers of p of ((p - c) / s) ** d."""
    return tuple(comb(d, i) * (-c) ** (d - i) / s**d for i in range(d + 1))


def _build(box: BlackBox, c, s, R0: Run, slope, on_axis, affine) -> Model:
    names, t = box.names, _offsets(box.options.degree)
    scaleK = float(np.abs(R0.K.data).max()) if R0.K.nnz else 1.0
    scaleM = float(np.abs(R0.M.data).max()) if R0.M.nnz else 1.0
    K0, M0 = sp.csr_array(R0.K), sp.csr_array(R0.M)
    dK: list = [None] * len(names)
    dM: list = [None] * len(names)
    terms = []
    V = np.vander(t, len(t) + 1, increasing=True)[:, 1:]  # t^1 .. t^D at each offset
    W = np.linalg.inv(V)
    for j, name in enumerate(names):
        if affine[name]:
            dK[j], dM[j] = _chop(slope[j][0], scaleK / s[j]), _chop(slope[j][1], scaleM / s[j])
            K0 = K0 - c[j] * (dK[j] if dK[j] is not None else 0 * K0)
            M0 = M0 - c[j] * (dM[j] if dM[j] is not None else 0 * M0)
            continue
        for d in range(1, len(t) + 1):
            Kd = sum((W[d - 1, i] * (r.K - R0.K) for i, r in enumerate(on_axis[j])), sp.csr_array(R0.K.shape))
            Md = sum((W[d - 1, i] * (r.M - R0.M) for i, r in enumerate(on_axis[j])), sp.csr_array(R0.M.shape))
            Kd, Md = _chop(Kd, scaleK), _chop(Md, scaleM)
            if Kd is not None or Md is not None:
                terms.append(Term((Polynomial(name, _shifted_power(float(c[j]), float(s[j]), d)),), K=Kd, M=Md))
    try:
        return Model(R0.dofs, K0, M0, box.parameters, tuple(dK), tuple(dM), name=box.name, terms=tuple(terms))
    except InputError as exc:
        raise InputError(f"black box {box.name!r}: the matrices of its runs: {exc}") from None


__all__ = ["BlackBox", "ProbeOptions", "Probed", "probe_model"]
