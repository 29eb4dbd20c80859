"""The sparse path's reusable workspace (femupdate.workspace) and the warm-started eigensolver:
the same modes, derivatives and updated parameters as a fresh SuperLU factorisation at every
call, whichever route (band Cholesky, ordered SuperLU) the workspace takes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from femupdate import MeasuredMode, TestData, model_modes, settings
from femupdate.generators import frame_lattice
from femupdate.modal import DENSE_LIMIT, solve_modes
from femupdate.sensitivity import jacobian
from femupdate.updating import update
from femupdate import workspace
from femupdate.workspace import BandCholesky, CholmodFactor, OrderedLU, SparseWorkspace, workspace_of


def massless_rotations(model):
    """The model with its rotational inertia removed: lumped translational masses only (the
    rotations massless, as commercial codes export frame models)."""
    d = model.M(model.values).diagonal().copy()
    d[[lab.split(":")[1].startswith("r") for lab in model.dofs]] = 0.0
    assert all(a is None or a.nnz == 0 for a in model.dM)
    return dataclasses.replace(model, M0=sp.diags_array(d).tocsr())


@pytest.fixture(scope="module")
def tower():
    """1,566 dofs (above the dense limit), a narrow band: the band route."""
    m = massless_rotations(frame_lattice(3, 3, 30, spacing=(3.0, 3.0, 3.0), mass="lumped", parameters="direction",
                                         bounds=(0.2, 2.0)).build())
    assert m.n_dofs > DENSE_LIMIT
    return m


@pytest.fixture(scope="module")
def slab():
    """1,536 dofs, wide in plan (a wider band than the tower's)."""
    m = frame_lattice(8, 8, 5, parameters="direction").build()
    assert m.n_dofs > DENSE_LIMIT
    return m


def same_modes(a, b, rtol=1e-9):
    np.testing.assert_allclose(a.eigenvalues, b.eigenvalues, rtol=rtol)
    scale = np.max(np.abs(a.shapes), axis=0)
    assert np.max(np.abs(a.shapes - b.shapes) / scale) < 1e-6
    assert a.n_rigid == b.n_rigid


def needs(backend_name):
    """Skip where the backend is not installed (CHOLMOD: scikit-sparse; PARDISO: MKL)."""
    if backend_name == "cholmod":
        pytest.importorskip("sksparse.cholmod", reason="the CHOLMOD backend needs scikit-sparse (femupdate[cholmod])")
    if backend_name == "pardiso" and not workspace.pardiso_installed():
        pytest.skip("the PARDISO backend needs MKL (the mkl package)")


@pytest.fixture(params=["superlu", "cholmod", "pardiso"])
def backend(request):
    """Each factorisation backend in turn, installed as the process's setting (CHOLMOD skipped
    where scikit-sparse is missing, PARDISO where MKL is)."""
    needs(request.param)
    with settings.using(factorisation=request.param):
        assert workspace.backend() == request.param
        yield request.param


SPARSE_KIND = {"superlu": OrderedLU, "cholmod": CholmodFactor, "pardiso": workspace.PardisoFactor}


@pytest.mark.parametrize("which, prefer", [("tower", None), ("tower", "sparse"), ("slab", None), ("slab", "sparse")])
def test_each_route_gives_the_modes_of_a_fresh_factorisation(request, backend, which, prefer):
    model = request.getfixturevalue(which)
    p = model.values * np.linspace(0.6, 1.5, len(model.parameters))
    K, M = model.K(p), model.M(p)
    ws = SparseWorkspace(K, M, prefer=prefer)
    fresh = solve_modes(K, M, n_modes=8, dofs=model.dofs)
    first = solve_modes(K, M, n_modes=8, dofs=model.dofs, workspace=ws)  # the backend's factor, and the route chosen
    sparse = first.factor[0]  # the backend's own factor, whose fill the chooser weighed
    nnz_l = (sparse.nnz + model.n_dofs) // 2 if backend == "superlu" else sparse.nnz
    efficiency = workspace.routes.PARDISO_BAND_EFFICIENCY if backend == "pardiso" else workspace.BAND_EFFICIENCY
    band = workspace.band_wins(model.n_dofs, ws.bandwidth, nnz_l, efficiency)
    assert band or backend == "pardiso"  # against CHOLMOD and SuperLU the cost model takes the band for both
    route = "band" if prefer is None and band else backend
    assert ws.route == route
    again = solve_modes(K, M, n_modes=8, dofs=model.dofs, workspace=ws)
    assert isinstance(again.factor[0], BandCholesky if route == "band" else SPARSE_KIND[backend])
    same_modes(fresh, first)
    same_modes(fresh, again)
    # the factorisation solves K x = b to round-off, in the original order
    b = np.random.default_rng(1).standard_normal((model.n_dofs, 3))
    x = again.factor[0].solve(b)
    assert np.max(np.abs(K @ x - b)) < 1e-9 * np.max(np.abs(b))


def test_the_cost_model_against_counts_of_operations():
    """band_wins compares n b^2 with BAND_EFFICIENCY nnz(L)^2 / n, within the storage limit."""
    n = 10_000
    assert workspace.band_wins(n, 100, 400_000)  # 1e8 against 8 * 1.6e7
    assert not workspace.band_wins(n, 400, 400_000)  # 1.6e9 against 1.28e8
    assert not workspace.band_wins(10 ** 6, 200, 10 ** 9)  # storage 2e8 > MAX_BAND_ENTRIES, whatever the fill


def test_a_cholmod_factor_solves_and_reports_singularity(backend):
    if backend != "cholmod":
        pytest.skip("CHOLMOD only")
    A = sp.csc_array(sp.diags_array([2.0, 3.0, 4.0]) + sp.diags_array([-1.0, -1.0], offsets=1)
                     + sp.diags_array([-1.0, -1.0], offsets=-1))
    f = workspace.factorize(A)
    assert isinstance(f, CholmodFactor)
    b = np.array([1.0, 2.0, 3.0])
    np.testing.assert_allclose(A @ f.solve(b), b, rtol=1e-14)
    np.testing.assert_allclose(A @ f.solve(b * (1 + 2j)), b * (1 + 2j), rtol=1e-14)  # complex right-hand side
    assert not workspace.nearly_singular(f)
    S = sp.csc_array(np.array([[1.0, -1.0], [-1.0, 1.0]]))  # singular: Cholesky fails, LU (SuperLU) takes it
    with pytest.raises(workspace.NotPositiveDefinite):
        workspace.factorize(S, definite=True)
    with pytest.raises(RuntimeError):
        workspace.factorize(S)  # SuperLU: exactly singular
    indefinite = sp.csc_array(np.diag([1.0, -2.0, 3.0]))
    lu = workspace.factorize(indefinite)  # Cholesky fails: SuperLU
    assert not isinstance(lu, CholmodFactor)
    np.testing.assert_allclose(indefinite @ lu.solve(b), b, rtol=1e-14)


def test_an_unknown_backend_is_refused_by_name():
    from femupdate import InputError

    with pytest.raises(InputError, match="factorisation 'mumps': not a factorisation backend"):
        workspace.backend("mumps")
    with pytest.raises(InputError, match="factorisation='mumps': not a factorisation backend"):
        settings.Settings(factorisation="mumps")
    K = sp.csc_array(np.diag([2.0, 3.0]))
    with pytest.raises(InputError, match="'mumps'"):
        workspace.factorize(K, backend="mumps")
    with pytest.raises(InputError, match="'mumps'"):
        SparseWorkspace(K, K, backend="mumps")


@pytest.mark.parametrize("which", ["tower", "slab"])
def test_warm_start_and_its_shift_give_the_same_modes(request, which):
    model = request.getfixturevalue(which)
    p0 = model.values * np.linspace(0.6, 1.5, len(model.parameters))
    p1 = p0 * np.linspace(1.1, 0.9, len(model.parameters))
    prev = model_modes(model, p0, n_modes=8)
    model_modes(model, p0, n_modes=8)  # the route is chosen
    warm = model_modes(model, p1, n_modes=8, start=prev)
    assert warm.factor[1] > 0  # shifted toward the lowest mode
    same_modes(model_modes(model, p1, n_modes=8, reuse=False), warm)


@pytest.mark.parametrize("which", ["tower", "slab"])
def test_a_shift_above_the_lowest_mode_is_rejected_and_the_lowest_modes_are_found(request, which):
    model = request.getfixturevalue(which)
    p = model.values * np.array([0.5, 0.6, 0.55])  # E_x != E_y: no repeated modes of the square plan
    model_modes(model, p, n_modes=6)
    model_modes(model, p, n_modes=6)
    stiff = model_modes(model, model.values * 1.9, n_modes=6)  # its lowest eigenvalue is far above
    warm = model_modes(model, p, n_modes=6, start=stiff)
    assert warm.factor[1] == 0.0  # the shift from the start was refused, the solution repeated at 0
    same_modes(model_modes(model, p, n_modes=6, reuse=False), warm)


def test_rigid_body_modes_through_the_workspace():
    model = frame_lattice(2, 2, 64, parameters="direction", support="none").build()
    assert model.n_dofs > DENSE_LIMIT
    fresh = model_modes(model, n_modes=10, reuse=False)
    model_modes(model, n_modes=10)
    reused = model_modes(model, n_modes=10)
    assert fresh.n_rigid == reused.n_rigid == 6
    assert reused.factor[1] < 0
    np.testing.assert_allclose(reused.eigenvalues[6:], fresh.eigenvalues[6:], rtol=1e-9)


def test_the_workspace_is_only_used_for_its_own_pattern(tower):
    K, M = tower.K(), tower.M()
    ws = workspace_of(tower, K, M)
    assert ws is not None and ws.matches(K, M)
    other = frame_lattice(3, 3, 30, parameters="direction").build()  # the same size, another M pattern
    assert not ws.matches(other.K(), other.M())
    assert not ws.matches(sp.csc_array(K), M)  # another storage
    K2 = K.copy()
    K2.indices = K2.indices.copy()
    K2.indices[[0, 1]] = K2.indices[[1, 0]]  # the same size, a permuted pattern
    assert not ws.matches(K2, M)
    # a mismatched workspace is ignored: a fresh SuperLU factorisation, the same modes
    modes = solve_modes(other.K(), other.M(), n_modes=5, dofs=other.dofs, workspace=ws)
    same_modes(model_modes(other, n_modes=5, reuse=False), modes)
    assert not isinstance(modes.factor[0], (BandCholesky, OrderedLU))
    # one workspace per model: a model with other values is another model, with its own
    changed = tower.with_values({tower.parameter_names[0]: 2 * tower.values[0]})
    assert workspace_of(changed, changed.K(), changed.M()) is not ws
    assert workspace_of(tower, tower.K(tower.values * 1.3), tower.M()) is ws  # values change, the pattern does not


def test_derivatives_from_the_shifted_factorisation_match_the_fresh_ones(tower):
    p = tower.values * np.array([0.7, 1.3, 1.1])
    sensors = [d for d in tower.dofs if d.endswith((":x", ":y"))][::7]
    ref = model_modes(tower, p, n_modes=9, reuse=False)
    model_modes(tower, p, n_modes=9)
    warm = model_modes(tower, p, n_modes=9, start=model_modes(tower, p * 0.97, n_modes=9))
    assert warm.factor[1] > 0
    same_modes(ref, warm)
    for method in ("subspace", "adjoint"):
        a = jacobian(tower, ref, [0, 1, 2], sensors, values=p, method=method, shape_scaling="mass",
                     relative_eigenvalues=False)
        b = jacobian(tower, warm, [0, 1, 2], sensors, values=p, method=method, shape_scaling="mass",
                     relative_eigenvalues=False)
        np.testing.assert_allclose(b.dlam, a.dlam, rtol=1e-8)
        np.testing.assert_allclose(b.dpsi, a.dpsi, atol=1e-8 * np.max(np.abs(a.dpsi)))


def test_updating_with_and_without_reuse_reaches_the_same_solution(tower):
    truth = tower.values * np.array([0.8, 1.25, 0.9])
    sensors = [f"{n}:{d}" for n in range(10, 271, 18) for d in ("x", "y")]
    mm = model_modes(tower, truth, n_modes=6, reuse=False)
    pos = tower.dof_index(sensors)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], sensors, mm.shapes[pos, j]) for j in range(3)))
    x0 = dict(zip(tower.parameter_names, tower.values * np.array([1.3, 0.7, 1.2])))
    off = update(tower, data, x0=x0, reuse=False)
    on = update(tower, data, x0=x0)
    assert off.success and on.success
    np.testing.assert_allclose(on.x, off.x, rtol=1e-8)
    np.testing.assert_allclose(on.x, truth, rtol=1e-6)


def test_blocked_multi_column_solves_equal_the_column_by_column_ones(tower, monkeypatch):
    from femupdate.workspace import band

    monkeypatch.setattr(band, "BLOCKED_MIN_BANDWIDTH", 16)  # the tower's band (58) goes by blocks too
    p = tower.values * np.array([0.7, 1.3, 1.1])
    K, M = tower.K(p), tower.M(p)
    ws = SparseWorkspace(K, M)
    ws.factor(K, M, 0.0)
    lu = ws.factor(K, M, 1.0)
    assert isinstance(lu, BandCholesky) and lu.c.shape[0] - 1 >= band.BLOCKED_MIN_BANDWIDTH
    B = np.random.default_rng(2).standard_normal((tower.n_dofs, workspace.BLOCKED_MIN_COLUMNS + 3))
    X = lu.solve(B)  # by blocks
    assert lu._blk is not None
    X1 = np.column_stack([lu.solve(B[:, j]) for j in range(B.shape[1])])  # LAPACK pbtrs, one column each
    np.testing.assert_allclose(X, X1, rtol=0, atol=1e-11 * np.max(np.abs(X1)))
    A = (K - 1.0 * M).toarray()
    assert np.max(np.abs(A @ X - B)) <= 1e-14 * np.max(np.abs(A)) * np.max(np.abs(X)) * A.shape[0]


def test_one_sweep_for_all_modes_equals_one_sweep_per_mode(tower, monkeypatch):
    import importlib

    sub = importlib.import_module("femupdate.sensitivity.subspace")  # the module (the package exports the function)

    p = tower.values * np.array([0.7, 1.3, 1.1])
    model_modes(tower, p, n_modes=9)
    modes = model_modes(tower, p, n_modes=9, start=model_modes(tower, p * 1.02, n_modes=9))
    joint = sub.subspace_details(tower, modes, [0, 1, 2], None, p)
    monkeypatch.setattr(sub, "JOINT_MAX_ENTRIES", 0)
    apart = sub.subspace_details(tower, modes, [0, 1, 2], None, p)
    assert np.all(joint[2] == joint[2][0])  # one sweep: the same number of terms for every mode
    np.testing.assert_allclose(joint[0], apart[0], rtol=1e-12)
    np.testing.assert_allclose(joint[1], apart[1], rtol=0, atol=1e-9 * np.max(np.abs(apart[1])))


@pytest.mark.parametrize("prefer", [None, "sparse"])
def test_rigid_body_modes_and_updating_through_each_backend_and_route(backend, prefer):
    """A free frame (six rigid-body modes: K singular, Cholesky fails at shift 0 and the shift
    goes below zero) and an update of the tower, with the workspace on the band or on the
    backend's sparse factor: the same answers as a fresh SuperLU factorisation at every call."""
    free = frame_lattice(2, 2, 64, parameters="direction", support="none").build()
    workspace._WORKSPACES[free] = SparseWorkspace(free.K(), free.M(), prefer=prefer)
    fresh = model_modes(free, n_modes=10, reuse=False)
    model_modes(free, n_modes=10)
    reused = model_modes(free, n_modes=10)
    assert workspace._WORKSPACES[free].route == ("band" if prefer is None else backend)
    assert fresh.n_rigid == reused.n_rigid == 6 and reused.factor[1] < 0
    np.testing.assert_allclose(reused.eigenvalues[6:], fresh.eigenvalues[6:], rtol=1e-9)

    tower = massless_rotations(frame_lattice(3, 3, 30, spacing=(3.0, 3.0, 3.0), mass="lumped",
                                             parameters="direction", bounds=(0.2, 2.0)).build())
    workspace._WORKSPACES[tower] = SparseWorkspace(tower.K(), tower.M(), prefer=prefer)
    truth = tower.values * np.array([0.8, 1.25, 0.9])
    sensors = [f"{n}:{d}" for n in range(10, 271, 18) for d in ("x", "y")]
    mm = model_modes(tower, truth, n_modes=6, reuse=False)
    pos = tower.dof_index(sensors)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], sensors, mm.shapes[pos, j]) for j in range(3)))
    x0 = dict(zip(tower.parameter_names, tower.values * np.array([1.3, 0.7, 1.2])))
    on = update(tower, data, x0=x0)
    assert on.success and workspace._WORKSPACES[tower].route == ("band" if prefer is None else backend)
    np.testing.assert_allclose(on.x, truth, rtol=1e-6)


def test_starts_in_local_processes_give_the_runs_of_one_process(tower):
    """multistart's per-start route on two local processes (the default for a model of this size on
    a machine with two cores or more) gives the runs of the sequential route, start by start."""
    from femupdate.updating import multistart
    from femupdate.updating.starts import local_jobs

    truth = tower.values * np.array([0.8, 1.25, 0.9])
    sensors = [f"{n}:{d}" for n in range(10, 271, 18) for d in ("x", "y")]
    mm = model_modes(tower, truth, n_modes=6, reuse=False)
    pos = tower.dof_index(sensors)
    data = TestData(modes=tuple(MeasuredMode(mm.eigenvalues[j], sensors, mm.shapes[pos, j]) for j in range(3)))
    one = multistart(tower, data, starts=4, seed=3, jobs=1)
    two = multistart(tower, data, starts=4, seed=3, jobs=2)
    np.testing.assert_array_equal(one.starts, two.starts)
    assert len(two.runs) == 4 and all(not isinstance(r, str) for r in two.runs)
    for a, b in zip(one.runs, two.runs):
        assert a.success == b.success
        np.testing.assert_allclose(b.x, a.x, rtol=1e-8)
    assert [s.count for s in one.solutions] == [s.count for s in two.solutions]
    assert all(c > 0 for c in two.cpu_seconds)  # recorded by the worker processes, which this one's clock misses
    assert local_jobs(tower, 1) == 1  # one start: no pool


# ---------------------------------------------------------------------------------- the route classes
def random_pencil(n=60, seed=0, arrow=False):
    """A random sparse SPD K (diagonally dominant) and SPD M whose pattern differs from K's (a
    diagonal and a few couplings of their own), so that K − σM lives on the union pattern;
    ``arrow``: K couples dof 0 to every other (a wide band, a sparse factor without fill)."""
    rng = np.random.default_rng(seed)
    if arrow:
        A = sp.coo_array((rng.uniform(0.1, 1.0, n - 1), (np.zeros(n - 1, int), np.arange(1, n))), shape=(n, n))
    else:
        A = sp.random_array((n, n), density=0.06, random_state=rng) + sp.diags_array(rng.uniform(0.1, 1, n - 1), offsets=1)
    A = sp.csr_array(A + A.T)
    K = sp.csr_array(A + sp.diags_array(np.abs(A).sum(axis=1) + 2.0))
    C = sp.random_array((n, n), density=0.02, random_state=rng) * 0.1
    M = sp.csr_array(C + C.T + sp.diags_array(rng.uniform(1.0, 2.0, n)))
    K.sort_indices()
    M.sort_indices()
    return K, M


def route_of(kind, K, M):
    """A route of ``kind`` made directly (not by the chooser), and the pattern."""
    from femupdate.workspace import band, routes

    pattern = routes.Pattern(K, M)
    union = pattern.union()
    perm, b = band.band_order(union, pattern.n)
    if kind == "band":
        return routes.BandRoute(pattern, perm, b)
    if kind == "superlu":
        return routes.SuperLURoute(pattern, union, workspace.superlu(K).perm_c, b)
    needs(kind)
    return (routes.CholmodRoute if kind == "cholmod" else routes.PardisoRoute).analyse(pattern, b, K, M, 0.0)[0]


@pytest.mark.parametrize("kind, name", [("band", "band Cholesky"), ("superlu", "SuperLU"),
                                        ("cholmod", "CHOLMOD Cholesky"), ("pardiso", "PARDISO Cholesky")])
@pytest.mark.parametrize("seed", [0, 1])
def test_each_route_solves_as_a_dense_solve(kind, name, seed):
    K, M = random_pencil(seed=seed)
    route = route_of(kind, K, M)
    assert route.name == kind
    B = np.random.default_rng(10 + seed).standard_normal((K.shape[0], 5))
    for sigma in (0.0, 0.3, -0.5):
        A = (K - sigma * M).toarray()
        f = route.factor(K, M, sigma)
        assert isinstance(f, workspace.Factor) and f.name == name == workspace.factor_name(f)
        X = np.linalg.solve(A, B)
        np.testing.assert_allclose(f.solve(B), X, rtol=0, atol=1e-12 * np.max(np.abs(X)))
        np.testing.assert_allclose(f.solve(B[:, 2]), X[:, 2], rtol=0, atol=1e-12 * np.max(np.abs(X)))
        assert not f.nearly_singular()


@pytest.mark.parametrize("backend_name", ["superlu", "cholmod", "pardiso"])
def test_each_factorisation_of_one_matrix_solves_as_a_dense_solve(backend_name):
    needs(backend_name)
    K, M = random_pencil(seed=3)
    B = np.random.default_rng(4).standard_normal((K.shape[0], 3))
    f = workspace.factorize(K, definite=True, backend=backend_name)
    assert isinstance(f, workspace.Factor)
    assert f.name == {"cholmod": "CHOLMOD Cholesky", "pardiso": "PARDISO Cholesky"}.get(backend_name, "SuperLU")
    np.testing.assert_allclose(f.solve(B), np.linalg.solve(K.toarray(), B), rtol=1e-12, atol=0)
    Z = (K - 40.0 * M).toarray()  # indefinite: LU whatever the backend
    lu = workspace.factorize(sp.csc_array(Z), definite=False, backend=backend_name)
    assert lu.name == "SuperLU"
    np.testing.assert_allclose(lu.solve(B), np.linalg.solve(Z, B), rtol=1e-10, atol=0)


@pytest.mark.parametrize("backend_name", ["superlu", "cholmod", "pardiso"])
@pytest.mark.parametrize("arrow, chosen", [(False, "band"), (True, "sparse")])
def test_the_chooser_takes_the_route_the_operation_counts_say(backend_name, arrow, chosen):
    """The first factorisation chooses once, by band_wins on the band ordering's bandwidth and the
    backend's fill: a narrow pattern goes to the band, an arrow (wide band, no fill) stays sparse."""
    from femupdate.workspace import band

    needs(backend_name)
    K, M = random_pencil(n=200, seed=2, arrow=arrow)
    if backend_name == "pardiso" and not arrow:  # PARDISO runs as fast as the band: a chain for the band to win
        K = sp.csr_array(sp.diags_array([-np.ones(199), 2.5 * np.ones(200), -np.ones(199)], offsets=[-1, 0, 1]))
        M = sp.csr_array(sp.diags_array(np.linspace(1.0, 2.0, 200)))
    n = K.shape[0]
    _, b = band.band_order(sp.csr_array(K + M), n)
    sparse = workspace.factorize(K, definite=True, backend=backend_name)
    nnz_l = sparse.nnz if backend_name != "superlu" else (sparse.nnz + n) // 2
    efficiency = workspace.routes.PARDISO_BAND_EFFICIENCY if backend_name == "pardiso" else workspace.BAND_EFFICIENCY
    expected = "band" if workspace.band_wins(n, b, nnz_l, efficiency) else backend_name
    assert expected == ("band" if chosen == "band" else backend_name)
    ws = SparseWorkspace(K, M, backend=backend_name)
    assert ws.route is None
    first = ws.factor(K, M, 0.0)
    assert first.name == sparse.name  # the backend's own factor made the choice
    assert (ws.route, ws.bandwidth, ws.backend) == (expected, b, backend_name)
    # imposed routes, and the band refused beyond its storage limit whatever is preferred
    for prefer, route in (("band", "band"), ("sparse", backend_name)):
        imposed = SparseWorkspace(K, M, prefer=prefer, backend=backend_name)
        imposed.factor(K, M, 0.0)
        assert imposed.route == route


def test_the_band_is_refused_beyond_its_storage_limit_even_when_preferred(monkeypatch):
    from femupdate.workspace import routes

    K, M = random_pencil()
    monkeypatch.setattr(routes, "MAX_BAND_ENTRIES", K.shape[0] - 1)
    ws = SparseWorkspace(K, M, prefer="band", backend="superlu")
    ws.factor(K, M, 0.0)
    assert ws.route == "superlu"


def test_the_route_is_chosen_once_and_refactorises_with_new_values(monkeypatch):
    from femupdate.workspace import routes

    calls = []

    def counted(*args):
        calls.append(args[-2:])
        return routes.choose_route(*args)

    monkeypatch.setattr(workspace, "choose_route", counted)
    K, M = random_pencil(seed=5)
    ws = SparseWorkspace(K, M, backend="superlu")
    ws.factor(K, M, 0.0)
    route = ws._route
    B = np.random.default_rng(6).standard_normal(K.shape[0])
    for scale, sigma in ((1.5, 0.2), (0.7, -1.0)):
        K2 = K.copy()
        K2.data = K.data * scale  # new values, the same pattern
        f = ws.factor(K2, M, sigma)
        np.testing.assert_allclose(f.solve(B), np.linalg.solve((K2 - sigma * M).toarray(), B), rtol=1e-11)
    assert calls == [("superlu", None)] and ws._route is route and ws.n_factorisations == 3
