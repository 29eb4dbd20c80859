"""Nastran bulk-data cards beyond shells and solids: CBAR/CBEAM with PBAR/PBEAM (femupdate's
frame3d), CELAS1/CELAS2 with PELAS (springs), CONM2 (point masses) and RBE2 (an exact rigid
link, :mod:`femupdate.constraints`).  Fields as the Quick Reference Guide numbers them; what
femupdate cannot model exactly is refused naming the card and its line.

Mappings:

* CBAR/CBEAM ``EID PID GA GB X1 X2 X3 OFFT / PA PB W1A W2A W3A W1B W2B W3B``: the orientation
  vector (X1-X3, or the grid G0 in X1: v = x_G0 − x_GA) lies in the member's plane 1 (local x-y);
  offsets W (OFFT ``GGG``, the default: global components) become frame end offsets.  Pin flags
  PA/PB, other OFFT with offsets, and CBEAM's warping points SA/SB are refused.
* PBAR ``PID MID A I1 I2 J NSM`` and PBEAM's end A ``PID MID A I1 I2 I12 J NSM``: I1 (plane 1)
  is frame3d's Iz, I2 its Iy.  NSM, I12 and a tapered PBEAM are refused; PBAR's shear factors K1,
  K2 must be blank (Euler-Bernoulli); PBEAM's (default 1.0: shear flexible) are listed as not
  modelled, since femupdate's frame is Euler-Bernoulli.
* CELAS1 ``EID PID G1 C1 G2 C2`` with PELAS ``PID K GE S (PID K GE S)``, CELAS2
  ``EID K G1 C1 G2 C2 GE S``: a spring between two dofs, or to ground (G2 blank).  Damping GE is
  listed as not read; scalar points are refused.
* CONM2 ``EID G CID M X1 X2 X3 / I11 I21 I22 I31 I32 I33``: CID 0 (offset in basic axes) or −1
  (X the centre of mass in basic coordinates); the inertia tensor has −I21, −I31, −I32 off the
  diagonal (the QRG's convention: the magnitudes are given).
* RBE2 ``EID GN CM GM1 GM2 ... (or GM1 THRU GM2)``: the GM nodes' CM dofs follow GN rigidly;
  thermal expansion ALPHA (the last field, real) must be blank or zero.
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError
from ..dofs import dof
from .core import DIRS, Section, int_id


def _f(d, i, default=""):
    return d[i] if i < len(d) and d[i] != "" else default


def _zero(text: str) -> bool:
    from .nastran import real

    return text == "" or real(text, "") == 0.0


def frame_card(name: str, d, where: str, frames: dict) -> None:
    """CBAR / CBEAM: collected in ``frames[name]`` (orientation resolved once the grids are read)."""
    from .nastran import real

    eid = int_id(_f(d, 0), where)
    where = f"{where} (element {eid})"
    pid = int_id(_f(d, 1, str(eid)), where)
    ga, gb = int_id(_f(d, 2), where), int_id(_f(d, 3), where)
    x1, x2, x3 = _f(d, 4), _f(d, 5), _f(d, 6)
    if x1 == "":
        raise InputError(f"{where}: no orientation vector (X1, X2, X3 or G0); femupdate reads no BAROR/BEAMOR defaults")
    orient: tuple[str, int | list[float]]
    if x2 == "" and x3 == "" and "." not in x1 and "e" not in x1.lower():
        orient = ("grid", int_id(x1, where))
    else:
        orient = ("vector", [real(x, where) if x else 0.0 for x in (x1, x2, x3)])
    offt = _f(d, 7, "GGG").upper()
    if name == "CBEAM" and offt and offt[0].isdigit():
        raise InputError(f"{where}: CBEAM bit field BIT = {offt} is not supported")
    for k, what in ((8, "PA"), (9, "PB")):
        if _f(d, k) not in ("", "0"):
            raise InputError(f"{where}: pin flags {what} = {d[k]} are not supported (femupdate's frames are rigidly "
                             "connected; model a release with a separate node and springs)")
    w = np.array([real(_f(d, k, "0"), where) for k in range(10, 16)]).reshape(2, 3)
    if np.any(w != 0) and offt != "GGG":
        raise InputError(f"{where}: offsets with OFFT = {offt} are not supported (give them in global axes, OFFT GGG)")
    if name == "CBEAM" and (_f(d, 16) or _f(d, 17)):
        raise InputError(f"{where}: CBEAM warping scalar points SA/SB are not supported")
    f = frames.setdefault(name, {"ids": [], "pids": [], "conn": [], "orient": [], "offsets": [], "where": []})
    f["ids"].append(eid)
    f["pids"].append(pid)
    f["conn"].append([ga, gb])
    f["orient"].append(orient)
    f["offsets"].append(w)
    f["where"].append(where)


def frame_orientations(f: dict, xyz_of) -> np.ndarray:
    """Each member's orientation vector: X1-X3 as given, or x_G0 − x_GA."""
    out = []
    for (kind, v), (ga, _), where in zip(f["orient"], f["conn"], f["where"]):
        if kind == "grid":
            try:
                out.append(xyz_of(v) - xyz_of(ga))
            except KeyError:
                raise InputError(f"{where}: orientation grid G0 = {v} is not defined") from None
        else:
            out.append(np.array(v, dtype=float))
    return np.array(out, dtype=float)


def pbar(d, where: str, mesh) -> None:
    """PBAR: a beam section (A, I1 -> Iz, I2 -> Iy, J)."""
    from .nastran import real

    pid = int_id(_f(d, 0), where)
    where = f"{where} (PBAR {pid})"
    A, I1, I2, J = (real(_f(d, k, "0"), where) for k in (2, 3, 4, 5))
    if not _zero(_f(d, 6)):
        raise InputError(f"{where}: non-structural mass NSM = {d[6]} is not supported")
    if not (_f(d, 16) == "" and _f(d, 17) == ""):
        raise InputError(f"{where}: shear factors K1, K2 = {_f(d, 16) or 'blank'}, {_f(d, 17) or 'blank'} are not "
                         "supported: femupdate's frame3d is Euler-Bernoulli (leave them blank)")
    if not _zero(_f(d, 18)):
        raise InputError(f"{where}: product of inertia I12 = {d[18]} is not supported (give principal axes)")
    mesh.sections.append(Section(str(pid), str(int_id(_f(d, 1), where)), None, where,
                                 beam={"A": A, "Iz": I1, "Iy": I2, "J": J}))


def pbeam(d, where: str, mesh) -> None:
    """PBEAM of constant section: end A's A, I1, I2, J (I12 and NSM zero)."""
    from .nastran import real

    pid = int_id(_f(d, 0), where)
    where = f"{where} (PBEAM {pid})"
    A, I1, I2, I12, J, NSM = (real(_f(d, k, "0"), where) for k in range(2, 8))
    if I12 != 0 or NSM != 0:
        raise InputError(f"{where}: I12 = {I12:g}, NSM = {NSM:g}: femupdate reads principal-axis sections "
                         "without non-structural mass")
    rest = d[16:]
    if rest and rest[0].upper() in ("YES", "YESA", "NO"):
        station, rest = rest[:16], rest[16:]
        xxb = _f(station, 1, "1.0")
        if real(xxb, where) != 1.0 or len(rest) >= 16 and rest[0].upper() in ("YES", "YESA", "NO"):
            raise InputError(f"{where}: intermediate stations are not supported (a tapered PBEAM)")
        end_b = [_f(station, k) for k in range(2, 8)]
        if station[0].upper() != "YESA" and any(b != "" and real(b, where) != a for a, b in
                                                  zip((A, I1, I2, I12, J, NSM), end_b)):
            raise InputError(f"{where}: end B's section differs from end A's (a tapered PBEAM is not supported)")
    k1, k2 = _f(rest, 0, "1.0"), _f(rest, 1, "1.0")
    if real(k1, where) != 0 or real(k2, where) != 0:
        mesh.ignored.append(f"shear flexibility of PBEAM {pid} (K1 = {k1}, K2 = {k2}; femupdate's frame3d is "
                            f"Euler-Bernoulli) ({where.split(' at ')[-1].split(' (')[0]})")
    if any(not _zero(x) for x in rest[2:8]):
        raise InputError(f"{where}: shear relief, non-structural inertia or warping (S1, S2, NSI, CW) is not supported")
    mesh.sections.append(Section(str(pid), str(int_id(_f(d, 1), where)), None, where,
                                 beam={"A": A, "Iz": I1, "Iy": I2, "J": J}))


def _grid_dof(g: str, c: str, where: str) -> str | None:
    if g in ("", "0"):
        return None
    if c not in DIRS:
        raise InputError(f"{where}: component {c or 'blank'!r} of grid {g} must be one digit 1 to 6 (scalar points "
                         "are not supported)")
    return dof(int_id(g, where), DIRS[c])


def celas(name: str, d, where: str, mesh, pelas: dict) -> None:
    """CELAS1 (stiffness from PELAS, resolved later) or CELAS2 (stiffness on the card)."""
    from .nastran import real

    eid = int_id(_f(d, 0), where)
    where = f"{where} (element {eid})"
    a, b = _grid_dof(_f(d, 2), _f(d, 3), where), _grid_dof(_f(d, 4), _f(d, 5), where)
    dofs = [x for x in (a, b) if x is not None]
    if not dofs:
        raise InputError(f"{where}: {name} joins no grid")
    if a is not None and a == b:
        raise InputError(f"{where}: {name} joins dof {a} to itself")
    if name == "CELAS2":
        k: float | int = real(_f(d, 1), where)
        if not _zero(_f(d, 6)):
            mesh.ignored.append(f"damping GE of CELAS2 {eid} ({where.split(' at ')[-1].split(' (')[0]})")
    else:
        k = int_id(_f(d, 1, str(eid)), where)
    mesh.springs.append({"dofs": dofs, "k": k, "where": where, "pid": name == "CELAS1"})


def pelas_card(d, where: str, mesh, pelas: dict) -> None:
    """PELAS: one or two property ids with their stiffness."""
    from .nastran import real

    for off in (0, 4):
        if _f(d, off) == "":
            continue
        pid = int_id(d[off], where)
        if pid in pelas:
            raise InputError(f"{where}: PELAS {pid} defined twice")
        pelas[pid] = real(_f(d, off + 1), f"{where} (PELAS {pid})")
        if not _zero(_f(d, off + 2)):
            mesh.ignored.append(f"damping GE of PELAS {pid} ({where.split(' at ')[-1]})")


def resolve_springs(mesh, pelas: dict) -> None:
    """CELAS1 stiffness from its PELAS."""
    for s in mesh.springs:
        if s.pop("pid"):
            if s["k"] not in pelas:
                raise InputError(f"{s['where']}: property PELAS {s['k']} is not defined")
            s["k"] = pelas[s["k"]]


def conm2(d, where: str, mesh, cords: dict) -> None:
    """CONM2: a point mass, its offset (CID 0 or -1) and inertia tensor."""
    from .nastran import real

    eid = int_id(_f(d, 0), where)
    where = f"{where} (element {eid})"
    g = int_id(_f(d, 1), where)
    cid = int_id(_f(d, 2, "0"), where)
    if cid not in (0, -1):
        raise InputError(f"{where}: CONM2 in coordinate system CID = {cid} is not supported (give 0: basic axes, or -1)")
    m = real(_f(d, 3), where)
    x = np.array([real(_f(d, k, "0"), where) for k in (4, 5, 6)])
    i11, i21, i22, i31, i32, i33 = (real(_f(d, k, "0"), where) for k in range(8, 14))
    J = np.array([[i11, -i21, -i31], [-i21, i22, -i32], [-i31, -i32, i33]])
    mesh.masses.append({"node": g, "m": m, "offset": x, "absolute": cid == -1, "inertia": J, "where": where})


def rbe2(d, where: str, mesh) -> None:
    """RBE2: GN independent, the GM grids' CM components dependent (a rigid link)."""
    from .nastran import real

    eid = int_id(_f(d, 0), where)
    where = f"{where} (RBE2 {eid})"
    gn, cm = int_id(_f(d, 1), where), _f(d, 2)
    if not cm or any(c not in DIRS for c in cm) or len(set(cm)) != len(cm):
        raise InputError(f"{where}: component CM {cm or 'blank'!r} must be digits 1 to 6")
    gm = [x for x in d[3:] if x != ""]
    if gm and ("." in gm[-1] or "e" in gm[-1].lower()):  # the thermal expansion coefficient ALPHA
        if real(gm[-1], where) != 0:
            raise InputError(f"{where}: thermal expansion ALPHA = {gm[-1]} is not supported")
        gm = gm[:-1]
    if len(gm) == 3 and gm[1].upper() == "THRU":
        a, b = int_id(gm[0], where), int_id(gm[2], where)
        nodes = list(range(a, b + 1))
    else:
        nodes = [int_id(x, where) for x in gm]
    if not nodes:
        raise InputError(f"{where}: no dependent grids GM")
    mesh.links.append({"kind": "rigid", "independent": gn, "dependent": nodes,
                       "dofs": [DIRS[c] for c in sorted(cm)], "where": where})


__all__ = ["frame_card", "frame_orientations", "pbar", "pbeam", "celas", "pelas_card", "resolve_springs", "conm2",
           "rbe2"]
