"""A mesh's declared unit system (``[mesh] units``, ``Structure.from_mesh(units=)``): the same plate
written in m-kg-s and in mm-t-s gives the same frequencies; parameters carry the system's units;
a modulus or density that contradicts the declared system is refused by name, exit 2, unless
``check_units = false``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse.linalg as ssl

from femupdate._errors import InputError
from femupdate.io.model_file import load_model
from femupdate.structure import Structure

ENV = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
# an aluminium plate 0.5 m x 0.4 m x 3 mm, clamped along x = 0, as (length scale, E, rho, t) per system
SI = (1.0, 7.0e10, 2700.0, 0.003)
MM = (1000.0, 7.0e4, 2.7e-9, 3.0)


def _deck(path: Path, system, n: int = 6) -> Path:
    """An Abaqus deck of n x n S4 shells in the given system (coordinates scaled by its length unit)."""
    scale, E, rho, t = system
    xs, ys = np.linspace(0, 0.5, n + 1) * scale, np.linspace(0, 0.4, n + 1) * scale
    node = lambda i, j: j * (n + 1) + i + 1  # noqa: E731
    nodes = [f"{node(i, j)}, {xs[i]:.17g}, {ys[j]:.17g}, 0." for j in range(n + 1) for i in range(n + 1)]
    els = [f"{j * n + i + 1}, {node(i, j)}, {node(i + 1, j)}, {node(i + 1, j + 1)}, {node(i, j + 1)}"
           for j in range(n) for i in range(n)]
    clamp = ", ".join(str(node(0, j)) for j in range(n + 1))
    path.write_text("*NODE\n" + "\n".join(nodes) + "\n*ELEMENT, TYPE=S4, ELSET=PLATE\n" + "\n".join(els)
                    + f"\n*NSET, NSET=ROOT\n{clamp}\n*MATERIAL, NAME=AL\n*ELASTIC\n{E!r}, 0.33\n*DENSITY\n{rho!r}\n"
                    f"*SHELL SECTION, ELSET=PLATE, MATERIAL=AL\n{t!r}\n*BOUNDARY\nROOT, ENCASTRE\n")
    return path


def _freqs(model, k: int = 8):
    """Lowest frequencies (Hz): shift-invert, one inverse iteration, Rayleigh quotients — accurate to
    ~1e-11 although translations and rotations are scaled very differently (a plain dense solve of
    either system's matrices gives only ~1e-7, even for matrices equal to 1e-15)."""
    K, M = model.K().tocsc(), model.M().tocsc()
    X = ssl.splu(K).solve(M @ ssl.eigsh(K, k=k, M=M, sigma=0, tol=0)[1])
    lam = np.einsum("ij,ij->j", X, K @ X) / np.einsum("ij,ij->j", X, M @ X)
    return np.sqrt(np.sort(lam)) / (2 * np.pi)


def test_same_plate_in_m_kg_s_and_mm_t_s_same_frequencies(tmp_path):
    a = Structure.from_mesh(_deck(tmp_path / "si.inp", SI)).build()
    b = Structure.from_mesh(_deck(tmp_path / "mm.inp", MM), units="mm-t-s").build()
    # exactly the same problem: K and M of mm-t-s are SI's scaled by 1e-3 (N/mm), 1 (N), 1e3 (N mm/rad), and
    # by 1e-3 (t) and 1e3 (t mm²): S K S with S = 10^-1.5 on translations and 10^1.5 on rotations
    assert a.dofs == b.dofs
    S = np.array([10**-1.5 if d.split(":")[1] in ("x", "y", "z") else 10**1.5 for d in a.dofs])
    for A, B in ((a.K(), b.K()), (a.M(), b.M())):
        A, B = A.toarray() * S[:, None] * S[None, :], B.toarray()
        assert abs(A - B).max() <= 1e-12 * abs(B).max()
    si, mm = _freqs(a), _freqs(b)
    # a second route: the first cantilever-plate frequency lies near the beam's 3.516/(2 pi L^2) sqrt(D/(rho t))
    D = SI[1] * SI[3] ** 3 / (12 * (1 - 0.33**2))
    beam = 3.516 / (2 * np.pi * 0.5**2) * np.sqrt(D / (SI[2] * SI[3]))
    assert abs(si[0] / beam - 1) < 0.05, (si[0], beam)
    assert np.max(np.abs(mm / si - 1)) < 1e-10, mm / si - 1


def test_parameter_units_follow_the_system(tmp_path):
    for system, units, expect in ((SI, "m-kg-s", ("Pa", "kg/m³", "m")), (MM, "mm-t-s", ("MPa", "t/mm³", "mm"))):
        f = _deck(tmp_path / f"{units}.inp", system)
        s = Structure.from_mesh(f, {"PLATE": {"E": "E", "rho": "rho", "t": "t"}}, units=units)
        for name, v in zip(("E", "rho", "t"), system[1:]):
            s.parameter(name, v)
        model = s.build()
        assert tuple(p.unit for p in model.parameters) == expect, units


def test_values_contradicting_the_system_refused_by_name(tmp_path):
    mm_deck = _deck(tmp_path / "mm.inp", MM)
    with pytest.raises(InputError, match=r"material 'AL'.*rho = 2\.7e-09 is not a plausible density in kg/m³ "
                                         r"\(the declared units m-kg-s\); read as t/mm³ \(mm-t-s\) it would be 2700 kg/m³"):
        Structure.from_mesh(mm_deck, units="m-kg-s")  # an mm-t-s deck declared SI
    bdf = tmp_path / "steel.bdf"
    bdf.write_text("GRID,1,,0.,0.,0.\nGRID,2,,1000.,0.,0.\nGRID,3,,1000.,1000.,0.\nGRID,4,,0.,1000.,0.\n"
                   "CQUAD4,1,1,1,2,3,4\nPSHELL,1,7,2.0,7\nMAT1,7,2.1+11,,0.3,7850.\n")
    with pytest.raises(InputError, match=r"PSHELL.*material '7'.*E = 2\.1e\+11 is not a plausible modulus in MPa "
                                         r"\(the declared units mm-t-s\).*check_units = false"):
        Structure.from_mesh(bdf, units="mm-t-s")
    with pytest.raises(InputError, match=r"\[mesh.sets.PLATE\]: rho = 7850 is not a plausible density in t/mm³.*"
                                         r"read as kg/m³ \(m-kg-s\) it would be 7\.85e-09 t/mm³"):
        Structure.from_mesh(mm_deck, {"PLATE": {"rho": 7850.0}}, units="mm-t-s")
    s = Structure.from_mesh(mm_deck, {"PLATE": {"E": "E_plate"}}, units="mm-t-s")
    s.parameter("E_plate", 7.0e10)  # a parameter's value: checked when built
    with pytest.raises(InputError, match=r"set 'PLATE': parameter 'E_plate' \(E\): E = 7e\+10 is not a plausible modulus in MPa"):
        s.build()
    with pytest.raises(InputError, match=r"units = 'mm-kg-s' is not a consistent unit system.*'m-kg-s', 'mm-t-s'"):
        Structure.from_mesh(mm_deck, units="mm-kg-s")
    # the escape: unchecked, the mismatched deck builds; undeclared units are not checked (a deck in another
    # consistent system, such as inch-lbf-s, is taken as it is) and the units read SI
    assert Structure.from_mesh(mm_deck, units="m-kg-s", check_units=False).build().dofs
    s = Structure.from_mesh(mm_deck, {"PLATE": {"E": "E_plate"}})
    s.parameter("E_plate", 7.0e4)
    assert s.build().parameters[0].unit == "Pa"


def test_model_file_units_cli(tmp_path):
    """[mesh] units through the command line: modes of an mm-t-s plate equal the SI plate's; the
    same deck declared m-kg-s exits 2 naming the material; check_units = false lets it through."""
    _deck(tmp_path / "mm.inp", MM)
    _deck(tmp_path / "si.inp", SI)
    (tmp_path / "mm.toml").write_text('[parameters.E_al]\nvalue = 7.0e4\n\n[mesh]\nfile = "mm.inp"\nunits = "mm-t-s"\n\n'
                                      '[mesh.sets.PLATE]\nE = "E_al"\n')
    (tmp_path / "si.toml").write_text('[mesh]\nfile = "si.inp"\n')
    assert load_model(tmp_path / "mm.toml").parameters[0].unit == "MPa"
    assert np.max(np.abs(_freqs(load_model(tmp_path / "mm.toml")) / _freqs(load_model(tmp_path / "si.toml")) - 1)) < 1e-10
    (tmp_path / "bad.toml").write_text('[mesh]\nfile = "mm.inp"\nunits = "m-kg-s"\n')
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "bad.toml"], cwd=tmp_path, capture_output=True,
                       text=True, env=ENV)
    assert r.returncode == 2 and "material 'AL'" in r.stderr and "rho = 2.7e-09" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
    (tmp_path / "escape.toml").write_text('[mesh]\nfile = "mm.inp"\nunits = "m-kg-s"\ncheck_units = false\n')
    r = subprocess.run([sys.executable, "-m", "femupdate", "modes", "escape.toml", "--n-modes", "2"], cwd=tmp_path,
                       capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
