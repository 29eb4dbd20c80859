"""ANSYS (MAPDL) matrices: the ``.full`` file that ``WRFULL`` writes.

Read through ansys-mapdl-reader (an optional dependency, ``pip install femupdate[ansys]``; it
brings VTK; imported here only, when a ``.full`` file is read).  A modal or static analysis
stopped after assembly::

    /SOLU
    ANTYPE,MODAL
    MODOPT,LANB,10
    WRFULL,1          ! write Jobname.full and stop after the matrices are assembled
    SOLVE

writes ``Jobname.full``: the assembled stiffness and (consistent) mass matrices as one triangle,
on every dof of every node, with the dofs the constraints (``D``) fix marked.  femupdate reads it
with the package's :class:`~ansys.mapdl.reader.full.FullFile`, symmetrises the triangle, removes
the constrained dofs (ANSYS writes them with a unit diagonal and no coupling) and labels each dof
``node:dir`` from the ANSYS node number and the dof name of the file's own dof list (``UX UY UZ
ROTX ROTY ROTZ`` → ``x y z rx ry rz``).  Other dof names (``TEMP``, ``PRES``, ``WARP``...), a
lumped mass matrix (``LUMPM,ON``) and an unsymmetric file (``NROPT,UNSYM``) are refused by name.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .._errors import InputError

#: ANSYS dof reference numbers (the file's dof list) read as femupdate directions
ANSYS_DOFS = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "rz"}
#: names of the other ANSYS dof reference numbers, for messages
_OTHER = {7: "AX", 8: "AY", 9: "AZ", 10: "VX", 11: "VY", 12: "VZ", 16: "WARP", 17: "CONC", 18: "HDSP", 19: "PRES",
          20: "TEMP", 21: "TBOT", 22: "TE2", 32: "TTOP", 25: "VOLT", 26: "MAG", 27: "ENKE", 28: "ENDS", 29: "EMF",
          30: "CURR"}


def _reader():
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            from ansys.mapdl.reader.full import FullFile
    except ImportError:
        raise InputError("reading ANSYS .full files needs ansys-mapdl-reader: pip install ansys-mapdl-reader "
                         "(or femupdate[ansys])") from None
    return FullFile


def _records(p: Path, count: int, what: str = "full") -> list[np.ndarray]:
    """The first ``count`` records of an ANSYS binary file: each ``[n][flags] n words [pad]``."""
    out = []
    bad = f"{what}: {p}: its headers do not read (a file cut short, or not an ANSYS .full file)"
    with open(p, "rb") as fh:
        for _ in range(count):
            head = np.fromfile(fh, "<i4", 2)
            if head.size < 2 or not 0 < head[0] <= 4096:
                raise InputError(bad)
            words = np.fromfile(fh, "<i4", int(head[0]))
            if words.size < head[0] or np.fromfile(fh, "<i4", 1).size < 1:
                raise InputError(bad)
            out.append(words)
    return out


@dataclass(frozen=True)
class FullMatrices:
    """The matrices of a ``.full`` file on its free (unconstrained) dofs.

    Attributes
    ----------
    dofs : tuple of str
        ``node:dir`` labels, node by node in ascending node number, in the order of the file's
        dof list.
    K, M : scipy.sparse.csr_array
        Symmetric.
    constrained : tuple of str
        The labels of the dofs the file marks as constrained (removed).
    """

    dofs: tuple
    K: sp.csr_array
    M: sp.csr_array
    constrained: tuple


def read_full(path, what: str = "full") -> FullMatrices:
    """K and M of an ANSYS ``.full`` file (module docstring).

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        How messages name the file's role.

    Returns
    -------
    FullMatrices

    Raises
    ------
    InputError
        ansys-mapdl-reader missing; no such file; a file that is not a ``.full`` file or is cut
        short; a lumped-mass or unsymmetric file; a file without K or M; a dof that is not a
        displacement or rotation; nodes with fewer dofs than the file's dof list.
    """
    FullFile = _reader()
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what}: ANSYS .full file {p} not found" + (" (it is a folder)" if p.is_dir() else ""))
    types = _records(p, 3, what)[2]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            full = FullFile(str(p))
    except NotImplementedError as exc:
        kind = "a lumped mass matrix (LUMPM,ON)" if "lumped" in str(exc) else "unsymmetric matrices (NROPT,UNSYM)"
        raise InputError(f"{what}: {p} holds {kind}, which femupdate does not read: write the .full file with the "
                         "consistent mass and symmetric matrices") from None
    except Exception as exc:  # noqa: BLE001 - the package raises many types on a damaged file
        raise InputError(f"{what}: cannot read {p} as an ANSYS .full file ({type(exc).__name__}: {exc})") from None
    neqn = int(full.neqn)
    end = int(full._header.get("ptrEND", 0))
    if end and p.stat().st_size < 4 * end:
        raise InputError(f"{what}: {p} is cut short ({p.stat().st_size} bytes; its header says {4 * end}): copy the "
                         "whole .full file")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            dof_ref, K, M = full.load_km(as_sparse=True, sort=False)
            const = np.asarray(full.const).reshape(-1, 2)
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{what}: cannot read the matrices of {p} ({type(exc).__name__}: {exc}): a damaged or "
                         "cut-short .full file") from None
    if K is None or M is None:
        raise InputError(f"{what}: {p} holds no {'stiffness' if K is None else 'mass'} matrix: write it with "
                         "WRFULL from a modal analysis (ANTYPE,MODAL), which assembles both")
    names = [int(t) for t in types]
    dof_ref = np.asarray(dof_ref)
    counts = np.bincount(np.unique(dof_ref[:, 0], return_inverse=True)[1])
    if np.any(counts != len(names)):
        raise InputError(f"{what}: {p}: some nodes have fewer dofs than the file's dof list "
                         f"({', '.join(_name(t) for t in names)}): femupdate reads files whose nodes all carry the same dofs")
    for t in names:
        if t not in ANSYS_DOFS:
            raise InputError(f"{what}: {p}: dof {_name(t)} is not a displacement or rotation (UX UY UZ ROTX ROTY "
                             "ROTZ): femupdate reads structural dofs only")
    labels = [f"{int(n)}:{ANSYS_DOFS[names[int(j)]]}" for n, j in dof_ref]
    fixed = {f"{int(n)}:{ANSYS_DOFS[names[int(j)]]}" for n, j in const}
    K, M = _symmetric(K, neqn), _symmetric(M, neqn)
    order = sorted((i for i, lab in enumerate(labels) if lab not in fixed),
                   key=lambda i: (int(dof_ref[i, 0]), int(dof_ref[i, 1])))
    idx = np.array(order, dtype=int)
    return FullMatrices(tuple(labels[i] for i in idx), K[idx][:, idx].tocsr(), M[idx][:, idx].tocsr(),
                        tuple(sorted(fixed, key=lambda s: (int(s.split(":")[0]), s))))


def _name(t: int) -> str:
    return {1: "UX", 2: "UY", 3: "UZ", 4: "ROTX", 5: "ROTY", 6: "ROTZ"}.get(t, _OTHER.get(t, f"#{t}"))


def _symmetric(A, n: int) -> sp.csr_array:
    """The full symmetric matrix of the file's upper triangle."""
    U = sp.csr_array(sp.triu(sp.csr_array(A), format="csr"))
    if U.shape != (n, n):
        raise InputError(f"a .full matrix of shape {U.shape} for {n} equations")
    return sp.csr_array(U + sp.triu(U, 1, format="csr").T)


def read_nodes(path, what: str = "deck") -> dict:
    """Node coordinates from an ANSYS archive (``CDWRITE``: ``.cdb``), through the package's
    :class:`~ansys.mapdl.reader.Archive`."""
    _reader()
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what}: ANSYS archive {p} not found")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            from ansys.mapdl.reader import Archive

            arch = Archive(str(p), parse_vtk=False)
            return {int(n): tuple(float(v) for v in xyz) for n, xyz in zip(arch.nnum, arch.nodes)}
    except Exception as exc:  # noqa: BLE001
        raise InputError(f"{what}: cannot read node coordinates from {p} ({type(exc).__name__}: {exc})") from None


def ansys_model(table, parameters, path: Path, name: str):
    """A :class:`~femupdate.Model` from a model file's ``[ansys]`` table (docs/file-formats.md):
    K and M of the ``full`` file, written at the parameters' ``exported_at`` values (default
    ``value``); a parameter either ``scales`` the file's whole ``"K"`` or ``"M"`` (K = p / x0 ·
    K_file), or names a second ``full`` file written with only that parameter changed to
    ``full_at`` (dK/dp = (K_at − K_file) / (full_at − x0));
    both exact for a parameter the matrices are affine in (a modulus, a density)."""
    from ..model import Model, Parameter
    from ..priors import parse_prior

    src = f"{path}: [ansys]"
    base = path.parent
    unknown = sorted(set(table) - {"full", "deck"})
    if unknown:
        raise InputError(f"{src}: unknown key(s) {', '.join(unknown)} (allowed: full, deck)")
    if not isinstance(table.get("full"), str):
        raise InputError(f"{src}: 'full' must name the .full file WRFULL wrote")
    fm = read_full(base / table["full"], f"{src} full")
    params, dK, dM = [], [], []
    K0, M0 = fm.K.copy(), fm.M.copy()
    allowed = {"value", "bounds", "fixed", "prior", "scales", "full", "full_at", "exported_at", "card"}
    for pname, spec in parameters.items():
        where = f"{path}: [parameters.{pname}]"
        if not isinstance(spec, dict) or "value" not in spec:
            raise InputError(f"{where} must be a table with at least 'value'")
        if set(spec) - allowed or ("scales" in spec) == ("full" in spec):
            raise InputError(f"{where}: an ANSYS parameter takes {', '.join(sorted(allowed))}, with either scales "
                             "(\"K\" or \"M\") or full and full_at (a second .full file); got " + ", ".join(spec))
        try:
            par = Parameter(pname, spec["value"], tuple(spec.get("bounds", (-np.inf, np.inf))), spec.get("fixed", False),
                            prior=parse_prior(spec["prior"], f"{where} prior") if "prior" in spec else None)
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
        params.append(par)
        x0 = spec.get("exported_at", par.value)  # the value the file of [ansys] was written at
        if isinstance(x0, bool) or not isinstance(x0, (int, float)) or not np.isfinite(x0) or x0 == 0:
            raise InputError(f"{where}: exported_at (the value {table['full']} was written at) must be a nonzero "
                             f"number, got {x0!r}")
        if "scales" in spec:
            if spec["scales"] not in ("K", "M"):
                raise InputError(f"{where}: scales must be \"K\" or \"M\" (the file's whole matrix goes as the "
                                 f"parameter); got {spec['scales']!r}")
            A = (fm.K if spec["scales"] == "K" else fm.M) / x0
            dK.append(A if spec["scales"] == "K" else None)
            dM.append(A if spec["scales"] == "M" else None)
            if spec["scales"] == "K":  # A · x0 is the file's matrix: taken off exactly
                K0 = K0 - fm.K
            else:
                M0 = M0 - fm.M
            continue
        at = spec.get("full_at")
        if isinstance(at, bool) or not isinstance(at, (int, float)) or not np.isfinite(at) or at == x0:
            raise InputError(f"{where}: full_at (the value the second .full file was written at) must be a number "
                             f"other than value, got {at!r}")
        other = read_full(base / str(spec["full"]), f"{where} full")
        if other.dofs != fm.dofs:
            raise InputError(f"{where}: {spec['full']} is on other dofs than {table['full']} (another mesh or other "
                             "constraints)")
        dk, dm = (other.K - fm.K) / (at - x0), (other.M - fm.M) / (at - x0)
        dK.append(dk if dk.count_nonzero() else None)
        dM.append(dm if dm.count_nonzero() else None)
        K0 = K0 - dk * x0
        M0 = M0 - dm * x0
    nodes = read_nodes(base / str(table["deck"]), f"{src} deck") if "deck" in table else {}
    used = {d.split(":")[0] for d in fm.dofs}
    nodes = {k: v for k, v in nodes.items() if str(k) in used}
    try:
        return Model(fm.dofs, sp.csr_array(K0), sp.csr_array(M0), tuple(params), tuple(dK), tuple(dM), name=name,
                     nodes=nodes)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


__all__ = ["ANSYS_DOFS", "FullMatrices", "read_full", "read_nodes", "ansys_model"]
