"""Nastran matrices: OUTPUT4 (``.op4``) files with the dof map of an OP2, and DMIG punch files.

Read through pyyeti (an optional dependency, ``pip install femupdate[nastran]``; imported here
only, when a Nastran file is read):

* **OP4** files written by ``OUTPUT4`` (or a DMAP such as nas2cam): the matrices are named in
  the file (``KAA``, ``MAA``, ``KGG``, ``MGG``; case ignored) and carry no dof labels.  Their rows
  are the dofs of a Nastran set in internal (USET) order: the set is given (``a`` for KAA/MAA,
  ``g`` for KGG/MGG) and the dof map comes from the USET table of an OP2 of the same run
  (``PARAM,POST,-1``; or the output of pyyeti's nas2cam DMAP).
* **DMIG** punch files (``PARAM,EXTOUT,DMIGPCH`` writes the a-set matrices of a reduced
  superelement as ``DMIG`` bulk entries, e.g. ``KAAX``, ``MAAX``), or an OP2 holding DMIG
  matrices: every term names its grid (or scalar point) and component, so the labels come
  from the file itself.

Labels are ``id:dir`` from Nastran's grid id and component 1-6 (x, y, z, rx, ry, rz), and
``id:s`` for a scalar point (component 0).  Matrices must be real and square on one dof set.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .._errors import InputError

_COMPONENT = {0: "s", 1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}
SETS = ("a", "g", "f", "n", "l", "b")


def _pyyeti():
    try:
        import pyyeti.nastran as nastran
    except ImportError:
        raise InputError("reading Nastran OP4, OP2 and DMIG files needs pyyeti: pip install pyyeti "
                         "(or femupdate[nastran])") from None
    return nastran


def labels_of(pairs, where: str) -> list[str]:
    """``id:dir`` labels of (grid or scalar point id, component) pairs."""
    out = []
    for node, comp in pairs:
        comp = int(comp)
        if comp not in _COMPONENT:
            raise InputError(f"{where}: component {comp} of {node} is not 0-6")
        out.append(f"{int(node)}:{_COMPONENT[comp]}")
    return out


def _real(A, where: str):
    values = A.data if sp.issparse(A) else np.asarray(A)
    if np.iscomplexobj(values):
        if np.any(values.imag):
            raise InputError(f"{where} is complex (largest imaginary part {np.abs(values.imag).max():.4g}); K and M must "
                             "be real")
        A = A.real
    return A


def read_op4(path, name: str, where: str = "op4"):
    """Matrix ``name`` of an OP4 file (case ignored), real.

    Raises
    ------
    InputError
        pyyeti missing; the file unreadable or without the matrix (its matrices named); complex.
    """
    nastran = _pyyeti()
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{where}: OP4 file {p} not found")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mats = nastran.op4.read(str(p))
    except Exception as exc:  # noqa: BLE001 - pyyeti raises many types on a damaged file
        raise InputError(f"{where}: cannot read {p} as an OP4 file ({type(exc).__name__}: {exc})") from None
    found = {k.lower(): k for k in mats}
    if name.lower() not in found:
        raise InputError(f"{where}: {p} holds no matrix {name!r} (it holds {', '.join(mats) or 'none'})")
    return _real(mats[found[name.lower()]], f"{where}: {name} of {p}")


def set_labels(op2, dof_set: str, where: str = "op2") -> list[str]:
    """Labels of the dofs of Nastran set ``dof_set`` in USET order, from an OP2's USET table
    (``PARAM,POST,-1``, read with pyyeti's ``rdparampost``), or from the output of pyyeti's
    nas2cam DMAP (``<name>.op2`` with ``<name>.op4``: the residual's USET).

    Raises
    ------
    InputError
        pyyeti missing; no such file; no USET in it; an unknown set letter.
    """
    nastran = _pyyeti()
    p = Path(op2)
    if dof_set not in SETS:
        raise InputError(f"{where}: set {dof_set!r} is not one of {', '.join(SETS)} (a for KAA/MAA, g for KGG/MGG)")
    if not p.is_file():
        raise InputError(f"{where}: OP2 file {p} not found")
    uset = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            uset = nastran.op2.rdparampost(str(p)).get("uset")
        except Exception:  # noqa: BLE001 - not a PARAM,POST,-1 file: try nas2cam's layout
            uset = None
        if uset is None and p.with_suffix(".op4").is_file():
            try:
                uset = nastran.op2.rdnas2cam(str(p.with_suffix("")))["uset"][0]
            except Exception:  # noqa: BLE001
                uset = None
    if uset is None:
        raise InputError(f"{where}: {p} has no USET table: write the OP2 with PARAM,POST,-1 (the dof map of the "
                         "OUTPUT4 matrices)")
    pv = nastran.n2p.mksetpv(uset, "p", dof_set)
    return labels_of(uset.index[pv].tolist(), f"{where}: {p}")


def read_dmig(path, name: str, where: str = "dmig") -> tuple[list[str], np.ndarray]:
    """DMIG matrix ``name`` (case ignored) of a punch file or an OP2: its labels and values.

    Raises
    ------
    InputError
        pyyeti missing; no such file or matrix; a matrix that is not square on one dof set
        (rows and columns naming the same dofs); complex.
    """
    nastran = _pyyeti()
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{where}: DMIG file {p} not found")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mats = nastran.rddmig(str(p))
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{where}: cannot read DMIG matrices from {p} ({type(exc).__name__}: {exc})") from None
    found = {k.lower(): k for k in (mats or {})}
    if name.lower() not in found:
        raise InputError(f"{where}: {p} holds no DMIG matrix {name!r} (it holds {', '.join(mats or {}) or 'none'})")
    df = mats[found[name.lower()]]
    if list(df.index) != list(df.columns):
        raise InputError(f"{where}: DMIG {name} of {p} has {df.shape[0]} rows and {df.shape[1]} columns on different "
                         "dofs: K and M are square on one dof set")
    return labels_of(df.index.tolist(), f"{where}: {p}"), _real(df.to_numpy(), f"{where}: DMIG {name} of {p}")


def nastran_model(table, parameters, path: Path, name: str):
    """A :class:`~femupdate.Model` from a model file's ``[nastran]`` table (docs/file-formats.md):
    ``K``, ``M`` (and each parameter's ``K``, ``M``) are matrix names in the ``op4`` file, on
    the dofs of ``set`` in the USET of ``op2``; or in the ``dmig`` file, labelled by it (a
    parameter's DMIG may hold some of the dofs of ``K``: it is placed on them)."""
    from ..model import Model, Parameter
    from ..priors import parse_prior

    src = f"{path}: [nastran]"
    base = path.parent
    allowed = {"op4", "op2", "set", "dmig", "K", "M", "deck"}  # deck: only where updated values are written
    if set(table) - allowed:
        raise InputError(f"{src}: unknown key(s) {', '.join(sorted(set(table) - allowed))} (allowed: "
                         f"{', '.join(sorted(allowed))})")
    if ("op4" in table) == ("dmig" in table):
        raise InputError(f"{src}: give either op4 (with op2 and set) or dmig")
    for key in ("K", "M"):
        if not isinstance(table.get(key), str):
            raise InputError(f"{src}: '{key}' must name a matrix of the file (e.g. {key}AA)")
    if "op4" in table:
        dofs = set_labels(base / str(table.get("op2", "")), str(table.get("set", "a")), src)

        def get(mname, where):
            A = read_op4(base / str(table["op4"]), mname, where)
            if A.shape != (len(dofs), len(dofs)):
                raise InputError(f"{where}: {mname} is {A.shape[0]} × {A.shape[1]}, but set {table.get('set', 'a')!r} "
                                 f"of {table.get('op2')} has {len(dofs)} dofs: another set, or another run's OP2")
            return A
    else:
        dofs, _ = read_dmig(base / str(table["dmig"]), table["K"], src)

        def get(mname, where):
            lab, A = read_dmig(base / str(table["dmig"]), mname, where)
            if lab == dofs:
                return A
            pos = {d: i for i, d in enumerate(dofs)}
            extra = [d for d in lab if d not in pos]
            if extra:
                raise InputError(f"{where}: DMIG {mname} has dof(s) {', '.join(extra[:6])} that {table['K']} does not "
                                 "have")
            idx = np.array([pos[d] for d in lab])  # a matrix on some of the dofs (a spring's, a panel's): placed
            out = np.zeros((len(dofs), len(dofs)))
            out[np.ix_(idx, idx)] = A
            return out
    K0, M0 = get(table["K"], f"{src} K"), get(table["M"], f"{src} M")
    params, dK, dM = [], [], []
    for pname, spec in parameters.items():
        where = f"{path}: [parameters.{pname}]"
        if not isinstance(spec, dict) or "value" not in spec or not ({"K", "M"} & set(spec)):
            raise InputError(f"{where} must be a table with 'value' and K and/or M (matrix names in the file)")
        try:
            params.append(Parameter(pname, spec["value"], tuple(spec.get("bounds", (-np.inf, np.inf))),
                                    spec.get("fixed", False),
                                    prior=parse_prior(spec["prior"], f"{where} prior") if "prior" in spec else None))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        dK.append(get(spec["K"], f"{where} K") if "K" in spec else None)
        dM.append(get(spec["M"], f"{where} M") if "M" in spec else None)
    try:
        return Model(tuple(dofs), K0, M0, tuple(params), tuple(dK), tuple(dM), name=name)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


__all__ = ["read_op4", "set_labels", "read_dmig", "labels_of", "nastran_model", "SETS"]
