"""The node-block assembly of shell and solid groups (femupdate.structure.node_assembly) against
the triplet route it replaced, scikit-fem's trilinear hexahedron, and the dof-label fast check."""

from __future__ import annotations

import numpy as np
import pytest

from femupdate import elements_3d as e3
from femupdate.dofs import _all_canonical_integer, canonical_all
from femupdate.structure import Structure
from femupdate.structure.groups import NodeDofs


def _brick(nx, ny, nz, distort=0.0, seed=0):
    """Nodes (ids from 1) and hexahedra (femupdate's node order) of a box, optionally distorted."""
    x, y, z = (np.linspace(0, L, m + 1) for L, m in ((1.0, nx), (0.6, ny), (0.4, nz)))
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    p = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    if distort:
        p = p + np.random.default_rng(seed).uniform(-distort, distort, p.shape) * np.array([1 / nx, 0.6 / ny, 0.4 / nz])
    nid = np.arange(len(p)).reshape(nx + 1, ny + 1, nz + 1) + 1
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    hexes = np.column_stack([nid[i + a, j + b, k + c] for a, b, c in corners])
    return nid, p, hexes


def _mixed(generic: bool) -> Structure:
    """Solids in two parameter sets, a shell skin (E t³: a non-linear term), springs to a named
    node, point masses, supports by node and by dof."""
    nid, p, hexes = _brick(4, 3, 2, distort=0.2)
    s = Structure("mixed")
    for name, v in (("E1", 2e11), ("E2", 7e10), ("rho1", 7850.0), ("Es", 2e11), ("ts", 0.01)):
        s.parameter(name, v)
    s.add_nodes(np.arange(1, len(p) + 1), p)
    half = len(hexes) // 2
    s.solid(hexes[:half], E="E1", nu=0.3, rho="rho1")
    s.solid(hexes[half:], E="E2", nu=0.25, rho=2700.0, mass="lumped")
    top = nid[:, :, -1]
    quads = np.column_stack([top[:-1, :-1].ravel(), top[1:, :-1].ravel(), top[1:, 1:].ravel(), top[:-1, 1:].ravel()])
    s.shell(quads, E="Es", nu=0.3, t="ts", rho=7850.0)
    s.spring(["A2:x", f"{nid[-1, -1, 0]}:x"], k=1e6)
    s.spring(["A2:x"], k=2e5)
    s.mass(["A2:x"], m=3.0)
    s.mass([f"{nid[-1, 0, -1]}:y"], m=2.0)
    s.support_node(nid[0].ravel().tolist())
    s.support([f"{nid[-1, 0, 0]}:z"])
    if generic:  # the triplet route: plain label lists
        for g in s.groups:
            if isinstance(g.labels, NodeDofs):
                g.labels = list(g.labels)
    return s


def _close(A, B, what):
    assert (A is None) == (B is None), what
    if A is None:
        return
    A, B = A.toarray(), B.toarray()
    scale = max(np.abs(B).max(), 1e-300)
    assert np.abs(A - B).max() <= 1e-12 * scale, what


def test_node_blocks_equal_the_triplet_route():
    new, old = _mixed(False).build(), _mixed(True).build()
    assert new.dofs == old.dofs and any(d.startswith("A2:") for d in new.dofs)
    assert [p.name for p in new.parameters] == [p.name for p in old.parameters]
    _close(new.K0, old.K0, "K0")
    _close(new.M0, old.M0, "M0")
    for a, b, p in zip(new.dK, old.dK, new.parameters):
        _close(a, b, f"dK/d{p.name}")
    for a, b, p in zip(new.dM, old.dM, new.parameters):
        _close(a, b, f"dM/d{p.name}")
    assert len(new.terms) == len(old.terms) >= 1
    for a, b in zip(new.terms, old.terms):
        assert a.factors == b.factors
        for x, y in ((a.K, b.K), (a.M, b.M)):
            _close(x, y, str(a.factors))
    p = new.values * 1.1
    _close(new.K(p), old.K(p), "K(p)")


def test_chunks_do_not_change_the_matrices(monkeypatch):
    from femupdate.structure import node_assembly

    whole = _mixed(False).build()
    monkeypatch.setattr(node_assembly, "CHUNK", 5)
    chunked = _mixed(False).build()
    for a, b in ((whole.K0, chunked.K0), (whole.M0, chunked.M0), *zip(whole.dK, chunked.dK)):
        _close(a, b, "chunked")


def test_trilinear_hexahedron_equals_scikit_fem(monkeypatch):
    """With the incompatible modes off, K_E and M of a distorted brick equal scikit-fem's
    ElementVector(ElementHex1()) with the same 2 x 2 x 2 rule (an independent code)."""
    skfem = pytest.importorskip("skfem")
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    nid, p, hexes = _brick(3, 2, 2, distort=0.25, seed=3)
    # scikit-fem's hexahedron numbers its corners by (x, y, z) bits of the reference cube
    sk_order = [0, 4, 3, 1, 7, 5, 2, 6]  # femupdate's node at each of scikit-fem's positions
    mesh = skfem.MeshHex(p.T, (hexes[:, sk_order] - 1).T)
    basis = skfem.Basis(mesh, skfem.ElementVector(skfem.ElementHex1()), intorder=3)

    @skfem.BilinearForm
    def mass(u, v, w):
        return dot(u, v)

    K_ref = skfem.asm(linear_elasticity(*lame_parameters(1.0, 0.3)), basis).tocsr()
    M_ref = skfem.asm(mass, basis).tocsr()
    qm6 = e3.hex8_terms
    plain = lambda xyz, nu, mass="consistent": qm6(xyz, nu, mass=mass, incompatible=False)  # noqa: E731
    monkeypatch.setattr(e3, "hex8_terms", plain)
    s = Structure("brick")
    s.parameter("E", 1.0)
    s.add_nodes(np.arange(1, len(p) + 1), p)
    s.solid(hexes, E="E", nu=0.3, rho=1.0)
    m = s.build()
    assert m.dofs[:6] == ("1:x", "1:y", "1:z", "2:x", "2:y", "2:z")  # scikit-fem's interleaved order
    _close(m.dK[0], K_ref, "K")
    _close(m.M0, M_ref, "M")


def test_qm6_patch_test_on_the_assembled_mesh():
    """A linear displacement field gives zero force at every free node of a distorted QM6 mesh."""
    nid, p, hexes = _brick(3, 3, 2, distort=0.3, seed=5)
    s = Structure("patch")
    s.add_nodes(np.arange(1, len(p) + 1), p)
    s.solid(hexes, E=1.0, nu=0.3, rho=1.0)
    m = s.build()
    ids = np.array([int(d.split(":")[0]) for d in m.dofs])
    comp = np.array(["xyz".index(d.split(":")[1]) for d in m.dofs])
    A = np.array([[1e-3, 2e-4, -3e-4], [5e-4, -1e-3, 2e-4], [1e-4, 3e-4, 2e-3]])
    u = (p[ids - 1] @ A.T)[np.arange(len(ids)), comp]
    f = m.K0 @ u
    boundary = np.zeros(len(p) + 1, bool)
    boundary[np.concatenate([nid[[0, -1]].ravel(), nid[:, [0, -1]].ravel(), nid[:, :, [0, -1]].ravel()])] = True
    interior = ~boundary[ids]
    assert interior.any()
    assert np.abs(f[interior]).max() <= 1e-12 * np.abs(m.K0.data).max() * np.abs(u).max()


def test_canonical_label_fast_check():
    assert _all_canonical_integer(["1:x", "22:rz", "-3:s", "0:y"])
    for bad in (["01:x"], ["1:X"], ["1:x\n2:y"], ["A:x"], [" 1:x"], ["-0:x"], [], ["1:x", ""], ["1:1"], [1]):
        assert not _all_canonical_integer(bad), bad
    assert canonical_all(["1:X", " 2 : 3"]) == ("1:x", "2:z")
    with pytest.raises(Exception, match="listed twice"):
        canonical_all(["1:x", "1:x"])


def test_symmetry_check_of_a_symmetric_pattern():
    """The quick check (one transposed copy) passes symmetric matrices and hands an asymmetric
    one with a symmetric pattern to the full check, which refuses it naming the matrix."""
    import scipy.sparse as sp

    from femupdate import InputError, Model
    from femupdate._checks import symmetric_pattern_close

    K = sp.csr_array(np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 2.0]]))
    assert symmetric_pattern_close(K, 0.0)
    bad = K.copy()
    bad.data[1] = -1.001  # the (0, 1) entry: same pattern, values no longer symmetric
    assert not symmetric_pattern_close(bad, 1e-10 * 2)
    with pytest.raises(InputError, match="K0 is not symmetric"):
        Model(dofs=("1:x", "2:x", "3:x"), K0=bad, M0=sp.identity(3, format="csr"))


def test_nastran_grid_and_chexa_common_and_other_forms(tmp_path):
    """GRID and CHEXA cards read the quick way (plain numbers) and the long way (Nastran reals
    such as 1.-3, an explicit CP of 0, a blank property id) give the same mesh, in deck order."""
    from femupdate.mesh import read_mesh

    deck = tmp_path / "two.bdf"
    deck.write_text(
        "BEGIN BULK\nMAT1    1       2.1+11          0.3     7850.\nPSOLID  1       1\n"
        "GRID    1               0.      0.      0.\n"
        "GRID    2       0       1.-0    0.      \n"  # Nastran real, explicit CP, blank z
        "GRID    3               1.      1.      0.\n"
        "GRID,4,,0.,1.,0.\n"
        "GRID    5               0.      0.      1.\nGRID    6               1.      0.      1.\n"
        "GRID    7               1.      1.      1.\nGRID    8               0.      1.      1.\n"
        "GRID    9               2.      0.      0.\nGRID    10              2.      1.      0.\n"
        "GRID    11              2.      0.      1.\nGRID    12              2.      1.      1.\n"
        "CHEXA   1       1       1       2       3       4       5       6       +\n+       7       8\n"
        "CHEXA   2               2       9       10      3       6       11      +\n+       12      7\n"
        "ENDDATA\n")
    mesh = read_mesh(deck, "nastran")
    assert mesh.node_ids.tolist() == list(range(1, 13))
    np.testing.assert_array_equal(mesh.xyz[:4], [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    (block,) = mesh.blocks
    assert block.type == "hex8" and block.ids.tolist() == [1, 2]
    assert block.conn.tolist() == [[1, 2, 3, 4, 5, 6, 7, 8], [2, 9, 10, 3, 6, 11, 12, 7]]
    assert sorted(mesh.elsets) == ["1", "2"] and mesh.elsets["2"].tolist() == [2]  # blank PID: the element id
