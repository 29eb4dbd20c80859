r"""Counting criteria for unique identification from modal data (paper eqs. 13-15, 18 and Summary).

For a measurement plan of ``n`` measured dofs and ``m`` measured modes, ``L`` unknown parameters
and a model of ``N`` dofs, each criterion counts something different:

``jung_ewins_lin`` — eq. 13, :math:`m(n+1) \ge L` (Jung & Ewins 1992; Lin 1993)
    the number of rows of the sensitivity matrix (eq. 18): one eigenvalue and ``n`` shape entries
    per mode.  A necessary condition for the rank of S to reach L — but it counts the shape
    entries as if they had an absolute scale, which they do not.
``botto_data`` — eq. 14, :math:`mn > L` (Botto et al. 1993)
    the measured shape entries, required to *exceed* L.
``botto_modes`` — eq. 15, :math:`\tfrac m2\,(2N-(m+1)) > L` (Botto et al. 1993)
    :math:`mN - m(m+1)/2`: the number of free entries of m complete (N-component) mode shapes
    once their :math:`m(m+1)/2` mass-orthonormality conditions are removed.  Botto et al.
    require eqs. 14 and 15 together (``botto``).
``data_count`` — :math:`mn \ge L`
    the number of *independent* data: per mode the eigenvalue plus ``n − 1`` shape ratios (one
    entry is lost to the arbitrary scaling).  The paper's "obvious criterion" — necessary, and
    shown by its two-dof example not to be sufficient.
``paper`` — :math:`mn \ge L` and :math:`n > 1` (the paper's Summary)
    the data count, plus at least two sensors, suggested by the paper's 6-dof simulation.

None of these is sufficient in general: the Monte Carlo study (:mod:`femupdate.uniqueness.study`)
and the exact solution sets (:mod:`femupdate.uniqueness.exact`) give the true answer for a model.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._checks import count_arg
from .._errors import InputError

#: criterion name -> (paper equation, formula, what is counted)
CRITERIA = {
    "jung_ewins_lin": ("13", "m(n+1) >= L", "rows of the sensitivity matrix: one eigenvalue and n shape entries per mode"),
    "botto_data": ("14", "mn > L", "measured shape entries, strictly more than the unknowns"),
    "botto_modes": ("15", "m/2 (2N - (m+1)) > L",
                    "free entries of m complete mass-orthonormal mode shapes: mN - m(m+1)/2"),
    "botto": ("14 and 15", "mn > L and m/2 (2N - (m+1)) > L", "Botto et al. require both"),
    "data_count": ("18 (text)", "mn >= L", "independent data: per mode the eigenvalue and n - 1 shape ratios"),
    "paper": ("Summary", "mn >= L and n > 1", "the data count and at least two sensors (the paper's 6-dof finding)"),
}


@dataclass(frozen=True)
class CriterionCount:
    """One criterion for one plan: the counted quantity, the threshold and the verdict.

    Built by :func:`counting_criteria`; each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    name : str
        Criterion name, a key of :data:`CRITERIA`.
    equation : str
        The paper's equation number (``"13"``, ``"14 and 15"``, ``"Summary"``, ...).
    formula : str
        The criterion, e.g. ``"mn >= L"``.
    count : float
        The counted quantity (for ``botto``, the smaller of the two counts).
    threshold : int
        L, the number of unknown parameters.
    satisfied : bool
        The criterion predicts a unique solution.
    """

    name: str
    equation: str
    formula: str
    count: float
    threshold: int
    satisfied: bool


def counting_criteria(n: int, m: int, L: int, N: int) -> dict[str, CriterionCount]:
    """Every criterion of :data:`CRITERIA` for one measurement plan (paper eqs. 13-15, 18, Summary).

    Parameters
    ----------
    n : int
        Number of measured dofs (>= 1, at most ``N``).
    m : int
        Number of measured modes (>= 1, at most ``N``).
    L : int
        Number of unknown parameters (>= 1).
    N : int
        Number of model dofs (>= 1).

    Returns
    -------
    dict of str to CriterionCount
        Per criterion name; ``satisfied``: the criterion predicts a unique solution.

    Raises
    ------
    InputError
        An argument that is not an integer >= 1, or ``n`` or ``m`` above ``N``.
    """
    for what, v in (("n (measured dofs)", n), ("m (measured modes)", m), ("L (unknown parameters)", L),
                    ("N (model dofs)", N)):
        count_arg(v, what, "counting_criteria")
    if n > N or m > N:
        raise InputError(f"counting criteria: n = {n} and m = {m} cannot exceed the model's N = {N} dofs")
    eq15 = m * (2 * N - (m + 1)) / 2
    counts = {
        "jung_ewins_lin": (m * (n + 1), m * (n + 1) >= L),
        "botto_data": (m * n, m * n > L),
        "botto_modes": (eq15, eq15 > L),
        "botto": (min(m * n, eq15), m * n > L and eq15 > L),
        "data_count": (m * n, m * n >= L),
        "paper": (m * n, m * n >= L and n > 1),
    }
    return {k: CriterionCount(k, CRITERIA[k][0], CRITERIA[k][1], c, L, bool(ok)) for k, (c, ok) in counts.items()}


def criteria_verdicts(n: int, m: int, L: int, N: int) -> dict[str, bool]:
    """Verdict of every counting criterion (the ``criteria`` of ``femupdate uniqueness``).

    Parameters
    ----------
    n, m, L, N : int
        Measured dofs, measured modes, unknown parameters and model dofs, as :func:`counting_criteria`.

    Returns
    -------
    dict of str to bool
        {criterion name: predicts a unique solution}.

    Raises
    ------
    InputError
        As :func:`counting_criteria`.
    """
    return {k: c.satisfied for k, c in counting_criteria(n, m, L, N).items()}


__all__ = ["CRITERIA", "CriterionCount", "counting_criteria", "criteria_verdicts"]
