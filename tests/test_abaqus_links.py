"""Abaqus ``*KINEMATIC COUPLING`` and ``*MPC`` BEAM/TIE read as exact constraints: a plate whose edge
is coupled to a clamped reference node is the plate with that edge clamped; a deck with BEAM and TIE
MPCs equals the same model built in Python; unsupported MPC types and options named with their line."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl

import femupdate as fu
from femupdate._errors import InputError

N = 4  # elements per side of the unit plate


def plate_deck(extra: str = "", boundary: str = "") -> str:
    nid = lambda i, j: 1 + i + (N + 1) * j  # noqa: E731
    nodes = "".join(f"{nid(i, j)}, {i / N}, {j / N}, 0.\n" for j in range(N + 1) for i in range(N + 1))
    els = "".join(f"{1 + i + N * j}, {nid(i, j)}, {nid(i + 1, j)}, {nid(i + 1, j + 1)}, {nid(i, j + 1)}\n"
                  for j in range(N) for i in range(N))
    edge = ", ".join(str(nid(0, j)) for j in range(N + 1))
    return ("*NODE\n" + nodes + "100, -0.2, 0.5, 0.1\n*ELEMENT, TYPE=S4, ELSET=plate\n" + els + f"*NSET, NSET=edge\n{edge}\n"
            "*MATERIAL, NAME=alu\n*ELASTIC\n70e9, 0.3\n*DENSITY\n2700.\n*SHELL SECTION, ELSET=plate, MATERIAL=alu\n0.01\n"
            + extra + boundary)


def eig(model):
    return sl.eigh(model.K().toarray(), model.M().toarray(), eigvals_only=True)


def test_edge_coupled_to_a_clamped_reference_node_is_a_clamped_edge(tmp_path):
    (tmp_path / "coupled.inp").write_text(plate_deck("*KINEMATIC COUPLING, REF NODE=100\nedge, 1, 6\n",
                                                     "*BOUNDARY\n100, ENCASTRE\n"))
    (tmp_path / "clamped.inp").write_text(plate_deck("", "*BOUNDARY\nedge, ENCASTRE\n"))
    a = fu.Structure.from_mesh(tmp_path / "coupled.inp").build()
    b = fu.Structure.from_mesh(tmp_path / "clamped.inp").build()
    assert a.dofs == b.dofs and len(a.constraints.labels) == 6 * (N + 1)
    # the same matrices but for the order of summation in assembly (round-off, 1e-16 of the largest entry)
    assert abs(a.K0 - b.K0).max() <= 1e-15 * abs(b.K0).max() and abs(a.M0 - b.M0).max() == 0
    assert np.allclose(eig(a)[:8], eig(b)[:8], rtol=1e-8, atol=0)


def test_mpc_beam_and_tie_equal_the_python_model(tmp_path):
    """Node 100 (off the plate) carries the coupling; the edge follows it as a rigid beam (MPC BEAM on a
    node set), the far corner's dofs are tied to it (MPC TIE), and a coupling of translations only at a
    middle node."""
    far = 1 + N + (N + 1) * N
    mid = 1 + N // 2 + (N + 1) * (N // 2)
    extra = (f"*MPC\nBEAM, edge, 100\nTIE, {far}, 100\n*KINEMATIC COUPLING, REF NODE=100\n{mid}, 1, 3\n")
    (tmp_path / "mpc.inp").write_text(plate_deck(extra))
    (tmp_path / "bare.inp").write_text(plate_deck())
    a = fu.Structure.from_mesh(tmp_path / "mpc.inp").build()
    s = fu.Structure.from_mesh(tmp_path / "bare.inp")
    s.rigid_link(100, [1 + (N + 1) * j for j in range(N + 1)])
    s.equal_dofs(100, far)
    s.rigid_link(100, mid, dofs=["x", "y", "z"])
    b = s.build()
    assert a.dofs == b.dofs and a.constraints.labels == b.constraints.labels
    assert abs(a.K0 - b.K0).max() == 0 and abs(a.M0 - b.M0).max() == 0
    lam = eig(a)
    # free-free, but the TIE holds the far corner to node 100's motion: rigid rotations about any axis but
    # the line through the two move them apart, so 4 rigid-body modes remain (3 translations, 1 rotation)
    assert np.sum(np.abs(lam) < 1e-9 * lam.max()) == 4 and lam[4] > 1e4, lam[:6]


@pytest.mark.parametrize("extra, message", [
    ("*MPC\nPIN, 5, 100\n", "MPC type 'PIN' is not supported"),
    ("*KINEMATIC COUPLING, REF NODE=100, ORIENTATION=ori\nedge, 1, 6\n", "ORIENTATION are not read"),
    ("*KINEMATIC COUPLING, REF NODE=100\nrim, 1, 6\n", "no node set 'rim'"),
    ("*COUPLING, REF NODE=100, SURFACE=s\n*DISTRIBUTING\n", "*COUPLING (line"),
    ("*MPC\nBEAM, 5, 100\n*MPC\nTIE, 5, 100\n", "dof 5:x is dependent twice"),
])
def test_unsupported_abaqus_constraints_named_with_their_line(tmp_path, extra, message):
    (tmp_path / "bad.inp").write_text(plate_deck(extra))
    with pytest.raises(InputError) as exc:
        fu.Structure.from_mesh(tmp_path / "bad.inp").build()
    assert message in str(exc.value) and "bad.inp" in str(exc.value), str(exc.value)
