r"""Direct joint identification from complete data of several configurations.

Eqs. 4-10 of the paper stacked over the configurations: each configuration contributes its own
rows :math:`\sum_j p_j (K_j - \lambda M_j)\phi = (\lambda M_{f,c} - K_{f,c})\phi` to one system
:math:`A p = b`, solved by the pseudo-inverse (eq. 10).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..._errors import InputError
from ...direct import INFO_TOL, EquationBuilder, LinearSystem, frf_equations, modal_equations, solve_system, static_equations
from ...model import Model
from .configurations import Configuration, check_unknowns, config_values, prepare
from .results import MultiConfigResult, conditioning


def direct_configurations(model: Model, configurations: Sequence[Configuration], *, unknowns: Sequence[str] | None = None,
                          values=None, use: Sequence[str] = ("modes", "frf", "static"), bounded: bool = False) -> MultiConfigResult:
    """Direct (linear) joint identification from complete data of several configurations.

    Each configuration's equations (paper eqs. 4-9 for modes, 24-28 for FRF lines, static
    equilibrium) are built on its own model and stacked into one system whose columns are the
    unknowns; it is solved by the pseudo-inverse (eq. 10) or, with ``bounded``, by bounded least
    squares.  A configuration may see only some of the unknowns (its other columns are zero); a
    parameter no configuration's data strain is refused by name.

    Parameters
    ----------
    model : Model
        The baseline (unmodified) model; its values give the known parameters.
    configurations : sequence of Configuration
        Data at *every* dof of each configuration's model.
    unknowns : sequence of str, optional
        Names to identify (default every parameter not ``fixed``).
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Parameter values of the known parameters (default nominal); each configuration's
        modification overrides its own.
    use : sequence of str, default ``("modes", "frf", "static")``
        Kinds of data to stack.
    bounded : bool, default False
        Honour the parameters' bounds (bounded least squares instead of the pseudo-inverse).

    Returns
    -------
    MultiConfigResult
        ``method`` ``"direct"``; ``success`` whether the least-squares solution is unique;
        ``conditioning`` compares each configuration alone with the configurations stacked
        (columns scaled by their norms over all configurations); ``direct`` the
        :class:`~femupdate.direct.DirectResult`.

    Raises
    ------
    InputError
        Invalid unknowns or configurations (:func:`~.configurations.prepare`); an unknown data
        kind; a configuration without complete data; an unknown no configuration's data carry
        information on; fewer equations than unknowns or homogeneous equations.
    NumericalError
        The bounded solve failed.
    """
    names = check_unknowns(model, unknowns)
    kinds = set(use)
    bad = kinds - {"modes", "frf", "static"}
    if bad:
        raise InputError(f"unknown data kind(s) {sorted(bad)}: use modes, frf, static")
    cms = prepare(model, configurations, names)
    col = {n: k for k, n in enumerate(names)}
    blocks, rhs, rows_desc, per, notes = [], [], [], [], []
    info = np.zeros(len(names))
    for c, cmc in zip(configurations, cms):
        cm = cmc.model
        mine = [n for n in names if n in cm.parameter_names]
        b = EquationBuilder(cm, config_values(model, cm, c.modification, values), mine)
        cnotes: list[str] = []
        if "modes" in kinds and c.data.modes:
            modal_equations(b, c.data.modes, cnotes)
        if "frf" in kinds:
            for fs in c.data.frf_sets:  # one set per excitation
                frf_equations(b, fs)
        if "static" in kinds and c.data.static:
            static_equations(b, c.data.static)
        notes += [f"{c.label}: {x}" for x in cnotes]
        if not b.cols:
            raise InputError(f"configuration {c.label!r}: no complete data to build direct equations from "
                             "(need mode shapes, FRFs or static deflections at every dof of its model)")
        A_c = np.vstack(b.cols)
        full = np.zeros((A_c.shape[0], len(names)))
        full[:, [col[n] for n in mine]] = A_c
        blocks.append(full)
        rhs.append(np.concatenate(b.rhs))
        rows_desc += [(f"{c.label}: {d}", k) for d, k in b.blocks]
        info[[col[n] for n in mine]] = np.maximum(info[[col[n] for n in mine]], b.info)
        per.append({"name": c.label, "modification": c.modification.describe(), "n_equations": int(A_c.shape[0]),
                    "n_data": int(A_c.shape[0]), "unknowns_seen": mine, "dropped": list(cmc.dropped)})
    blind = [names[i] for i in np.flatnonzero(info < INFO_TOL)]
    if blind:
        raise InputError(
            f"direct solve: no configuration's data carry information on parameter(s) {', '.join(blind)}; "
            "fix them or add data that strain their elements"
        )
    A = np.vstack(blocks)
    system = LinearSystem(A, np.concatenate(rhs), tuple(names), rows_desc)
    res = solve_system(model, system, values, bounded, notes)
    scale = np.linalg.norm(A, axis=0)
    cond = conditioning([B / scale for B in blocks], names, [c.label for c in configurations])
    from .record import attach

    return attach(MultiConfigResult(
        method="direct", parameters=res.parameters, names=tuple(names), x=res.x, success=bool(res.unique),
        message="unique least-squares solution" if res.unique else (res.notes[-1] if res.notes else "not unique"),
        configurations=per, conditioning=cond, standard_error=res.standard_error, direct=res, notes=res.notes,
    ), model, "update-multi")
