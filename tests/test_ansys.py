"""ANSYS .full files (femupdate.io.ansys), on the file ansys-mapdl-reader ships: ``file.full``,
written by MAPDL 15.0 for its ``HexBeam.cdb`` model (a 1 × 1 × 5 cantilever of 40 SOLID186
bricks, 321 nodes, the 21 nodes at z = 0 fixed; ν = 0.35 in the archive).

Checked against an independent assembly of the same structure (femupdate's own hex8 elements on
a finer grid whose nodes include every node of the archive): frequency ratios and mode shapes.
Skipped without ansys-mapdl-reader (``pip install femupdate[ansys]``).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

pytest.importorskip("ansys.mapdl.reader")
from ansys.mapdl.reader import examples  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meshes3d import assemble, box_hex  # noqa: E402

from femupdate import load_model  # noqa: E402
from femupdate._errors import InputError  # noqa: E402
from femupdate.elements_3d import hex8_terms  # noqa: E402
from femupdate.io.ansys import read_full, read_nodes  # noqa: E402

FULL = Path(examples.fullfile)
CDB = Path(examples.hexarchivefile)


def _modes(K, M, k=8):
    w, v = sla.eigsh(sp.csc_matrix(K), k=k, M=sp.csc_matrix(M), sigma=0, which="LM")
    order = np.argsort(w)
    return np.sqrt(w[order]) / (2 * np.pi), v[:, order]


@pytest.fixture(scope="module")
def beam():
    fm = read_full(FULL)
    return fm, _modes(fm.K, fm.M)


def test_labels_and_constrained_dofs(beam):
    fm, _ = beam
    assert len(fm.dofs) == 900 and len(set(fm.dofs)) == 900  # 963 equations less 63 fixed
    assert fm.dofs[:3] == ("22:x", "22:y", "22:z")
    clamped = {str(n) for n, xyz in read_nodes(CDB).items() if xyz[2] == 0.0}
    assert {c.split(":")[0] for c in fm.constrained} == clamped and len(fm.constrained) == 63
    assert not {d.split(":")[0] for d in fm.dofs} & clamped
    for A in (fm.K, fm.M):
        assert abs(A - A.T).max() == 0.0  # the triangle symmetrised
        assert abs(sp.tril(A, -1)).max() > 0


def test_frequencies_as_the_package_reports_them(beam):
    # the frequencies ansys-mapdl-reader's own example asserts for this file (examples.load_km)
    _, (f, _) = beam
    assert np.allclose(f[:6], [1283.20036921, 1283.20036921, 5781.97486169, 6919.39887714, 6919.39887714,
                                        10172.61497694], rtol=1e-8)


def test_against_an_independent_assembly_of_the_cantilever(beam):
    """femupdate's hex8 on a 4 × 4 × 20 grid (every archive node is a grid node): frequency
    ratios to 1.5 % (two discretisations of one continuum: 6 × 6 × 30 moves them by < 1 %) and
    the mode shapes at the file's own dofs, placed by the archive's coordinates (a wrong dof map
    or node order gives MACs far below 0.99)."""
    fm, (fa, va) = beam
    nodes, hexes = box_hex(4, 4, 20, (1.0, 1.0, 5.0))
    K, M = assemble(hex8_terms(nodes[hexes], 0.35), hexes, len(nodes), 3, {"E": 1.0, "rho": 1.0})
    free = np.repeat(nodes[:, 2] > 1e-9, 3)
    fh, vh = _modes(K[free][:, free], M[free][:, free])
    assert np.all(np.abs((fh / fh[0]) / (fa / fa[0]) - 1) < 0.015)
    xyz = read_nodes(CDB)
    grid = {tuple(np.round(p, 9)): i for i, p in enumerate(nodes)}
    full_rows = np.cumsum(free) - 1
    rows = []
    for lab in fm.dofs:
        node, d = lab.split(":")
        rows.append(full_rows[3 * grid[tuple(np.round(xyz[int(node)], 9))] + "xyz".index(d)])
    vh = vh[np.array(rows)]
    for group in ([0, 1], [2], [3, 4], [5]):  # pairs of equal frequency: compare the planes they span
        Qa, Qh = np.linalg.qr(va[:, group])[0], np.linalg.qr(vh[:, group])[0]
        assert np.linalg.svd(Qa.T @ Qh, compute_uv=False).min() > 0.99


def _model(tmp_path, parameters: str, full=FULL) -> Path:
    shutil.copy(full, tmp_path / "beam.full")
    p = tmp_path / "beam.toml"
    p.write_text(f'[ansys]\nfull = "beam.full"\ndeck = "{CDB.as_posix()}"\n{parameters}', encoding="utf-8")
    return p


def _scaled_copy(src: Path, dst: Path, factor: float) -> None:
    """A copy of a .full file with its stiffness terms times ``factor`` (the same file written at a
    modulus ``factor`` times the first): the K block's records, equation by equation, are
    ``[n][flags] n row numbers [pad] [2n][flags] n doubles [pad]``."""
    from femupdate.io.ansys import _records

    head = _records(src, 2)[1]
    neqn, ptr = int(head[1]), int(head[18])
    data = bytearray(src.read_bytes())
    loc = 4 * ptr
    for _ in range(neqn):
        n = int(np.frombuffer(data, "<i4", 1, loc)[0])
        loc += 8 + 4 * n + 4 + 8
        vals = np.frombuffer(data, "<f8", n, loc) * factor
        data[loc:loc + 8 * n] = vals.tobytes()
        loc += 8 * n + 4
    dst.write_bytes(bytes(data))


def test_a_modulus_updated_from_the_file(tmp_path):
    from femupdate import MeasuredMode, TestData, model_modes, update

    p = _model(tmp_path, "[parameters.E]\nvalue = 1.0\nbounds = [0.5, 2.0]\nscales = \"K\"\n")
    m = load_model(p)
    assert len(m.nodes) == 300  # the archive's coordinates of the free nodes
    tm = model_modes(m, {"E": 1.21})
    data = TestData(modes=tuple(MeasuredMode(tm.eigenvalues[j]) for j in range(3)))  # frequencies, in order
    res = update(m, data)
    assert res.success
    assert res.parameters["E"] == pytest.approx(1.21, rel=1e-8)


def test_a_parameter_from_a_second_full_file(tmp_path):
    """dK/dE from two files written at E = 1 and E = 1.3: the model equals the file's K times E."""
    _scaled_copy(FULL, tmp_path / "beam_13.full", 1.3)
    p = _model(tmp_path, "[parameters.E]\nvalue = 1.0\nfull = \"beam_13.full\"\nfull_at = 1.3\n")
    m = load_model(p)
    ref = read_full(FULL)
    for e in (1.0, 0.8):
        K = m.with_values({"E": e}).K()
        assert abs(K - e * ref.K).max() <= 1e-9 * abs(ref.K).max()
    assert read_full(tmp_path / "beam_13.full").K.nnz == ref.K.nnz


def _patched(tmp_path, offset: int, value: int) -> Path:
    data = bytearray(FULL.read_bytes())
    data[offset:offset + 4] = np.int32(value).tobytes()
    out = tmp_path / "patched.full"
    out.write_bytes(bytes(data))
    return out


def test_bad_files_named(tmp_path):
    cut = tmp_path / "cut.full"
    cut.write_bytes(FULL.read_bytes()[:300_000])
    with pytest.raises(InputError, match=r"cut\.full is cut short .*copy the whole \.full file"):
        read_full(cut)
    (tmp_path / "head.full").write_bytes(FULL.read_bytes()[:600])
    with pytest.raises(InputError, match=r"head\.full: its headers do not read \(a file cut short, or not an ANSYS \.full file\)"):
        read_full(tmp_path / "head.full")
    # the full header (record 2, from byte 420): item 11 lumpm, item 14 keyuns
    with pytest.raises(InputError, match=r"holds a lumped mass matrix \(LUMPM,ON\), which femupdate does not read"):
        read_full(_patched(tmp_path, 420 + 4 * 10, 1))
    with pytest.raises(InputError, match=r"holds unsymmetric matrices \(NROPT,UNSYM\)"):
        read_full(_patched(tmp_path, 420 + 4 * 13, 1))
    # the dof list (record 3, from byte 412 + 8 + 4 * 100 + 4 + 8): TEMP (20) in place of UZ
    with pytest.raises(InputError, match=r"dof TEMP is not a displacement or rotation"):
        read_full(_patched(tmp_path, 412 + 8 + 400 + 4 + 8 + 8, 20))
    with pytest.raises(InputError, match=r"garbage\.full: its headers do not read"):
        (tmp_path / "garbage.full").write_bytes(b"\x01" * 4000)
        read_full(tmp_path / "garbage.full")
    with pytest.raises(InputError, match=r"not found"):
        read_full(tmp_path / "none.full")
    p = _model(tmp_path, "[parameters.E]\nvalue = 1.0\nscales = \"C\"\n")
    with pytest.raises(InputError, match=r"\[parameters\.E\]: scales must be \"K\" or \"M\""):
        load_model(p)


def test_without_the_package_the_reader_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ansys.mapdl.reader.full", None)  # import fails as if it were absent
    with pytest.raises(InputError, match=r"needs ansys-mapdl-reader: pip install ansys-mapdl-reader \(or "
                                         r"femupdate\[ansys\]\)"):
        read_full(FULL)


def test_cli_reads_the_file_and_refuses_a_cut_one(tmp_path, capsys):
    """``modes`` on an [ansys] model; a cut file exits 2 naming it; ``--write-model`` keeps the
    value the file was written at (exported_at), so the written model reloads to the update."""
    from femupdate.cli import main

    p = _model(tmp_path, "[parameters.E]\nvalue = 1.0\nbounds = [0.5, 2.0]\nscales = \"K\"\n")
    with pytest.raises(SystemExit) as info:
        main(["modes", str(p), "--n-modes", "3"])
    assert info.value.code == 0 and "1283.2" in capsys.readouterr().out
    (tmp_path / "beam.full").write_bytes(FULL.read_bytes()[:400_000])
    with pytest.raises(SystemExit) as info:
        main(["modes", str(p)])
    err = capsys.readouterr().err
    assert info.value.code == 2 and "beam.full is cut short" in err and "Traceback" not in err
    from femupdate.io.model_write import updated_model_text

    shutil.copy(FULL, tmp_path / "beam.full")
    (tmp_path / "out").mkdir()
    text = updated_model_text(p, tmp_path / "out" / "u.toml", {"E": 1.3}, {"command": "update"})
    (tmp_path / "out" / "u.toml").write_text(text)
    m = load_model(tmp_path / "out" / "u.toml")
    assert m.parameters[0].value == 1.3
    assert abs(m.K() - 1.3 * read_full(FULL).K).max() <= 1e-12 * abs(read_full(FULL).K).max()


def test_a_free_structure_of_another_mapdl_version():
    """tests/data/ansys/sparse.full (MAPDL 20.1, no constraints; MIT, from ansys-mapdl-reader's
    repository): a free body, so K r = 0 for the three rigid translations and K, M have exactly six
    eigenvalues at zero (below 1e-10 of the first elastic one); a wrong symmetrisation or dof map
    breaks both."""
    fm = read_full(Path(__file__).parent / "data" / "ansys" / "sparse.full")
    assert len(fm.dofs) == 345 and fm.constrained == () and fm.dofs[:3] == ("1:x", "1:y", "1:z")
    for d in "xyz":
        r = np.array([lab.endswith(":" + d) for lab in fm.dofs], float)
        assert np.abs(fm.K @ r).max() <= 1e-12 * abs(fm.K).max()
        assert r @ (fm.M @ r) > 0
    import scipy.linalg as la

    w = la.eigh(fm.K.toarray(), fm.M.toarray(), eigvals_only=True)
    assert np.all(np.abs(w[:6]) < 1e-10 * w[6]) and w[6] > 0
