"""Abaqus ``.mtx`` files: assembled ``*MATRIX GENERATE`` output and ``*ELEMENT MATRIX OUTPUT``.

No file written by Abaqus itself ships with any package installable here, so the files are
written by this test in the documented formats (the matrix input format of ``*MATRIX INPUT``; the
``*USER ELEMENT, LINEAR`` format with the triangle stored by columns, as the results file's
records 1011/1021) from matrices that **OpenSees** assembles (an independent code: its
elasticBeamColumn elements with consistent mass, its own global assembly, read back with
``printA``).  The reader's model is then checked against femupdate's own beam elements and
against OpenSees' eigenvalues, and updated to known values.
"""

import ctypes
import os
from pathlib import Path

import numpy as np
import pytest

from femupdate import InputError, MeasuredMode, Structure, TestData, model_modes, update
from femupdate.io.abaqus import read_assembled, read_element_matrices
from femupdate.io.model_file import load_model

A, I, RHO = 4e-3, 2e-5, 7850.0
E = {"E_cols": 2.1e11, "E_beam": 2.0e11}
NODES = {1: (0.0, 0.0), 5: (0.0, 1.5), 2: (0.0, 3.0), 7: (2.0, 3.0), 3: (4.0, 3.0), 6: (4.0, 1.5), 4: (4.0, 0.0)}
SETS = {"cols": {11: (1, 5), 12: (5, 2), 13: (4, 6), 14: (6, 3)}, "beam": {21: (2, 7), 22: (7, 3)}}
DIRS = {"x": 1, "y": 2, "rz": 6}


def opensees():
    """OpenSeesPy, its bundled BLAS/LAPACK loaded first where the dynamic loader does not find them."""
    try:
        import openseespy.opensees as ops
        return ops
    except (ImportError, RuntimeError):
        pass
    try:
        import importlib.util

        spec = importlib.util.find_spec("openseespylinux")
        lib = Path(spec.origin).parent / "lib"
        for name in ("libquadmath.so.0", "libgfortran.so.4", "libgomp.so.1", "libblas.so.3", "liblapack.so.3"):
            if (lib / name).exists():
                ctypes.CDLL(os.fspath(lib / name), mode=ctypes.RTLD_GLOBAL)
        import openseespy.opensees as ops
        return ops
    except Exception:  # noqa: BLE001
        pytest.skip("OpenSeesPy is not installed or does not load (pip install openseespy)")


def ops_matrices(ops, nodes, elements, fix=()):
    """K, M assembled by OpenSees (A = m M + c C + k K of the GimmeMCK integrator) and the
    equation numbers of every node's dofs."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for t, (x, y) in nodes.items():
        ops.node(t, x, y)
    for t in fix:
        ops.fix(t, 1, 1, 1)
    ops.geomTransf("Linear", 1)
    for t, (i, j, e) in elements.items():
        ops.element("elasticBeamColumn", t, i, j, A, e, I, 1, "-mass", RHO * A, "-cMass")
    out = []
    for coef in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)):
        ops.wipeAnalysis()
        ops.constraints("Plain")
        ops.numberer("Plain")
        ops.system("FullGeneral")
        ops.algorithm("Linear")
        ops.integrator("GimmeMCK", *coef)
        ops.analysis("Transient")
        ops.analyze(1, 0.0)  # forms A; the solve of a singular K fails, as expected
        n = ops.systemSize()
        out.append(np.array(ops.printA("-ret")).reshape(n, n))
    return out[0], out[1], {t: ops.nodeDOFs(t) for t in nodes}


def dof_keys(eq):
    """(equation, node, Abaqus dof) for every free equation."""
    return sorted((q, t, [1, 2, 6][k]) for t, qs in eq.items() for k, q in enumerate(qs) if q >= 0)


def write_assembled(path, A, eq):
    """The matrix input format: one 'node, dof, node, dof, value' line per nonzero term of the
    lower triangle."""
    keys = dof_keys(eq)
    lines = ["** written by tests/test_abaqus.py in the matrix input format (no Abaqus run)"]
    for qa, na, da in keys:
        for qb, nb, db in keys:
            if qb <= qa and A[qa, qb] != 0.0:
                lines.append(f"{na},{da}, {nb},{db},  {A[qa, qb]:.17e}")
    path.write_text("\n".join(lines) + "\n")


def write_elements(path, ops, elements):
    """One block per element as *ELEMENT MATRIX OUTPUT, OUTPUT FILE=USER DEFINED writes it."""
    lines = []
    for t, (i, j, e) in elements.items():
        K, M, eq = ops_matrices(ops, {i: NODES[i], j: NODES[j]}, {t: (i, j, e)})
        order = [q for n in (i, j) for q in eq[n]]
        lines += [f"** ELEMENT NUMBER {t} STEP NUMBER 1 INCREMENT NUMBER 1", "** ELEMENT NODES", f"{i}, {j}",
                  "*USER ELEMENT, NODES=2, LINEAR", "1, 2, 6"]
        for kind, X in (("STIFFNESS", K), ("MASS", M)):
            X = X[np.ix_(order, order)]
            vals = [X[r, c] for c in range(6) for r in range(c + 1)]  # upper triangle by columns
            lines.append(f"*MATRIX, TYPE={kind}")
            lines += [", ".join(f"{v:.17e}" for v in vals[k:k + 4]) for k in range(0, len(vals), 4)]
    path.write_text("\n".join(lines) + "\n")


def all_elements():
    return {t: (i, j, E["E_cols"] if s == "cols" else E["E_beam"]) for s, els in SETS.items() for t, (i, j) in els.items()}


@pytest.fixture(scope="module")
def frame_files(tmp_path_factory):
    """The portal frame's files: assembled K and M (supports not applied: held in the model file),
    element matrices of the two sets, a deck of node coordinates."""
    ops = opensees()
    d = tmp_path_factory.mktemp("abaqus")
    K, M, eq = ops_matrices(ops, NODES, all_elements())
    write_assembled(d / "frame_STIF2.mtx", K, eq)
    write_assembled(d / "frame_MASS2.mtx", M, eq)
    for s, els in SETS.items():
        write_elements(d / f"{s}.mtx", ops, {t: (i, j, E[f"E_{s}"]) for t, (i, j) in els.items()})
    (d / "frame.inp").write_text("*HEADING\nportal frame\n*NODE\n" + "\n".join(
        f"{t}, {x}, {y}" for t, (x, y) in NODES.items()) + "\n*ELEMENT, TYPE=B23\n11, 1, 5\n")
    (d / "frame.toml").write_text(
        '[model]\nname = "portal frame from Abaqus"\n\n[abaqus]\nstiffness = "frame_STIF2.mtx"\n'
        'mass = "frame_MASS2.mtx"\nheld = [1, 4]\ndeck = "frame.inp"\n\n'
        '[parameters.E_cols]\nvalue = 2.1e11\nbounds = [1e11, 4e11]\nK_elements = "cols.mtx"\n\n'
        '[parameters.E_beam]\nvalue = 2.0e11\nbounds = [1e11, 4e11]\nK_elements = "beam.mtx"\n\n'
        '[parameters.rho_beam]\nvalue = 7850.0\nbounds = [4000.0, 12000.0]\nM_elements = "beam.mtx"\n')
    Kf, _, eqf = ops_matrices(ops, NODES, all_elements(), fix=(1, 4))
    ops.wipeAnalysis()
    lam = np.array(ops.eigen("-fullGenLapack", 6))
    ops.wipe()
    return d, lam


def femupdate_frame():
    """The same frame from femupdate's own beam elements (the independent assembly)."""
    s = Structure("portal frame")
    s.add_nodes(list(NODES), np.array(list(NODES.values())))
    s.parameter("E_cols", E["E_cols"], (1e11, 4e11))
    s.parameter("E_beam", E["E_beam"], (1e11, 4e11))
    s.parameter("rho_beam", RHO, (4000.0, 12000.0))
    for name, els in SETS.items():
        for i, j in els.values():
            s.beam2d((i, j), E=f"E_{name}", A=A, I=I, rho=RHO if name == "cols" else "rho_beam", mass="consistent")
    s.support_node([1, 4])
    return s.build()


def test_the_abaqus_files_give_the_frame_of_an_independent_assembly(frame_files):
    d, lam_opensees = frame_files
    model = load_model(d / "frame.toml")
    own = femupdate_frame()
    assert sorted(model.dofs) == sorted(own.dofs) and len(model.dofs) == 15
    assert model.nodes[7] == (2.0, 3.0, 0.0)
    idx = model.dof_index(own.dofs)
    for values in (None, {"E_cols": 2.6e11, "E_beam": 1.5e11, "rho_beam": 9000.0}):
        Ka, Ma = model.K(values).toarray()[np.ix_(idx, idx)], model.M(values).toarray()[np.ix_(idx, idx)]
        Ko, Mo = own.K(values).toarray(), own.M(values).toarray()
        assert np.abs(Ka - Ko).max() <= 1e-9 * np.abs(Ko).max()
        assert np.abs(Ma - Mo).max() <= 1e-9 * np.abs(Mo).max()
    modes = model_modes(model)
    np.testing.assert_allclose(modes.eigenvalues[:6], lam_opensees, rtol=1e-8)


def test_an_abaqus_model_updates_to_the_truth(frame_files):
    d, _ = frame_files
    model = load_model(d / "frame.toml")
    truth = {"E_cols": 2.4e11, "E_beam": 1.7e11, "rho_beam": 7850.0}
    tm = model_modes(femupdate_frame(), truth)
    own = femupdate_frame().dofs
    sensors = [k for k, dof in enumerate(own) if dof.endswith(":x") or dof.endswith(":y")]
    data = TestData(modes=tuple(MeasuredMode(tm.eigenvalues[j], tuple(own[k] for k in sensors), tm.shapes[sensors, j])
                                for j in range(5)))
    res = update(model.with_fixed(["rho_beam"]), data)
    assert res.success
    np.testing.assert_allclose(res.x, [truth["E_cols"], truth["E_beam"]], rtol=1e-7)


def test_the_element_triangle_is_read_by_columns(tmp_path):
    """(1,1), (1,2), (2,2), (1,3), (2,3), (3,3): the upper triangle stored by columns."""
    (tmp_path / "e.mtx").write_text("** ELEMENT NUMBER 9\n** ELEMENT NODES\n3\n*USER ELEMENT, NODES=1, LINEAR\n"
                                    "1, 2, 6\n*MATRIX, TYPE=STIFFNESS\n11., 12., 22., 13.\n23., 33.\n")
    (e,) = read_element_matrices(tmp_path / "e.mtx")
    np.testing.assert_array_equal(e.matrix, [[11, 12, 13], [12, 22, 23], [13, 23, 33]])
    assert e.dofs == ((3, "x"), (3, "y"), (3, "rz")) and e.element == "9"


def test_abaqus_hazards_are_refused_by_name(tmp_path):
    f = tmp_path / "K.mtx"
    for text, message in (
        ("1,1, 1,1, 2.0\n2,8, 1,1, 1.0\n", r"line 2: dof 8 at node 2 is not a displacement or rotation"),
        ("1,1, 1,1, 2.0\n-3,1, 1,1, 1.0\n", r"line 2: node -3 is an Abaqus internal node"),
        ("1, 1, 2.0\n", r"line 1: expected 'node, dof, node, dof, value'.*FORMAT=COORDINATE"),
        ("1,1, 1,1, 2.0\n1,1, 2,1, -1.0\n2,1, 1,1, -1.5\n2,1, 2,1, 2.0\n", r"\(1:x, 2:x\) = -1 and \(2:x, 1:x\) = -1\.5 differ"),
        ("1,1, 1,1, 2.0\n1,1, 1,1, 2.0\n", r"line 2: the term \(1:x, 1:x\) is given twice"),
        ("** nothing\n", r"holds no matrix terms"),
    ):
        f.write_text(text)
        with pytest.raises(InputError, match=message):
            read_assembled(f, "stiffness")
    f.write_text("1,1, 1,1, 2.0\n1,1, 2,1, -1.0\n2,1, 1,1, -1.0\n2,1, 2,1, 2.0\n")  # the square format: counted once
    terms = read_assembled(f)
    assert terms[((1, "x"), (2, "x"))] == -1.0 and len(terms) == 4
    (tmp_path / "e.mtx").write_text("** ELEMENT NUMBER 9\n** ELEMENT NODES\n3\n*USER ELEMENT, NODES=1, LINEAR\n1\n"
                                    "*MATRIX, TYPE=STIFFNESS\n1.0, 2.0\n")
    with pytest.raises(InputError, match=r"element 9 \(line 1\): 2 matrix values for 1 dofs"):
        read_element_matrices(tmp_path / "e.mtx")
    with pytest.raises(InputError, match=r"no \*MATRIX, TYPE=MASS \(request MASS=YES"):
        read_element_matrices(tmp_path / "e.mtx", "MASS")
    with pytest.raises(InputError, match=r"no element header"):
        read_element_matrices(f)
    from femupdate.io.abaqus import read_nodes

    (tmp_path / "d.inp").write_text("*NODE\n1, 0., 0.\n2, 1., 0.\n1, 2., 0.\n")
    with pytest.raises(InputError, match=r"d\.inp: line 4: node 1 is defined twice"):
        read_nodes(tmp_path / "d.inp")


def test_the_command_line_updates_an_abaqus_model_and_writes_it_back(frame_files, tmp_path, capsys):
    """femupdate update on the [abaqus] model file; the written model keeps the value the element
    matrices were exported at (exported_at), so it loads to the updated stiffness."""
    import json
    import tomllib

    from femupdate.cli import main

    d, _ = frame_files
    truth = {"E_cols": 2.4e11, "E_beam": 1.7e11}
    own = femupdate_frame()
    tm = model_modes(own, truth)
    keep = [k for k, dof in enumerate(own.dofs) if dof.endswith(":x") or dof.endswith(":y")]
    (tmp_path / "d.json").write_text(json.dumps({"modes": [
        {"eigenvalue": float(tm.eigenvalues[j]), "shape": {own.dofs[k]: float(tm.shapes[k, j]) for k in keep}}
        for j in range(5)]}))
    out = tmp_path / "out" / "updated.toml"
    out.parent.mkdir()
    with pytest.raises(SystemExit) as info:
        main(["update", str(d / "frame.toml"), str(tmp_path / "d.json"), "--params", "E_cols,E_beam",
              "--write-model", str(out)])
    assert info.value.code in (None, 0), capsys.readouterr().err
    raw = tomllib.loads(out.read_text())
    assert raw["parameters"]["E_cols"]["exported_at"] == 2.1e11
    assert raw["abaqus"]["stiffness"] == f"{os.path.relpath(d, out.parent)}/frame_STIF2.mtx"
    updated = load_model(out)
    np.testing.assert_allclose(updated.values[:2], [truth["E_cols"], truth["E_beam"]], rtol=1e-7)
    np.testing.assert_allclose(model_modes(updated).eigenvalues[:5], tm.eigenvalues[:5], rtol=1e-7)
