"""Matrices as commercial FE codes export them: massless (rotational) dofs, and rigid links
modelled as penalty springs.

References: SciPy's QZ generalised eigenvalues of the full singular pencil (an independent route
that never condenses), central finite differences of the update Jacobian, and closed-form
frequencies of a spring-mass system.
"""

import numpy as np
import pytest
import scipy.linalg as sla

from femupdate import InputError, MeasuredMode, Parameter, Structure, TestData, model_modes, rules, solve_modes, update
from femupdate.model import from_matrices
from femupdate.updating import Problem, multistart

E = (2.1e11, 1.8e11, 2.4e11)


def frame_without_rotational_mass():
    """A 12-element cantilever in three modulus groups whose exported mass matrix has no
    rotational inertia (the rows of the rz dofs are zero), as from_matrices receives it."""
    s = Structure("cantilever")
    n_el = 12
    x = np.linspace(0.0, 2.4, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    for g, value in enumerate(E):
        s.parameter(f"E{g + 1}", value, (0.3 * value, 3 * value))
    for e in range(n_el):
        s.beam2d((e, e + 1), E=f"E{e // 4 + 1}", A=1e-3, I=8.33e-8, rho=7850.0, mass="lumped")
    s.support_node([0])
    m = s.build()
    L = len(m.parameter_names)
    K0 = m.K(np.zeros(L)).toarray()
    dK = [m.K(np.eye(L)[j]).toarray() - K0 for j in range(L)]
    M = m.M(m.values).toarray()
    rot = np.array([d.endswith("rz") for d in m.dofs])
    M[rot, :] = 0.0
    M[:, rot] = 0.0
    params = [Parameter(n, v, (0.3 * v, 3 * v)) for n, v in zip(m.parameter_names, m.values)]
    return from_matrices(m.dofs, K0, M, params, dK=dK, name="exported cantilever"), rot


def qz_frequencies(K, M, n):
    w = sla.eig(K, M, right=False)
    w = np.sort(w.real[np.isfinite(w) & (np.abs(w) < 1e30)])
    return w[:n]


def test_massless_dofs_give_the_finite_eigenvalues_of_the_singular_pencil():
    model, rot = frame_without_rotational_mass()
    modes = model_modes(model)
    assert modes.n_modes == int((~rot).sum())  # one finite mode per dof with mass
    K, M = model.K(model.values).toarray(), model.M(model.values).toarray()
    np.testing.assert_allclose(modes.eigenvalues[:6], qz_frequencies(K, M, 6), rtol=1e-9)
    # mass-normalised on the full dofs, and satisfying the full pencil's equation
    Phi = modes.shapes
    np.testing.assert_allclose(Phi.T @ M @ Phi, np.eye(Phi.shape[1]), atol=1e-9)
    np.testing.assert_allclose(K @ Phi[:, :6], M @ Phi[:, :6] * modes.eigenvalues[:6], atol=1e-6 * np.abs(K).max())
    sparse = solve_modes(model.K(model.values), model.M(model.values), n_modes=6, dofs=model.dofs, method="sparse")
    np.testing.assert_allclose(sparse.eigenvalues, modes.eigenvalues[:6], rtol=1e-9)


def test_a_model_with_massless_dofs_updates_without_hand_made_changes():
    model, rot = frame_without_rotational_mass()
    truth = np.array(E) * np.array([1.15, 0.9, 1.05])
    tm = model_modes(model, truth)
    sensors = [i for i, d in enumerate(model.dofs) if d.endswith(":y")][1::2]
    data = TestData(modes=tuple(MeasuredMode(tm.eigenvalues[j], tuple(model.dofs[i] for i in sensors),
                                             tm.shapes[sensors, j]) for j in range(4)))
    prob = Problem(model, data)
    x = prob.x_start
    J = prob.jacobian(x)
    # the beam's spectrum spans 4e6: eigenvalue round-off makes central differences noisy below
    # h = 1e-4 (their error grows as 1/h), so h = 1e-3, where truncation (h²) leaves about 2e-7
    h = 1e-3
    fd = np.column_stack([(prob.residuals(x + h * e) - prob.residuals(x - h * e)) / (2 * h) for e in np.eye(x.size)])
    assert np.abs(J - fd).max() <= 1e-5 * np.abs(J).max()
    res = update(model, data)
    assert res.success
    np.testing.assert_allclose(res.x, truth, rtol=1e-7)
    ms = multistart(model, data, starts=4, seed=0)  # the compiled route needs a definite M: per start
    assert ms.converged == 4 and type(ms.runs[0]).__name__ == "UpdateResult"
    np.testing.assert_allclose(ms.best.x, truth, rtol=1e-7)


def test_massless_dofs_without_stiffness_are_refused_by_name():
    K = np.diag([2.0, 1.0, 0.0])
    M = np.diag([1.0, 1.0, 0.0])
    with pytest.raises(InputError, match="massless dof.*3:x.*not held"):
        solve_modes(K, M, dofs=("1:x", "2:x", "3:x"))
    with pytest.raises(InputError, match="no positive mass at dof.*2:x"):
        solve_modes(np.eye(2), np.array([[1.0, 0.5], [0.5, 0.0]]), dofs=("1:x", "2:x"))


@pytest.mark.parametrize("penalty", [1e8, 1e10])
def test_a_penalty_link_does_not_turn_the_first_mode_into_a_rigid_body_mode(penalty):
    """Ground spring k, mass m1, linked rigidly (penalty) to a nearly massless point m2: the first
    mode is sqrt(k / (m1 + m2)), not 0 Hz."""
    k, m1, m2 = 1e4, 10.0, 1e-8
    K = np.array([[k + penalty, -penalty], [-penalty, penalty]])
    M = np.diag([m1, m2])
    modes = solve_modes(K, M, dofs=("1:x", "2:x"))
    assert modes.n_rigid == 0
    assert modes.eigenvalues[0] == pytest.approx(k / (m1 + m2), rel=1e-5)
    free = np.array([[penalty, -penalty], [-penalty, penalty]])  # no ground spring: truly rigid
    rigid = solve_modes(free, M, dofs=("1:x", "2:x"))
    assert rigid.n_rigid == 1 and rigid.eigenvalues[0] == 0.0


@pytest.mark.parametrize("penalty", [1e8, 1e10])
def test_the_compiled_route_tells_a_penalty_linked_mode_from_a_rigid_body_mode(penalty):
    """A chain k1 - m1 = (penalty link) = m2 - k2 - m3 with a nearly massless m2, updated by
    multi-start on the compiled route: its first mode is elastic.  The pencil-scale test (max
    K_ii / M_ii = penalty / m2) called it a rigid-body mode, and every start failed ("mode 1 is a
    rigid-body mode").  Now both routes compute the same eigenvalues and every start runs."""
    from femupdate.updating.batched import BatchedProblem

    k1, k2, m = 1e4, 2e4, (10.0, 1e-8, 5.0)
    dofs = ("1:x", "2:x", "3:x")
    link = np.zeros((3, 3))
    link[np.ix_([0, 1], [0, 1])] = [[penalty, -penalty], [-penalty, penalty]]
    dK1 = np.zeros((3, 3))
    dK1[0, 0] = 1.0
    dK2 = np.zeros((3, 3))
    dK2[np.ix_([1, 2], [1, 2])] = [[1.0, -1.0], [-1.0, 1.0]]
    model = from_matrices(dofs, link, np.diag(m), [Parameter("k1", k1, (1e3, 1e5)), Parameter("k2", k2, (1e3, 1e5))],
                          dK=[dK1, dK2])
    mm = model_modes(model)
    assert mm.n_rigid == 0 and mm.eigenvalues[0] > 0
    assert max(abs(np.diag(link + k1 * dK1 + k2 * dK2)) / m) * rules.RIGID_TOL > mm.eigenvalues[0]  # the old test's trap
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], ["1:x", "3:x"], mm.shapes[[0, 2], j]) for j in range(2)))
    starts = np.array([[2e4, 1e4], [5e3, 4e4], [1.2e4, 2.2e4]])
    bp = BatchedProblem.from_problem(Problem(model, data), starts)
    ev = bp.evaluate(bp.x_start, np.arange(3))
    for r in range(3):
        local = model_modes(model, dict(zip(model.parameter_names, starts[r])))
        assert ev.messages[r] is None
        assert ev.eigenvalues[r, 0] > 0
        # the same pencil reduced the same way (Cholesky of the diagonal M): the same eigenvalues
        np.testing.assert_allclose(ev.eigenvalues[r, :2], local.eigenvalues[:2], rtol=1e-9)
    a = multistart(model, data, starts=6, seed=2, batched=True)
    assert a.converged == 6 and not a.failures


# ------------------------------------------------------------------ hazards of exported files
import logging  # noqa: E402

import scipy.io  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from femupdate.io.model_file import load_model  # noqa: E402
from femupdate.penalty import PENALTY_RATIO, find_penalty_links  # noqa: E402


def chain_K(n=6, k=2000.0, link=None, penalty=0.0):
    """A grounded chain of n unit masses and springs k; the spring of the pair ``link`` replaced
    by a penalty spring."""
    K = np.zeros((n, n))
    K[0, 0] = k
    for i in range(n - 1):
        s = penalty if link == (i, i + 1) else k
        K[np.ix_([i, i + 1], [i, i + 1])] += s * np.array([[1.0, -1.0], [-1.0, 1.0]])
    return K


def write_mtx(path, A, header="coordinate real general", triangle="both"):
    """Matrix Market text as an exporter writes it, one entry per line (1-based)."""
    C = sp.coo_array(A)
    keep = {"both": C.row >= 0, "lower": C.row >= C.col, "upper": C.row <= C.col}[triangle]
    rows = [f"{i + 1} {j + 1} {float(v)!r}" for i, j, v in zip(C.row[keep], C.col[keep], C.data[keep])]
    path.write_text(f"%%MatrixMarket matrix {header}\n% written by an exporter\n{A.shape[0]} {A.shape[1]} "
                    f"{len(rows)}\n" + "\n".join(rows) + "\n")


def matrix_toml(tmp_path, n, K="K0.mtx", M="M0.mtx", dofs=None, extra=""):
    labels = dofs if dofs is not None else [f"{i + 1}:x" for i in range(n)]
    (tmp_path / "m.toml").write_text(f'[matrices]\ndofs = {labels!r}\nK0 = "{K}"\nM0 = "{M}"\n'.replace("'", '"')
                                     + extra)
    return tmp_path / "m.toml"


def test_a_symmetric_header_over_both_triangles_is_refused_naming_the_file_and_an_entry(tmp_path):
    """SciPy mirrors every stored entry of a symmetric file, so a file that stores both triangles
    would have its off-diagonal terms doubled (an indefinite chain here): refused."""
    K = chain_K()
    write_mtx(tmp_path / "K0.mtx", K, "coordinate real symmetric", "both")
    write_mtx(tmp_path / "M0.mtx", np.eye(6), "coordinate real symmetric", "lower")
    with pytest.raises(InputError, match=r"K0\.mtx is declared symmetric but stores both triangles \(line \d+: "
                                         r"entry \(1, 2\) above the diagonal; its mirror entry is also stored\)"):
        load_model(matrix_toml(tmp_path, 6))
    # one triangle (either), as the format has it, is the file's matrix
    for triangle in ("lower", "upper"):
        write_mtx(tmp_path / "K0.mtx", K, "coordinate real symmetric", triangle)
        model = load_model(matrix_toml(tmp_path, 6))
        np.testing.assert_array_equal(model.K().toarray(), K)
    scipy.io.mmwrite(tmp_path / "K0.mtx", sp.coo_array(K), symmetry="symmetric")  # SciPy's own writer
    np.testing.assert_array_equal(load_model(matrix_toml(tmp_path, 6)).K().toarray(), K)


def test_pattern_and_complex_files_are_refused_and_a_zero_imaginary_part_is_said(tmp_path, caplog):
    K = chain_K()
    write_mtx(tmp_path / "M0.mtx", np.eye(6))
    write_mtx(tmp_path / "K0.mtx", K)
    text = (tmp_path / "K0.mtx").read_text().splitlines()
    pattern = [text[0].replace("real", "pattern"), *text[1:3], *(" ".join(ln.split()[:2]) for ln in text[3:])]
    (tmp_path / "K0.mtx").write_text("\n".join(pattern) + "\n")
    with pytest.raises(InputError, match=r"K0\.mtx is a 'pattern' file"):
        load_model(matrix_toml(tmp_path, 6))
    for imag, expect in ((0.0, None), (30.0, r"K0\.mtx holds complex values \(line \d+: imaginary part 30\)")):
        rows = [text[0].replace("real", "complex"), *text[1:3]]
        rows += [f"{ln} {imag if ln.split()[0] != ln.split()[1] else 0.0}" for ln in text[3:]]
        (tmp_path / "K0.mtx").write_text("\n".join(rows) + "\n")
        if expect:
            with pytest.raises(InputError, match=expect):
                load_model(matrix_toml(tmp_path, 6))
        else:
            with caplog.at_level(logging.WARNING):
                model = load_model(matrix_toml(tmp_path, 6))
            np.testing.assert_array_equal(model.K().toarray(), K)
            assert any("imaginary parts are all zero: read as real" in r.getMessage() and "K0.mtx" in r.getMessage()
                       for r in caplog.records)
    np.save(tmp_path / "K0.npy", K * (1 + 0.02j))  # structural damping as an imaginary stiffness
    with pytest.raises(InputError, match=r"K0\.npy holds a complex matrix"):
        load_model(matrix_toml(tmp_path, 6, K="K0.npy"))


def test_index_bases_sizes_and_duplicate_dofs_are_refused_by_name(tmp_path):
    K = chain_K()
    write_mtx(tmp_path / "M0.mtx", np.eye(6))
    text = ["%%MatrixMarket matrix coordinate real general", "6 6 6"] + [f"{i} {i} {float(K[i, i])!r}" for i in range(6)]
    (tmp_path / "K0.mtx").write_text("\n".join(text) + "\n")  # written from 0
    with pytest.raises(InputError, match=r"K0\.mtx: line 3: row index 0 outside 1\.\.6 \(Matrix Market counts from "
                                         r"1: the file looks written with 0-based indices\)"):
        load_model(matrix_toml(tmp_path, 6))
    # a 0-based writer that kept the 1-based node numbers: one row too many, the first empty
    big = np.zeros((7, 7))
    big[1:, 1:] = K
    write_mtx(tmp_path / "K0.mtx", big)
    with pytest.raises(InputError, match=r"K0 \(K0\.mtx\): a matrix of shape \(7, 7\), but the model has 6 dofs "
                                         r"\(the dofs list\); its first row and column are empty"):
        load_model(matrix_toml(tmp_path, 6))
    write_mtx(tmp_path / "K0.mtx", K)
    (tmp_path / "dofs.txt").write_text("1:x\n2:x\n3:x\n4:x\n2:1\n6:x\n")  # 2:1 is 2:x in Nastran's numbering
    (tmp_path / "m.toml").write_text('[matrices]\ndofs = "dofs.txt"\nK0 = "K0.mtx"\nM0 = "M0.mtx"\n')
    with pytest.raises(InputError, match=r"dofs file dofs\.txt.*2:x"):
        load_model(tmp_path / "m.toml")


def test_an_indefinite_stiffness_is_refused_naming_its_files(tmp_path):
    K = chain_K()
    K[2, 3] = K[3, 2] = 2 * K[2, 3]  # a term counted twice by a faulty export
    write_mtx(tmp_path / "K0.mtx", K)
    write_mtx(tmp_path / "M0.mtx", np.eye(6))
    assert np.linalg.eigvalsh(K)[0] < 0
    with pytest.raises(InputError, match=r"the stiffness of K0\.mtx at the nominal parameter values is not positive "
                                         r"semi-definite \(negative eigenvalue -"):
        load_model(matrix_toml(tmp_path, 6))


def tied_reference(k=2000.0, n=6, link=(2, 3)):
    """The chain with the link as an exact tie u_3 = u_4, assembled directly on 5 dofs: springs
    between consecutive kept dofs, the tied node's mass doubled (a second route to the answer)."""
    m = n - 1
    K = np.zeros((m, m))
    K[0, 0] = k
    for i in range(m - 1):
        K[np.ix_([i, i + 1], [i, i + 1])] += k * np.array([[1.0, -1.0], [-1.0, 1.0]])
    M = np.eye(m)
    M[link[0], link[0]] = 2.0
    return sla.eigh(K, M, eigvals_only=True)


@pytest.mark.parametrize("penalty", [1e12, 4e12, 1e14, 1e20])
def test_a_penalty_tie_is_eliminated_exactly_and_updates(tmp_path, penalty):
    """A rigid link by penalty on a grounded chain: tied exactly (5 dofs), the eigenvalues those of
    the chain assembled with the tie; before, the 6-dof pencil kept the penalty's 1/P error and its
    spurious sixth mode (at 1e14 and 1e20, rigid-body modes).  The penalty is stored in K0 alone,
    the springs in the parameter's matrix, so no stored entry rounds one beside the other: even
    1e20 ties exactly.  An update from the tied model's own modes recovers the spring."""
    k = 2000.0
    K = chain_K(k=k, link=(2, 3), penalty=penalty)
    elastic = chain_K(k=1.0, link=(2, 3), penalty=0.0)  # dK/dk
    write_mtx(tmp_path / "K0.mtx", K - k * elastic)
    write_mtx(tmp_path / "Kk.mtx", elastic)
    write_mtx(tmp_path / "M0.mtx", np.eye(6))
    path = matrix_toml(tmp_path, 6, extra=f'[parameters.k]\nvalue = {k}\nbounds = [500.0, 8000.0]\nK = "Kk.mtx"\n')
    model = load_model(path)
    assert model.dofs == ("1:x", "2:x", "3:x", "5:x", "6:x")
    modes = model_modes(model)
    assert modes.n_rigid == 0 and modes.n_modes == 5
    np.testing.assert_allclose(modes.eigenvalues, tied_reference(k), rtol=1e-10)
    truth = model_modes(model, {"k": 1.3 * k})
    np.testing.assert_allclose(truth.eigenvalues, tied_reference(1.3 * k), rtol=1e-10)
    data = TestData(modes=tuple(MeasuredMode(truth.eigenvalues[j], ("2:x", "5:x", "6:x"), truth.shapes[[1, 3, 4], j])
                                for j in range(3)))
    res = update(model, data)
    assert res.success and res.x[0] == pytest.approx(1.3 * k, rel=1e-8)


@pytest.mark.parametrize("penalty", [1e14, 1e20])
def test_a_penalty_that_has_swallowed_the_elastic_terms_is_refused_naming_the_dofs(tmp_path, penalty):
    """1e20 + 2000 is 1e20: the file's own matrix has lost the elastic terms (five rigid-body modes
    at 0 Hz before); at 1e14 they are held to 1e-5 only (the first elastic mode was called a
    rigid-body mode).  Refused, by file and dofs, in the model file and in from_matrices."""
    K = chain_K(link=(2, 3), penalty=penalty)
    write_mtx(tmp_path / "K0.mtx", K)
    write_mtx(tmp_path / "M0.mtx", np.eye(6))
    with pytest.raises(InputError, match=r"the stiffness of K0\.mtx: a penalty link \(stiffness 1e\+(14|20), .*\) "
                                         r"ties 3:x, 4:x; .*multipoint constraint"):
        load_model(matrix_toml(tmp_path, 6))
    with pytest.raises(InputError, match=r"ties 3:x, 4:x"):
        from_matrices([f"{i + 1}:x" for i in range(6)], K, np.eye(6))


def test_a_penalty_with_a_lever_arm_is_refused_and_stiff_elastic_pairs_are_left_alone():
    """u_b = u_a + r θ_a by penalty couples b's translation to a's rotation: no tie of equal dofs,
    refused by name.  A lone spring (nothing else to compare with) and the beam models above are
    not penalties."""
    P, k, r = 1e15, 1e3, 0.5
    g = np.array([-1.0, -r, 1.0])  # constraint u_b - u_a - r θ_a = 0 on (a:x, a:rz, b:x)
    K = P * np.outer(g, g) + np.diag([k, k, k])
    with pytest.raises(InputError, match=r"joins 1:x, 1:rz, 2:x other than as equal motions"):
        from_matrices(["1:x", "1:rz", "2:x"], K, np.eye(3))
    assert not find_penalty_links(1e12 * np.array([[1.0, -1.0], [-1.0, 1.0]]))
    model, _ = frame_without_rotational_mass()
    assert not find_penalty_links(model.K()) and PENALTY_RATIO == 1e8


def test_the_command_line_refuses_a_hazard_with_exit_2_naming_the_file(tmp_path, capsys):
    from femupdate.cli import main

    K = chain_K()
    write_mtx(tmp_path / "K0.mtx", K, "coordinate real symmetric", "both")
    write_mtx(tmp_path / "M0.mtx", np.eye(6))
    with pytest.raises(SystemExit) as info:
        main(["modes", str(matrix_toml(tmp_path, 6))])
    err = capsys.readouterr().err
    assert info.value.code == 2 and "K0.mtx is declared symmetric but stores both triangles" in err
    assert "Traceback" not in err
