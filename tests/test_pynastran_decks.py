"""Decks written by pyNastran's BDF writer (tests/data/pynastran, written by make_decks.py there in a
throwaway environment; pyNastran is not needed here), read by femupdate: each equals the same model
built in Python with nodes placed by hand (the CORD2R grid rotated here, independently of the
reader), its small-field, large-field and double-precision versions agree, and the total mass is
the closed form."""

from pathlib import Path

import numpy as np
import pytest

import femupdate as fu

DATA = Path(__file__).parent / "data" / "pynastran"
E, NU, RHO, T = 2.1e11, 0.3, 7850.0, 0.01
FORMS = ("small", "large", "double")


def plate_twin(support: bool = True):
    """Deck (a): grid 7 is (1.5, -0.5, 0) in CORD2R 5 (origin (2, 0, 0), z = basic z, x along
    C - A = (4, 3, 0)): basic = A + 1.5 ex - 0.5 ey with ex = (0.8, 0.6, 0), ey = ez × ex."""
    ex = np.array([4.0, 3.0, 0.0]) / 5.0
    ey = np.cross([0.0, 0.0, 1.0], ex)
    x7 = np.array([2.0, 0.0, 0.0]) + 1.5 * ex - 0.5 * ey
    s = fu.Structure("plate")
    for i, x in {1: (0, 0, 0), 2: (1, 0, 0), 3: (2, 0, 0), 4: (0, 1, 0), 5: (1, 1, 0), 6: (2, 1, 0), 7: x7}.items():
        s.node(i, x)
    s.shell([[1, 2, 5, 4]], E=E, nu=NU, t=T, rho=RHO)
    s.shell([[2, 3, 6], [2, 6, 5], [3, 7, 6]], E=E, nu=NU, t=T, rho=RHO)
    s.point_mass(5, 2.5, offset=[0, 0, 0.1], inertia=np.diag([0.01, 0.02, 0.03]))
    if support:
        s.support_node([1, 4])
    return s.build()


def block_twin(support: bool = True):
    """Deck (b): a unit-cube hex, two tets to the apex (1.5, 0.5, 0.5) on its face x = 1, grids 6, 7,
    9 rigidly (x, y, z) on grid 10, a spring of 1e5 on 10:x to ground, the face x = 0 fixed in x, y, z."""
    s = fu.Structure("block")
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    for i, x in enumerate(corners + [(1.5, 0.5, 0.5), (2.5, 0.5, 0.5)], start=1):
        s.node(i, x)
    s.solid([[1, 2, 3, 4, 5, 6, 7, 8]], E=E, nu=NU, rho=RHO)
    s.solid([[2, 3, 7, 9], [2, 7, 6, 9]], E=E, nu=NU, rho=RHO)
    s.rigid_link(10, [6, 7, 9], dofs=["x", "y", "z"])
    s.spring(["10:x"], k=1e5)
    if support:
        s.support([f"{n}:{d}" for n in (1, 4, 5, 8) for d in "xyz"])
    return s.build()


def labels(model):
    return None if model.constraints is None else model.constraints.labels


def close(A, B, rtol=1e-12):
    return abs(A - B).max() <= rtol * abs(B).max()


@pytest.mark.parametrize("name,twin", [("plate", plate_twin), ("block", block_twin)])
def test_pynastran_deck_equals_the_python_model_in_every_field_format(name, twin):
    ref = twin()
    models = {f: fu.Structure.from_mesh(DATA / f"{name}_{f}.bdf").build() for f in FORMS}
    for form, a in models.items():
        assert a.dofs == ref.dofs and labels(a) == labels(ref), form
        assert close(a.K0, ref.K0) and close(a.M0, ref.M0), form
    small = models["small"]
    for form in FORMS[1:]:
        assert close(models[form].K0, small.K0, 1e-15) and close(models[form].M0, small.M0, 1e-15), form


@pytest.mark.parametrize("name,twin,mass", [("plate", plate_twin, RHO * T * 2.75 + 2.5),  # 2.75 m² of plate
                                            ("block", block_twin, RHO * (1 + 1 / 6))])  # cube + pyramid
def test_total_mass_of_the_unsupported_deck_is_the_closed_form(tmp_path, name, twin, mass):
    """The decks without SPC1: x-translation of every dof x gives r'Mr = the total mass."""
    text = (DATA / f"{name}_small.bdf").read_text()
    (tmp_path / "free.bdf").write_text("".join(l for l in text.splitlines(True) if not l.startswith("SPC1")))
    for model in (fu.Structure.from_mesh(tmp_path / "free.bdf").build(), twin(support=False)):
        r = np.array([d.endswith(":x") for d in model.dofs], dtype=float)
        assert abs(r @ (model.M0 @ r) - mass) <= 1e-12 * mass


def test_pynastran_plate_frequencies_equal_the_python_model_s():
    ref = fu.model_modes(plate_twin(), n_modes=6).eigenvalues
    for form in FORMS:
        lam = fu.model_modes(fu.Structure.from_mesh(DATA / f"plate_{form}.bdf").build(), n_modes=6).eigenvalues
        np.testing.assert_allclose(lam, ref, rtol=1e-10)
