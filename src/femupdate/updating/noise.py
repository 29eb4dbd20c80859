"""The noise of an updating problem's residuals, block by block (:mod:`femupdate.variance`).

:func:`layout` splits a problem's residual vector into the blocks whose noise is stated or
estimated apart: per test mode its eigenvalue residual and its shape residuals (kinds
``eigenvalue`` and ``shape``; the dynamic formulation's residual per mode, kind ``dynamic``), the
FRF residuals of each excitation (``frf``), each static case (``static``).  A block is *stated*
when its residuals are divided by standard deviations — from the test data file (``std_frequency``,
``std_shape``) or given as options (``--std-eigenvalue``, ``--std-shape``, ``--std-frf``,
``--std-static``; ``measurement_std``) — and *estimated* otherwise; :class:`NoiseOptions`
``basis="estimate"`` estimates every block (a stated one: a factor on its stated deviations).

:func:`analyse` estimates the components by REML at the solution
(:func:`femupdate.variance.variance_components`; one eigenvalue per mode has no redundancy, so the
eigenvalues of all modes are pooled into one component) and tests the fit
(:func:`femupdate.variance.fit_test`): χ² against the stated blocks, and a plausibility bound on
the estimated ones — a relative frequency noise above :data:`PLAUSIBLE_FREQUENCY_STD`, or a shape
noise above :data:`PLAUSIBLE_SHAPE_STD` of the test shape's RMS entry, is more than a vibration
test gives: the model cannot reproduce the data.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..variance import ALPHA, FitTest, VarianceComponents, fit_test, variance_components

#: relative standard deviation of a measured natural frequency above which an estimated
#: eigenvalue noise is implausible for a vibration test (model error instead): 2 %
PLAUSIBLE_FREQUENCY_STD = 0.02
#: standard deviation of a scaled shape entry, as a fraction of the test shape's RMS entry, above
#: which an estimated shape noise is implausible (MAC below about 0.96): 20 %
PLAUSIBLE_SHAPE_STD = 0.2

#: how a stated block's deviations came, as results name it
SOURCES = {"data": "stated in the data file", "given": "given as an option"}


@dataclass
class Layout:
    """The blocks of a residual vector: {label: rows}, their kinds, the degrees of freedom their
    own normalisation takes, the stated ones {label: ``"data"`` | ``"given"``} and plausible
    bounds {kind: σ in the residuals' units}."""

    blocks: dict = field(default_factory=dict)
    kinds: dict = field(default_factory=dict)
    lost: dict = field(default_factory=dict)
    stated: dict = field(default_factory=dict)
    plausible: dict = field(default_factory=dict)

    def add(self, other: Layout, offset: int, factor: float = 1.0) -> None:
        for lb, rows in other.blocks.items():
            self.blocks[lb] = np.asarray(rows) + offset
        self.kinds.update(other.kinds)
        self.lost.update(other.lost)
        self.stated.update(other.stated)
        for k, v in other.plausible.items():
            self.plausible[k] = max(self.plausible.get(k, 0.0), v * abs(factor))


def modal_layout(prob) -> Layout:
    """The blocks of a modal :class:`~femupdate.updating.Problem`: per test mode ``eigenvalue
    mode k`` and ``shape mode k`` (``dynamic mode k`` for the dynamic formulation)."""
    tg = prob.targets
    out = Layout()
    stated = getattr(prob, "stated_sources", {})
    row = 0
    dyn = prob.formulation == "dynamic"
    n_dofs = prob.model.n_dofs
    for k in range(tg.n_test):
        sl = tg.measured(k)
        ns = sl.stop - sl.start
        if dyn:
            lb = f"dynamic mode {k + 1}"
            out.blocks[lb], out.kinds[lb], out.lost[lb] = np.arange(row, row + n_dofs), "dynamic", n_dofs - ns
            if "eigenvalue" in stated:
                out.stated[lb] = stated["eigenvalue"]
            row += n_dofs
            continue
        lb = f"eigenvalue mode {k + 1}"
        out.blocks[lb], out.kinds[lb] = np.array([row]), "eigenvalue"
        if "eigenvalue" in stated:
            out.stated[lb] = stated["eigenvalue"]
        row += 1
        if ns:
            n = ns if prob.formulation == "mac" else int(ns - 1 if tg.ref[k] >= 0 else ns)
            lb = f"shape mode {k + 1}"
            out.blocks[lb], out.kinds[lb] = np.arange(row, row + n), "shape"
            out.lost[lb] = 0 if (tg.ref[k] >= 0 and prob.formulation != "mac") else 1
            if "shape" in stated:
                out.stated[lb] = stated["shape"]
            row += n
    if not dyn:
        out.plausible["eigenvalue"] = 2 * PLAUSIBLE_FREQUENCY_STD * float(np.sqrt(np.mean(tg.w_lam ** 2)))
        if tg.shaped.any() and prob.formulation == "shapes":
            rms = [float(np.sqrt(np.mean(tg.psi_e[tg.measured(k)] ** 2))) * float(tg.w_psi[k])
                   for k in np.flatnonzero(tg.shaped)]
            out.plausible["shape"] = PLAUSIBLE_SHAPE_STD * float(np.sqrt(np.mean(np.square(rms))))
    return out


def layout(prob, sigma) -> Layout:
    """The :class:`Layout` of any updating problem: modal, combined (block by block), or one block
    of the problem's kind (FRF, static, a multi-configuration problem), stated when ``sigma``."""
    from .combined import CombinedProblem
    from .problem import Problem

    if isinstance(prob, Problem):
        return modal_layout(prob)
    m = int(prob.n_residuals) if hasattr(prob, "n_residuals") else None
    if isinstance(prob, CombinedProblem):
        out = Layout()
        for b, a in zip(prob.blocks, prob.rows[:-1]):
            if isinstance(b.problem, Problem):
                out.add(modal_layout(b.problem), int(a), b.scale)
            else:
                n = int(prob.rows[list(prob.blocks).index(b) + 1] - a)
                out.blocks[b.label], out.kinds[b.label] = np.arange(a, a + n), b.kind
                n_ind = getattr(b.problem, "n_independent", None)
                if n_ind is not None:  # a damped modes block: each unit-length, phase-aligned
                    # complex shape takes two degrees of freedom (its norm and its phase)
                    out.lost[b.label] = n - int(n_ind)
                if b.weighting == "stated std":  # a damped modes block says where its deviations came from
                    srcs = set(getattr(b.problem, "stated", {}).values())
                    out.stated[b.label] = "data" if srcs == {"data"} else "given"
        return out
    kind = "frf" if hasattr(prob, "omega") else "residuals"
    out = Layout()
    out.blocks[kind] = slice(None) if m is None else np.arange(m)
    out.kinds[kind] = kind
    if sigma is not None:
        out.stated[kind] = "given"
    return out


def analyse(prob, S, r, sigma, basis: str = "auto", alpha: float = ALPHA) -> tuple[VarianceComponents, FitTest, Layout]:
    """The variance components of ``prob``'s residuals r at the solution and the fit's test.

    Parameters
    ----------
    prob : updating problem
    S : numpy.ndarray, shape ``(m, L)``
        The Jacobian over the parameters analysed (any column scaling; the covariance is in it).
    r : numpy.ndarray, shape ``(m,)``
    sigma : object or None
        The problem's stated deviations (not None: every residual is divided by one).
    basis : {"auto", "stated", "estimate"}
        ``"estimate"``: every block estimated (a stated one as a factor on its deviations).
    alpha : float
        Level of the fit's test.

    Returns
    -------
    vc : VarianceComponents
    test : FitTest
    layout : Layout
    """
    lay = layout(prob, sigma)
    m = r.size
    if lay.blocks and isinstance(next(iter(lay.blocks.values())), slice):
        lay.blocks = {k: np.arange(m)[v] for k, v in lay.blocks.items()}
    stated = set() if basis == "estimate" else set(lay.stated)
    vc = variance_components(S, r, lay.blocks, kinds=lay.kinds, stated=stated, lost=lay.lost)
    test = fit_test(vc, alpha=alpha, plausible=lay.plausible)
    return vc, test, lay


def basis_records(vc: VarianceComponents, lay_stated: dict) -> list[dict]:
    """The components' records with the source of each stated one (``source``:
    ``"stated in the data file"``, ``"given as an option"``, ``"estimated"``, ``"pooled"``,
    ``"not estimable"``)."""
    out = []
    for c in vc.components:
        rec = c.record()
        if c.basis == "stated":
            srcs = {lay_stated.get(mb, "given") for mb in c.members}
            rec["source"] = " and ".join(sorted(SOURCES[s] for s in srcs))
        else:
            rec["source"] = c.basis
        out.append(rec)
    return out


def basis_lines(noise: list[dict], method: str) -> list[str]:
    """One terminal line per noise component (the stated ones grouped by kind and source): what
    the standard deviations rest on."""
    out = []
    stated: dict = {}
    for c in noise:
        if c["basis"] == "stated":
            stated.setdefault((c["kind"], c.get("source", "stated")), []).append(c)
    for (kind, source), cs in stated.items():
        n = sum(c["n_residuals"] for c in cs)
        blocks = f", {len(cs)} blocks" if len(cs) > 1 else ""
        out.append(f"noise of {kind if len(cs) > 1 else cs[0]['label']} ({n} residuals{blocks}): {source}")
    for c in noise:
        if c["basis"] == "stated":
            continue
        what = f"{c['label']} ({c['n_residuals']} residuals"
        what += f", {len(c['members'])} blocks)" if len(c["members"]) > 1 else ")"
        if c["basis"] == "not estimable":
            out.append(f"noise of {what}: not estimable (redundancy {_f(c['redundancy'])}): the standard deviations "
                       "are not given")
        else:
            how = "pooled over its blocks, " if c["basis"] == "pooled" else ""
            out.append(f"noise of {what}: estimated from the fit, {how}std {_f(c['std'])} in the residuals' units, "
                       f"{_f(c['dof'])} dof")
    if any(c["basis"] in ("estimated", "pooled") for c in noise):
        out.append(f"estimated noise: {method}; the parameters' intervals are Student-t with their effective dof "
                   "(Satterthwaite)")
    return out


def model_error_line(record: dict) -> str:
    """The headline of a fit's test from its JSON record (:meth:`FitTest.record`); '' for none."""
    if not record:
        return ""
    nan = float("nan")

    def num(k):
        v = record.get(k)
        return nan if v is None else float(v)

    return FitTest(str(record.get("test", "none")), num("statistic"), num("dof"), num("p_value"),
                   float(record.get("alpha", ALPHA)), str(record.get("verdict", "untested")),
                   list(record.get("detail") or [])).headline()


def _f(v) -> str:
    return "-" if v is None else f"{v:.3g}"


__all__ = ["Layout", "layout", "modal_layout", "analyse", "basis_records", "basis_lines", "model_error_line", "PLAUSIBLE_FREQUENCY_STD",
           "PLAUSIBLE_SHAPE_STD", "SOURCES"]
