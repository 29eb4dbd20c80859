"""A portal frame in OpenSees, run by femupdate as a black box (docs/blackbox.md).

Two columns 3 m high (modulus ``E_cols``, a parameter) carry a 4 m beam of rectangular section
0.2 m wide and ``h`` high (a parameter: the area b h and the second moment b h^3 / 12 follow it,
so K and M are not affine in h); each member is two elastic beam-column elements with a
consistent mass.  Run as a command::

    python opensees_frame.py E_cols=2.1e11 h=0.3

it writes, in the folder it runs in, ``K.mtx`` and ``M.mtx`` (Matrix Market) and ``dofs.txt``
(one label ``node:dir`` per equation).  :func:`matrices` is the same as a Python callable;
:func:`frequencies` and :func:`eigen` are OpenSees' own eigen-solution.
"""

from __future__ import annotations

import ctypes
import glob
import importlib.util
import os
import sys

import numpy as np

NODES = {1: (0.0, 0.0), 5: (0.0, 1.5), 2: (0.0, 3.0), 7: (2.0, 3.0), 3: (4.0, 3.0), 6: (4.0, 1.5), 4: (4.0, 0.0)}
COLUMNS = {11: (1, 5), 12: (5, 2), 13: (4, 6), 14: (6, 3)}
BEAM = {21: (2, 7), 22: (7, 3)}
A_COL, I_COL, B_BEAM, RHO, E_BEAM = 4e-3, 2e-5, 0.2, 7850.0, 2.0e11
NOMINAL = {"E_cols": 2.1e11, "h": 0.3}
DIRS = ("x", "y", "rz")


def opensees():
    """OpenSeesPy, with the BLAS/LAPACK its Linux wheel ships (in a folder the loader does not search)
    loaded first."""
    spec = importlib.util.find_spec("openseespylinux")
    if spec is not None and spec.submodule_search_locations:
        folder = list(spec.submodule_search_locations)[0]
        for lib in sorted(glob.glob(os.path.join(folder, "lib", "*.so*"))):
            try:
                ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
            except OSError:
                pass
    import openseespy.opensees as ops

    return ops


def build(ops, E_cols: float, h: float) -> None:
    """The frame in OpenSees' domain (2D, three dofs a node, the column bases fixed)."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for tag, (x, y) in NODES.items():
        ops.node(tag, x, y)
    ops.fix(1, 1, 1, 1)
    ops.fix(4, 1, 1, 1)
    ops.geomTransf("Linear", 1)
    for tag, (i, j) in COLUMNS.items():
        ops.element("elasticBeamColumn", tag, i, j, A_COL, E_cols, I_COL, 1, "-mass", RHO * A_COL, "-cMass")
    A, I = B_BEAM * h, B_BEAM * h**3 / 12
    for tag, (i, j) in BEAM.items():
        ops.element("elasticBeamColumn", tag, i, j, A, E_BEAM, I, 1, "-mass", RHO * A, "-cMass")


def matrices(values: dict):
    """(K, M, dof labels) of the frame at ``values`` {"E_cols": ..., "h": ...}: the matrices
    OpenSees assembles (``GimmeMCK`` forms m M + c C + k K; ``printA`` returns it), the labels
    from each node's equation numbers (``nodeDOFs``)."""
    ops = opensees()
    out = []
    for mck in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)):
        build(ops, float(values["E_cols"]), float(values["h"]))
        ops.constraints("Plain")
        ops.numberer("Plain")
        ops.system("FullGeneral")
        ops.algorithm("Linear")
        ops.integrator("GimmeMCK", *mck)
        ops.analysis("Transient")
        ops.analyze(1, 0.0)
        n = ops.systemSize()
        out.append(np.array(ops.printA("-ret")).reshape(n, n))
    labels = [""] * n
    for tag in NODES:
        for k, eq in enumerate(ops.nodeDOFs(tag)):
            if eq >= 0:
                labels[eq] = f"{tag}:{DIRS[k]}"
    ops.wipe()
    return out[0], out[1], labels


def frequencies(values: dict, n: int = 4) -> np.ndarray:
    """The first ``n`` natural frequencies (Hz) by OpenSees' own eigen-solver."""
    ops = opensees()
    build(ops, float(values["E_cols"]), float(values["h"]))
    lam = np.array(ops.eigen("-fullGenLapack", n))
    ops.wipe()
    return np.sqrt(lam) / (2 * np.pi)


def eigen(values: dict, n: int = 4):
    """OpenSees' own eigen-solution: the first ``n`` eigenvalues (rad²/s²) and the shapes
    ``[{"node:dir": value}, ...]`` at the translational dofs of the free nodes."""
    ops = opensees()
    build(ops, float(values["E_cols"]), float(values["h"]))
    lam = np.array(ops.eigen("-fullGenLapack", n))
    free = [t for t in NODES if t not in (1, 4)]
    shapes = [{f"{t}:{d}": float(ops.nodeEigenvector(t, k + 1, i + 1)) for t in free for i, d in enumerate("xy")}
              for k in range(n)]
    ops.wipe()
    return lam, shapes


def main(argv: list[str]) -> None:
    values = dict(NOMINAL)
    for arg in argv:
        name, _, value = arg.partition("=")
        if name not in values:
            sys.exit(f"unknown parameter {name!r} (known: {', '.join(values)})")
        values[name] = float(value)
    if not values["h"] > 0:
        sys.exit(f"h = {values['h']}: the section height must be positive")
    import scipy.io
    import scipy.sparse as sp

    K, M, labels = matrices(values)
    # a "symmetric" Matrix Market file stores the lower triangle: SciPy drops entries above it
    scipy.io.mmwrite("K.mtx", sp.coo_array(np.tril(K)), symmetry="symmetric", precision=17)
    scipy.io.mmwrite("M.mtx", sp.coo_array(np.tril(M)), symmetry="symmetric", precision=17)
    with open("dofs.txt", "w") as fh:
        fh.write("\n".join(labels) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
