"""Generators of test structures: sizes, parameters, definiteness, analytic spectra, the benchmark."""

from __future__ import annotations

import doctest
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

import femupdate.generators as gen
from femupdate import InputError
from femupdate.dofs import parse_dof
from femupdate.generators import chs_section, frame_lattice, shear_building, truss_lattice
from femupdate.modal import DENSE_LIMIT

ROOT = Path(__file__).resolve().parents[1]
EPS = np.finfo(float).eps


def _dense(model, values=None):
    return model.K(values).toarray(), model.M(values).toarray()


def _assert_spd(A, what):
    asym = np.max(np.abs(A - A.T))
    assert asym <= 10 * EPS * np.max(np.abs(A)), f"{what} not symmetric ({asym:.3g})"
    np.linalg.cholesky(A)  # raises LinAlgError unless positive definite


# ------------------------------------------------------------------ frame_lattice
@pytest.mark.parametrize("nx, ny, nz", [(2, 2, 2), (3, 2, 4), (1, 3, 3), (4, 3, 2)])
def test_frame_lattice_sizes_base(nx, ny, nz):
    m = frame_lattice(nx, ny, nz).build()
    assert m.n_dofs == 6 * nx * ny * (nz - 1)
    assert m.parameter_names == tuple(f"E_{s}" for s in range(1, nz))
    # the base (nodes 1 .. nx*ny) is fixed; the first free dof is the first node of level 1
    assert m.dofs[0] == f"{nx * ny + 1}:x" and m.dofs[-1] == f"{nx * ny * nz}:rz"


@pytest.mark.parametrize("parameters, count", [("storey", 3), ("storey_mass", 6), ("direction", 3), ("none", 0)])
def test_frame_lattice_parameter_counts(parameters, count):
    m = frame_lattice(3, 2, 4, parameters=parameters).build()
    assert len(m.parameters) == count
    if parameters == "storey_mass":
        assert m.parameter_names[:4] == ("E_1", "rho_1", "E_2", "rho_2")
        assert m.dM[1] is not None and m.dK[1] is None  # rho enters M only, E only K


def test_frame_lattice_direction_drops_absent_family():
    assert frame_lattice(1, 3, 3, parameters="direction").build().parameter_names == ("E_y", "E_z")


def test_frame_lattice_spd_after_supports():
    m = frame_lattice(3, 3, 3).build()
    K, M = _dense(m)
    _assert_spd(K, "K")
    _assert_spd(M, "M")


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_frame_lattice_free_free_has_six_rigid_modes(mass):
    m = frame_lattice(2, 2, 2, support="none", mass=mass).build()
    assert m.n_dofs == 6 * 8
    K, M = _dense(m)
    _assert_spd(M, "M")
    lam = sla.eigh(K, M, eigvals_only=True)
    assert np.sum(np.abs(lam) < 1e-8 * lam.max()) == 6
    assert np.all(lam > -1e-8 * lam.max())


def test_frame_lattice_storey_parameters_match_numeric_model():
    """Two routes: per-storey parameters at nominal values == all-numeric model."""
    Kp, Mp = _dense(frame_lattice(3, 2, 3, parameters="storey_mass").build())
    Kn, Mn = _dense(frame_lattice(3, 2, 3, parameters="none").build())
    np.testing.assert_allclose(Kp, Kn, rtol=0, atol=1e-12 * np.max(np.abs(Kn)))
    np.testing.assert_allclose(Mp, Mn, rtol=0, atol=1e-12 * np.max(np.abs(Mn)))


def test_frame_lattice_storey_stiffness_is_local():
    """dK/dE_s touches only the nodes of levels s-1 and s."""
    nx, ny, nz = 3, 2, 5
    m = frame_lattice(nx, ny, nz).build()
    level = np.array([(parse_dof(d)[0] - 1) // (nx * ny) for d in m.dofs])
    for j, name in enumerate(m.parameter_names):
        s = int(name.split("_")[1])
        rows, cols = m.dK_dp(j).nonzero()
        assert set(level[rows]) | set(level[cols]) == {s - 1, s} - {0}
    # ... and E_s multiplies all of the storey's axial and bending stiffness: K is affine in E
    p = m.values.copy()
    p[1] *= 1.3
    dK = m.K(p) - m.K()
    np.testing.assert_allclose(dK.toarray(), 0.3 * m.values[1] * m.dK_dp(1).toarray(), atol=1e-6)


def test_frame_lattice_geometry_and_bounds():
    s = frame_lattice(2, 2, 3, spacing=(2.0, 3.0, 4.0), bounds=(0.8, 1.25))
    assert s.nodes[1] == (0.0, 0.0, 0.0)
    assert s.nodes[2 * 2 * 3] == (2.0, 3.0, 8.0)
    assert s.parameters["E_1"].bounds == pytest.approx((0.8 * 210e9, 1.25 * 210e9))


def test_chs_section_against_tables():
    sec = chs_section()  # CHS 114.3 x 6.3: A = 21.4 cm^2, I = 313 cm^4 (EN 10210 tables)
    assert sec["A"] == pytest.approx(21.4e-4, rel=5e-3)
    assert sec["Iy"] == pytest.approx(313e-8, rel=5e-3)
    assert sec["J"] == pytest.approx(2 * sec["Iz"])


# ------------------------------------------------------------------ truss_lattice
@pytest.mark.parametrize("nx, ny", [(2, 2), (4, 3), (3, 5)])
def test_truss_lattice_sizes(nx, ny):
    m = truss_lattice(nx, ny).build()
    assert m.n_dofs == 2 * nx * (ny - 1)
    assert {parse_dof(d)[1] for d in m.dofs} == {"x", "y"}
    assert len(m.parameters) == ny - 1
    assert len(truss_lattice(nx, ny, parameters="storey_mass").build().parameters) == 2 * (ny - 1)
    assert len(truss_lattice(nx, ny, parameters="none").build().parameters) == 0


def test_truss_lattice_spd_and_fully_parametrised():
    m = truss_lattice(4, 4).build()
    K, M = _dense(m)
    _assert_spd(K, "K")
    _assert_spd(M, "M")
    assert m.K0.nnz == 0  # every rod's stiffness is E_s * (A / l) * unit: K = sum_s E_s K_s
    np.testing.assert_allclose(m.K(2 * m.values).toarray(), 2 * K, rtol=0, atol=1e-12 * np.max(np.abs(K)))


def test_truss_lattice_free_free_has_three_rigid_modes():
    m = truss_lattice(3, 3, support="none").build()
    assert m.n_dofs == 2 * 9
    K, M = _dense(m)
    lam = sla.eigh(K, M, eigvals_only=True)
    assert np.sum(np.abs(lam) < 1e-8 * lam.max()) == 3


# ------------------------------------------------------------------ shear_building
def test_shear_building_uniform_matches_closed_form():
    n, k, mass = 6, 2.0e7, 1.5e4
    m = shear_building(n, k=k, m=mass).build()
    assert m.n_dofs == n and m.parameter_names == tuple(f"k_{r}" for r in range(1, n + 1))
    K, M = _dense(m)
    lam = sla.eigh(K, M, eigvals_only=True)
    r = np.arange(1, n + 1)
    exact = 4 * k / mass * np.sin((2 * r - 1) * math.pi / (2 * (2 * n + 1))) ** 2
    np.testing.assert_allclose(lam, exact, rtol=1e-12)


def test_shear_building_matrices_nonuniform():
    k, mass = [3.0, 2.0, 1.0], [4.0, 5.0, 6.0]
    m = shear_building(3, k=k, m=mass, parameters="storey_mass").build()
    assert m.parameter_names == ("k_1", "m_1", "k_2", "m_2", "k_3", "m_3")
    K, M = _dense(m)
    np.testing.assert_array_equal(K, [[5.0, -2.0, 0.0], [-2.0, 3.0, -1.0], [0.0, -1.0, 1.0]])
    np.testing.assert_array_equal(M, np.diag(mass))
    assert m.K0.nnz == 0 and m.M0.nnz == 0
    assert shear_building(1, parameters="none").build().n_dofs == 1


def test_frame_lattice_members_object_and_keywords_build_the_same_model():
    """The members' fields as keywords (the older call) and as a FrameMembers give one model; the
    member changes it (an aluminium tube has the stiffness ratio E_al / E_steel in every K term)."""
    kw = frame_lattice(2, 2, 3, E=70e9, rho=2700.0).build()
    obj = frame_lattice(2, 2, 3, members=gen.FrameMembers(E=70e9, rho=2700.0)).build()
    mapping = frame_lattice(2, 2, 3, members={"E": 70e9, "rho": 2700.0}).build()
    steel = frame_lattice(2, 2, 3).build()
    for m in (obj, mapping):
        np.testing.assert_array_equal(m.K().toarray(), kw.K().toarray())
        np.testing.assert_array_equal(m.M().toarray(), kw.M().toarray())
    # E enters the axial and bending terms (G = E / 2(1 + nu) too): K scales by 70 / 210
    np.testing.assert_allclose(kw.K().toarray(), steel.K().toarray() * (70e9 / 210e9), rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(kw.M().toarray(), steel.M().toarray() * (2700.0 / 7850.0), rtol=1e-12, atol=1e-12)
    with pytest.raises(TypeError, match="'Ee'; did you mean 'E'"):
        frame_lattice(2, 2, 3, Ee=70e9)


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "call, word",
    [
        (lambda: frame_lattice(3, 3, 1), "nz"),
        (lambda: frame_lattice(1, 1, 3), "two nodes in plan"),
        (lambda: frame_lattice(2.5, 3, 3), "nx"),
        (lambda: frame_lattice(2, 2, 2, parameters="member"), "parameters"),
        (lambda: frame_lattice(2, 2, 2, support="top"), "support"),
        (lambda: frame_lattice(2, 2, 2, spacing=(1.0, -1.0, 1.0)), "spacing"),
        (lambda: frame_lattice(2, 2, 2, thickness=0.1), "thickness"),
        (lambda: frame_lattice(2, 2, 2, bounds=(1.2, 2.0)), "bounds"),
        (lambda: frame_lattice(2, 2, 2, E=-1.0), "E"),
        (lambda: frame_lattice(2, 2, 2, nu=0.5), "nu"),
        (lambda: frame_lattice(2, 2, 2, members=gen.FrameMembers(rho=0.0)), "rho"),
        (lambda: truss_lattice(1, 3), "nx"),
        (lambda: truss_lattice(3, 3, A=0.0), "A"),
        (lambda: shear_building(0), "n_storeys"),
        (lambda: shear_building(3, k=[1.0, 2.0]), "k"),
        (lambda: shear_building(2, m=[1.0, -2.0]), "storey 2"),
        (lambda: shear_building(2, k="stiff"), "k"),
    ],
)
def test_bad_input_names_the_argument(call, word):
    with pytest.raises(InputError, match=word):
        call()


def test_docstring_examples():
    result = doctest.testmod(gen, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 3 and result.failed == 0


# ------------------------------------------------------------------ benchmark smoke test
def test_bench_modes_quick_runs(tmp_path):
    out = tmp_path / "bench.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_modes.py"), "--quick", "--output", str(out)],
        capture_output=True, text=True, timeout=120, cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "eigenvalues (b) vs (c)" in proc.stdout
    res = json.loads(out.read_text())
    assert res["model"]["n_dofs"] > DENSE_LIMIT and res["model"]["modes_path"] == "sparse"
    assert res["eigen_check"]["ok"]
    assert set(res["phases"]) == {"generate", "build", "K_M_first", "K_M_again", "model_modes", "eigsh_baseline"}
