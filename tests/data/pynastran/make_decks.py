"""Write the bulk-data decks of this folder with pyNastran's BDF writer.

Run ONLY in a throwaway environment, never by the test suite (pyNastran's release pins NumPy < 2,
so it is not a femupdate dependency)::

    python3 -m venv /tmp/pyn && /tmp/pyn/bin/pip install "numpy<2" pyNastran
    /tmp/pyn/bin/python tests/data/pynastran/make_decks.py

Each deck is written three times: small field (``size=8``), large field (``size=16``) and large
field in double precision (``size=16, is_double=True``).  tests/test_pynastran_decks.py reads them
with femupdate and compares with the same model built in Python.  All numbers are chosen to be
exact in eight characters, so the three versions hold the same values.
"""

from pathlib import Path

import pyNastran
from pyNastran.bdf.bdf import BDF

HERE = Path(__file__).parent
E, NU, RHO, T = 2.1e11, 0.3, 7850.0, 0.01


def shell_plate() -> BDF:
    """(a) A flat plate in z = 0: a CQUAD4 and three CTRIA3 (one on a grid given in a rotated CORD2R),
    PSHELL, MAT1, SPC1 on the edge x = 0, a CONM2 with offset and inertia."""
    m = BDF(debug=False)
    for nid, xyz in {1: (0.0, 0.0, 0.0), 2: (1.0, 0.0, 0.0), 3: (2.0, 0.0, 0.0),
                     4: (0.0, 1.0, 0.0), 5: (1.0, 1.0, 0.0), 6: (2.0, 1.0, 0.0)}.items():
        m.add_grid(nid, list(xyz))
    # CORD2R 5: origin (2, 0, 0), z axis along basic z, x axis along (0.8, 0.6, 0)
    m.add_cord2r(5, [2.0, 0.0, 0.0], [2.0, 0.0, 1.0], [6.0, 3.0, 0.0])
    m.add_grid(7, [1.5, -0.5, 0.0], cp=5)  # basic (3.5, 0.5, 0)
    m.add_cquad4(11, 1, [1, 2, 5, 4])
    m.add_ctria3(12, 1, [2, 3, 6])
    m.add_ctria3(13, 1, [2, 6, 5])
    m.add_ctria3(14, 1, [3, 7, 6])
    m.add_pshell(1, mid1=9, t=T, mid2=9)
    m.add_mat1(9, E, None, NU, rho=RHO)
    m.add_spc1(1, "123456", [1, 4])
    m.add_conm2(21, 5, 2.5, X=[0.0, 0.0, 0.1], I=[0.01, 0.0, 0.02, 0.0, 0.0, 0.03])
    return m


def solid_block() -> BDF:
    """(b) A unit-cube CHEXA and two CTETRA (a pyramid on its face x = 1), PSOLID, MAT1, SPC1 123 on
    the face x = 0, an RBE2 (123) from grid 10 to grids 6, 7, 9, and a CELAS2 from 10 (x) to ground."""
    m = BDF(debug=False)
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    for nid, xyz in enumerate(corners, start=1):
        m.add_grid(nid, [float(c) for c in xyz])
    m.add_grid(9, [1.5, 0.5, 0.5])
    m.add_grid(10, [2.5, 0.5, 0.5])
    m.add_chexa(31, 2, [1, 2, 3, 4, 5, 6, 7, 8])
    m.add_ctetra(32, 2, [2, 3, 7, 9])
    m.add_ctetra(33, 2, [2, 7, 6, 9])
    m.add_psolid(2, 9)
    m.add_mat1(9, E, None, NU, rho=RHO)
    m.add_spc1(1, "123", [1, 4, 5, 8])
    m.add_rbe2(41, 10, "123", [6, 7, 9])
    m.add_celas2(51, 1.0e5, [10, 0], c1=1, c2=0)
    return m


if __name__ == "__main__":
    for name, build in (("plate", shell_plate), ("block", solid_block)):
        model = build()
        for suffix, size, double in (("small", 8, False), ("large", 16, False), ("double", 16, True)):
            out = HERE / f"{name}_{suffix}.bdf"
            model.write_bdf(str(out), size=size, is_double=double)
            print(out.name, "written by pyNastran", pyNastran.__version__)
