"""Small structured meshes for the shell and solid element tests (no mesh reader needed)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from femupdate.elements import combine
from femupdate.elements_3d.solids import TET10_EDGES

# the Kuhn split of a hexahedron (nodes in hex8 order) into 6 tetrahedra along its diagonal 0-6:
# conforming between neighbours of a structured grid
KUHN = np.array([[0, 1, 2, 6], [0, 1, 5, 6], [0, 3, 2, 6], [0, 3, 7, 6], [0, 4, 5, 6], [0, 4, 7, 6]])


def box_hex(nx, ny, nz, size=(1.0, 1.0, 1.0)):
    """Nodes (n, 3) and hex8 connectivity of a box [0, Lx] x [0, Ly] x [0, Lz]."""
    xs, ys, zs = (np.linspace(0, s, n + 1) for s, n in zip(size, (nx, ny, nz)))
    X, Y, Z = np.meshgrid(xs, ys, zs, indexing="ij")
    nodes = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    nid = np.arange(len(nodes)).reshape(nx + 1, ny + 1, nz + 1)
    conn = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                conn.append([nid[i, j, k], nid[i + 1, j, k], nid[i + 1, j + 1, k], nid[i, j + 1, k],
                             nid[i, j, k + 1], nid[i + 1, j, k + 1], nid[i + 1, j + 1, k + 1], nid[i, j + 1, k + 1]])
    return nodes, np.array(conn)


def hex_to_tets(nodes, hexes, quadratic=False):
    """Split hexahedra into tetrahedra (positively oriented); add mid-edge nodes for ``quadratic``."""
    tets = hexes[:, KUHN].reshape(-1, 4)
    x = nodes[tets]
    vol = np.einsum("ni,ni->n", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), x[:, 3] - x[:, 0])
    flip = vol < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    if not quadratic:
        return nodes, tets
    edges, mids, extra = {}, [], []
    for t in tets:
        row = []
        for i, j in TET10_EDGES:
            key = tuple(sorted((int(t[i]), int(t[j]))))
            if key not in edges:
                edges[key] = len(nodes) + len(extra)
                extra.append(0.5 * (nodes[key[0]] + nodes[key[1]]))
            row.append(edges[key])
        mids.append(row)
    return np.vstack([nodes, np.array(extra)]), np.hstack([tets, np.array(mids)])


def assemble(terms, conn, n_nodes, ndof, props):
    """Sparse global K and M (CSC) from element terms with numeric ``props``."""
    K = combine(terms.K, props)
    M = combine(terms.M, props)
    idx = (np.asarray(conn)[:, :, None] * ndof + np.arange(ndof)).reshape(len(conn), -1)
    ne = idx.shape[1]
    r = np.repeat(idx, ne, axis=1).ravel()
    c = np.tile(idx, ne).ravel()
    n = n_nodes * ndof
    return (sp.coo_matrix((K.ravel(), (r, c)), (n, n)).tocsc(), sp.coo_matrix((M.ravel(), (r, c)), (n, n)).tocsc())


def plate_mesh(n, a=1.0, triangles=False):
    """Square plate [0, a]^2 in the x-y plane: nodes and quadrilateral (or triangle) connectivity."""
    xs = np.linspace(0, a, n + 1)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    nodes = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    nid = np.arange(len(nodes)).reshape(n + 1, n + 1)
    q = np.array([[nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]] for i in range(n) for j in range(n)])
    return nodes, (np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]) if triangles else q)
