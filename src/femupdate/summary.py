r"""What a model holds (``femupdate summary``): dofs, elements by type, sets, parameters, mass and
each parameter matrix's share of the stiffness.

* **Mass.** The rigid-body translation mass along each axis, :math:`m_d = r_d^T M r_d` with
  :math:`r_d` = 1 at every translation dof along d and 0 elsewhere (the kinetic energy of a unit
  rigid translation, doubled).  ``free``: over the model's free dofs (mass at supported dofs is
  left out); ``total``: a structure's mass with its supports removed — its elements' masses and
  lumped masses added, as :math:`\sum_e r^T M_e r`; ``by_type`` splits it by element type.  A
  structure's mass is the same along every axis its elements move in.
* **Stiffness shares**, two measures, at the parameter values used:

  - ``trace``: :math:`f_j(p)\,\mathrm{tr}(K_j)/\mathrm{tr}(K(p))` — the term's part of the
    diagonal of K, one number per term, independent of the modes (mixes units where dofs do:
    translations and rotations);
  - ``energy``: the modal strain energy fraction :math:`f_j(p)\,\phi_r^T K_j \phi_r/\lambda_r`
    in each of the first flexible modes r (mass-normalised, :math:`\phi_r^T K \phi_r =
    \lambda_r`): how much the mode's frequency depends on the term — the relative eigenvalue
    sensitivity of an affine term, :math:`(p_j/\lambda_r)\,\partial\lambda_r/\partial p_j`.

  The shares of all terms, ``K0`` included, add up to 1.
"""

from __future__ import annotations

import copy
import re
from collections import Counter

import numpy as np

from .dofs import DIRECTIONS, parse_dof

SET_NAME = re.compile(r"set ('(?:[^']*)'|\"(?:[^\"]*)\")\)?$")
RIGID = 1e-6  # eigenvalues below this fraction of the largest computed are rigid-body modes


def _translation_masses(M, dofs) -> dict[str, float]:
    dirs = np.array([parse_dof(d)[1] for d in dofs])
    out = {}
    for d in DIRECTIONS[:3]:
        r = (dirs == d).astype(float)
        if r.any():
            out[d] = float(r @ (M @ r))
    return out


def _parameters_used(groups) -> set[str]:
    return {v for g in groups for vals in g.props.values() for v in vals if isinstance(v, str)}


def _structure_masses(structure, values: dict[str, float]) -> tuple[dict, dict]:
    """Mass along each axis of the whole structure (supports removed), and by element type."""
    def mass_of(groups):
        s = copy.copy(structure)
        s.groups, s.supports, s.support_nodes = list(groups), [], []
        used = _parameters_used(groups)
        s.parameters = {k: v for k, v in structure.parameters.items() if k in used}
        m = s.build()
        return _translation_masses(m.M({k: values[k] for k in m.parameter_names}), m.dofs)

    total = mass_of(structure.groups)
    by_type = {t: mass_of([g for g in structure.groups if g.type == t])
               for t in dict.fromkeys(g.type for g in structure.groups)}
    return total, by_type


def _elements(structure) -> tuple[dict[str, int], dict[str, int]]:
    types: Counter = Counter()
    sets: Counter = Counter()
    for g in structure.groups:
        n = len(g.labels)
        types[g.type] += n
        for w in g.where:
            hit = SET_NAME.search(w)
            if hit:
                sets[hit.group(1)[1:-1]] += 1
    return dict(types), dict(sets)


def _terms(model, p):
    """(name, coefficient, K matrix) of K0, every parameter's dK and every non-linear term's K."""
    out = [("K0", 1.0, model.K0)]
    for j, prm in enumerate(model.parameters):
        if model.dK[j] is not None and model.dK[j].nnz:
            out.append((prm.name, float(p[j]), model.dK[j]))
    named = dict(zip(model.parameter_names, p.tolist()))
    for t in model.terms:
        if t.K is not None:
            out.append((t.describe(), float(t.value(named)), t.K))
    return out


def stiffness_shares(model, values=None, n_modes: int = 3) -> dict:
    """Each stiffness term's share: ``{"trace": {term: share}, "energy": {term: [share per mode]},
    "modes": [mode numbers], "frequencies_hz": [...]}`` (module docstring).

    Parameters
    ----------
    model : Model
    values : mapping or array_like, optional
        Parameter values (default nominal).
    n_modes : int, default 3
        Flexible modes whose strain energy is split.
    """
    from .modal import model_modes

    p = model.resolve(values)
    terms = _terms(model, p)
    K = model.K(p)
    tr = float(K.diagonal().sum())
    trace = {name: c * float(A.diagonal().sum()) / tr for name, c, A in terms}
    modes = model_modes(model, p, n_modes=min(model.n_dofs, n_modes + 6))
    lam = modes.eigenvalues
    flexible = [r for r in range(len(lam)) if lam[r] > RIGID * max(float(np.max(np.abs(lam))), 1e-300)][:n_modes]
    energy = {}
    for name, c, A in terms:
        energy[name] = [c * float(modes.shapes[:, r] @ (A @ modes.shapes[:, r])) / float(lam[r]) for r in flexible]
    return {"trace": trace, "energy": energy, "modes": [r + 1 for r in flexible],
            "frequencies_hz": [float(modes.frequencies_hz[r]) for r in flexible]}


def model_summary(model, structure=None, values=None, n_modes: int = 3) -> dict:
    """What ``model`` holds, as a JSON-ready dict (module docstring).

    Parameters
    ----------
    model : Model
    structure : Structure, optional
        The structure ``model`` was built from (elements, sets, total mass); None for a
        matrices model.
    values : mapping or array_like, optional
        Parameter values (default nominal).
    n_modes : int, default 3
        Flexible modes of the strain-energy shares.

    Returns
    -------
    dict
        ``kind`` (``"summary"``), ``schema_version``, ``name``, ``n_dofs``, ``dofs_by_direction``,
        ``n_nodes``, ``elements`` (by type),
        ``sets`` (elements per set), ``parameters`` (name, value, unit, bounds — None where
        unbounded —, fixed, enters: ``K``, ``M`` and the non-linear terms it is a factor of),
        ``mass`` (``free``, ``total``, ``by_type``; kg along x, y, z), ``stiffness_shares``.
    """
    p = model.resolve(values)
    dirs = Counter(parse_dof(d)[1] for d in model.dofs)
    used_nodes = {parse_dof(d)[0] for d in model.dofs}
    in_terms = {x: [t.describe() for t in model.terms if x in t.parameters] for x in model.parameter_names}
    params = []
    for j, prm in enumerate(model.parameters):
        enters = [m for m, A in (("K", model.dK[j]), ("M", model.dM[j])) if A is not None and A.nnz]
        bounds = [b if np.isfinite(b) else None for b in prm.bounds]
        params.append({"name": prm.name, "value": float(p[j]), "unit": prm.unit, "bounds": bounds,
                       "fixed": prm.fixed, "enters": enters + in_terms[prm.name]})
    from .serialise import SCHEMA_VERSION

    out = {"kind": "summary", "schema_version": SCHEMA_VERSION, "name": model.name, "n_dofs": model.n_dofs,
           "dofs_by_direction": dict(dirs), "n_nodes": len(used_nodes),
           "elements": {}, "sets": {}, "parameters": params,
           "mass": {"free": _translation_masses(model.M(p), model.dofs), "total": None, "by_type": None}}
    if structure is not None:
        out["elements"], out["sets"] = _elements(structure)
        vals = dict(zip(model.parameter_names, map(float, p)))
        out["mass"]["total"], out["mass"]["by_type"] = _structure_masses(structure, vals)
    out["stiffness_shares"] = stiffness_shares(model, p, n_modes)
    return out


__all__ = ["model_summary", "stiffness_shares"]
