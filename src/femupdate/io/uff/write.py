"""Writing universal files: :func:`write_uff_modes` (dataset 55) and :func:`write_uff_frf` (dataset 58),
each with SI units (164) and node coordinates (2411), replaced atomically."""

from __future__ import annotations

import io
import logging
import os
import shutil
import tempfile
from collections.abc import Iterable, Mapping, Sequence

import numpy as np
import pyuff

from ..._docs import shared_docs
from ..._errors import InputError
from ...dofs import DIRECTIONS, canonical_all, describe, parse_dof
from ...testdata import FRFData
from .conventions import code_of_direction

__all__ = ["write_uff_modes", "write_uff_frf", "uff_dofs"]

log = logging.getLogger("femupdate.io.uff")  # the package's logger, as before the split into modules


# the writers' common parameters, documented once (femupdate._docs)
_DOCS = {
    "PATH": "Parameters\n----------\npath : str or path-like\n    Output file, replaced atomically.",
    "NAME_UNITS": "model_name : str\n    ID line 1 of every record.\nunits : bool\n    Write dataset 164 (SI units) first.",
}


def _id_line(text: str) -> str:
    """An ID line: one line of at most 80 characters, never blank (UFF uses "NONE")."""
    text = " ".join(str(text).split())[:80]
    return text or "NONE"

def uff_dofs(labels: Iterable[str], what: str) -> list[tuple[int, str]]:
    """``(node number, direction)`` of each label, refusing named nodes (universal files number
    nodes with integers).

    Parameters
    ----------
    labels : iterable of str
        Dof labels.
    what : str
        What writes the file (e.g. ``"modes --uff"`` or the file name), for the message.

    Returns
    -------
    list of (int, str)

    Raises
    ------
    InputError
        A malformed label, or a node that is a name (``A2``) rather than a number.
    """
    out = []
    for lab in labels:
        node, direction = parse_dof(lab)
        if direction not in DIRECTIONS:
            raise InputError(f"{what}: dof {lab!r} is a scalar point, which has no direction in space; universal files "
                             "hold translations and rotations only")
        if not isinstance(node, int):
            raise InputError(f"{what}: node {node!r} of dof {lab!r} is not an integer; universal files number "
                             "nodes with integers")
        out.append((node, direction))
    return out


def _si_units() -> dict:
    return pyuff.prepare_164(
        units_code=1,
        units_description="SI: Meter (newton)",
        temp_mode=2,
        length=1.0,
        force=1.0,
        temp=1.0,
        temp_offset=273.15,
    )


def _nodes_dataset(nodes: Mapping[int, Sequence[float]], used: Iterable[int], what: str) -> dict:
    ids = sorted(int(n) for n in nodes)
    missing = sorted(set(used) - set(ids))
    if missing:
        raise InputError(f"{what}: node(s) without coordinates in `nodes`: {', '.join(map(str, missing[:8]))}")
    try:
        xyz = np.array([[float(c) for c in nodes[n]] for n in ids], dtype=float).reshape(len(ids), 3)
    except (TypeError, ValueError):
        raise InputError(f"{what}: `nodes` must map node ids to (x, y, z)") from None
    if not np.all(np.isfinite(xyz)):
        raise InputError(f"{what}: `nodes` has NaN or infinite coordinates")
    zeros = np.zeros(len(ids), dtype=int)
    return pyuff.prepare_2411(
        node_nums=np.array(ids, dtype=int),
        def_cs=zeros,
        disp_cs=zeros,
        color=zeros,
        x=xyz[:, 0].copy(),
        y=xyz[:, 1].copy(),
        z=xyz[:, 2].copy(),
    )


def _atomic_write(path: str | os.PathLike, datasets: Sequence[dict]) -> None:
    """Write ``datasets`` with pyuff, then the whole file at once with
    :func:`femupdate.io.results.atomic_write_bytes` (a regular file replaced atomically; a device,
    a symbolic link or an input of the run handled as every output is).

    pyuff re-scans the whole file after every dataset it appends, which is quadratic in the
    number of datasets; each dataset is therefore written to a small scratch file and copied.
    """
    from ..results import atomic_write_bytes

    target = os.fspath(path)
    folder = os.path.dirname(os.path.realpath(target))
    if not os.path.isdir(folder):
        raise InputError(f"{target}: cannot write: directory {folder} does not exist")
    current = None
    out = io.BytesIO()
    try:
        with tempfile.TemporaryDirectory(prefix="femupdate-uff-") as scratch_dir:
            scratch = os.path.join(scratch_dir, "set.uff")
            for current in datasets:
                pyuff.UFF(scratch).write_sets(current, mode="overwrite")
                with open(scratch, "rb") as fh:
                    shutil.copyfileobj(fh, out)
    except Exception as exc:
        log.debug("pyuff failed writing %s", target, exc_info=True)
        kind = current.get("type", "?") if isinstance(current, dict) else "?"
        raise InputError(f"{target}: pyuff could not write dataset {kind}: {exc}") from None
    try:
        atomic_write_bytes(target, out.getvalue())
    except OSError as exc:
        raise InputError(f"{target}: cannot write: {exc.strerror or exc}") from None


@shared_docs(**_DOCS)
def write_uff_modes(
    path: str | os.PathLike,
    modes,
    nodes: Mapping[int, Sequence[float]] | None = None,
    model_name: str = "femupdate",
    *,
    units: bool = True,
) -> None:
    """Write real normal modes as a universal file.

    {{PATH}}
    modes : Modes
        ``eigenvalues`` (m,) in rad^2/s^2, real ``shapes`` (n, m) on ``dofs``.
    nodes : mapping int -> (x, y, z), optional
        Node coordinates, written as dataset 2411; must cover every node of ``modes.dofs``.
    {{NAME_UNITS}}

    Notes
    -----
    One dataset 55 per mode: model type structural, analysis type 2 (normal mode), specific
    data type 8 (displacement), real data, frequency :math:`\\sqrt{\\lambda}/2\\pi` Hz, modal
    mass 1 for mass-normalised modes (else 0, unknown), load case 1, modes numbered from 1.
    Dofs are grouped by node (ascending); the data characteristic is 2 (3-dof translation
    vector, ``x y z``) when every dof is a translation, otherwise 3 (6-dof translation and
    rotation vector, ``x .. rz``). Components a node lacks are written as 0. pyuff writes values
    and frequencies in E13.5 format: six significant digits.

    Raises
    ------
    InputError
        Complex or non-finite shapes, inconsistent shapes, a named node (``A2``: universal files
        number nodes with integers), nodes without coordinates, or a failed write (naming the file).
    """
    target = os.fspath(path)
    lam = np.atleast_1d(np.asarray(modes.eigenvalues, dtype=float))
    phi = np.asarray(modes.shapes)
    labels = canonical_all(modes.dofs, f"{target}: mode shapes")
    if phi.ndim == 1:
        phi = phi.reshape(-1, 1)
    if phi.shape != (len(labels), lam.size):
        raise InputError(f"{target}: shapes have shape {phi.shape}, expected ({len(labels)} dofs, {lam.size} modes)")
    if lam.size == 0:
        raise InputError(f"{target}: no modes to write")
    if np.iscomplexobj(phi):
        if np.any(phi.imag != 0):
            raise InputError(f"{target}: complex mode shapes cannot be written as real normal modes")
        phi = phi.real
    phi = phi.astype(float)
    if not np.all(np.isfinite(lam)) or not np.all(np.isfinite(phi)):
        raise InputError(f"{target}: NaN or infinite eigenvalues or shape values")
    freqs = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)

    rows: dict[int, dict[int, int]] = {}
    for i, (n, d) in enumerate(uff_dofs(labels, target)):
        rows.setdefault(n, {})[DIRECTIONS.index(d)] = i
    node_ids = sorted(rows)
    ncomp = 3 if all(j < 3 for r in rows.values() for j in r) else 6
    data_ch = 2 if ncomp == 3 else 3
    # (n_nodes, ncomp) row indices into phi, -1 where the node lacks that component
    idx = np.full((len(node_ids), ncomp), -1, dtype=int)
    for a, n in enumerate(node_ids):
        for j, i in rows[n].items():
            idx[a, j] = i

    datasets = []
    if units:
        datasets.append(_si_units())
    if nodes:
        datasets.append(_nodes_dataset(nodes, node_ids, target))
    modal_m = 1.0 if getattr(modes, "normalisation", "") == "mass" else 0.0
    padded = np.vstack([phi, np.zeros((1, lam.size))])  # row -1 = zeros
    for r in range(lam.size):
        comp = padded[idx, r]  # (n_nodes, ncomp)
        kw = {f"r{j + 1}": comp[:, j].copy() for j in range(ncomp)}
        datasets.append(
            pyuff.prepare_55(
                id1=_id_line(model_name),
                id2=_id_line(f"Mode {r + 1}"),
                id3="NONE",
                id4="NONE",
                id5=_id_line(f"Mode {r + 1} frequency {freqs[r]:.6g} Hz"),
                model_type=1,
                analysis_type=2,
                data_ch=data_ch,
                spec_data_type=8,
                data_type=2,
                n_data_per_node=ncomp,
                node_nums=np.array(node_ids, dtype=int),
                load_case=1,
                mode_n=r + 1,
                freq=float(freqs[r]),
                modal_m=modal_m,
                modal_damp_vis=0.0,
                modal_damp_his=0.0,
                **kw,
            )
        )
    _atomic_write(target, datasets)
    log.info("%s: wrote %d mode(s) at %d node(s)", target, lam.size, len(node_ids))


@shared_docs(**_DOCS)
def write_uff_frf(
    path: str | os.PathLike,
    frf: FRFData,
    nodes: Mapping[int, Sequence[float]] | None = None,
    model_name: str = "femupdate",
    *,
    units: bool = True,
) -> None:
    """Write FRFs as a universal file: one dataset 58 per response dof.

    {{PATH}}
    frf : FRFData
        Responses ``(n_freq, n_dofs)`` to one excitation dof (a single non-zero entry in
        ``frf.force``); written as receptance ``response / force``.
    nodes : mapping int -> (x, y, z), optional
        Node coordinates, written as dataset 2411; must cover every node used.
    {{NAME_UNITS}}

    Notes
    -----
    Function type 4 (FRF), complex double-precision ordinate, abscissa frequency in Hz
    (:math:`f = \\omega / 2\\pi`, specific data type 18), ordinate displacement (8) over
    excitation force (13). The abscissa is written in E13.5 format (six significant digits,
    as the UFF standard has it), so ``omega`` read back agrees to about 5e-6 relative.

    Raises
    ------
    InputError
        More than one excitation dof, a named node (``A2``: universal files number nodes with
        integers), nodes without coordinates, or a failed write.
    """
    target = os.fspath(path)
    loads = {k: v for k, v in dict(frf.force).items() if v != 0}
    if len(loads) != 1:
        raise InputError(
            f"{target}: dataset 58 holds FRFs of one excitation dof; the force acts at {describe(list(loads))}"
        )
    ((ref, amplitude),) = loads.items()
    ((ref_node, ref_dir),) = uff_dofs([ref], target)
    omega = np.atleast_1d(np.asarray(frf.omega, dtype=float))
    h = np.asarray(frf.response, dtype=complex).reshape(omega.size, -1) / amplitude
    if not np.all(np.isfinite(h)) or not np.all(np.isfinite(omega)):
        raise InputError(f"{target}: NaN or infinite FRF values")
    labels = tuple(frf.dofs)
    f_hz = omega / (2 * np.pi)
    even = f_hz.size == 1  # pyuff needs two abscissas to write an uneven axis
    x = np.array([f_hz[0], f_hz[0] + 1.0]) if even else f_hz.copy()
    nodes_dirs = uff_dofs(labels, target)
    used = {ref_node} | {n for n, _ in nodes_dirs}

    datasets = []
    if units:
        datasets.append(_si_units())
    if nodes:
        datasets.append(_nodes_dataset(nodes, used, target))
    for j, (lab, (node, direction)) in enumerate(zip(labels, nodes_dirs)):
        ds = pyuff.prepare_58(
            binary=0,
            id1=_id_line(model_name),
            id2=_id_line(f"Receptance {lab} / {ref}"),
            id3="NONE",
            id4="NONE",
            id5="NONE",
            func_type=4,
            ver_num=0,
            load_case_id=0,
            rsp_ent_name="NONE",
            rsp_node=int(node),
            rsp_dir=code_of_direction(direction),
            ref_ent_name="NONE",
            ref_node=int(ref_node),
            ref_dir=code_of_direction(ref_dir),
            ord_data_type=6,
            num_pts=int(omega.size),
            abscissa_spacing=1 if even else 0,
            abscissa_min=0.0,
            abscissa_inc=0.0,
            z_axis_value=0.0,
            abscissa_spec_data_type=18,
            abscissa_len_unit_exp=0,
            abscissa_force_unit_exp=0,
            abscissa_temp_unit_exp=0,
            abscissa_axis_units_lab="Hz",
            ordinate_spec_data_type=8,
            ordinate_len_unit_exp=0,
            ordinate_force_unit_exp=0,
            ordinate_temp_unit_exp=0,
            ordinate_axis_units_lab="NONE",
            orddenom_spec_data_type=13,
            orddenom_len_unit_exp=0,
            orddenom_force_unit_exp=0,
            orddenom_temp_unit_exp=0,
            orddenom_axis_units_lab="NONE",
            z_axis_spec_data_type=0,
            z_axis_len_unit_exp=0,
            z_axis_force_unit_exp=0,
            z_axis_temp_unit_exp=0,
            z_axis_axis_units_lab="NONE",
            data=h[:, j].copy(),
            x=x,
        )
        ds["func_id"] = j + 1
        datasets.append(ds)
    _atomic_write(target, datasets)
    log.info("%s: wrote %d FRF(s) of excitation %s, %d frequencies", target, len(labels), ref, omega.size)
