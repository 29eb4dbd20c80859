r"""Universal files (UFF / UNV) through :mod:`pyuff`: nodes, modes, FRFs and units.

Datasets read
-------------
* **15**, **2411** -- node coordinates, into :attr:`TestData.nodes` ``{id: (x, y, z)}``;
* **55** -- data at nodes: real normal modes (analysis type 2) and complex modes (analysis
  types 3 and 7), into :class:`~femupdate.testdata.MeasuredMode`, ordered by frequency;
* **58** -- functions at nodal dofs: frequency response functions (function type 4) of one
  excitation dof, into :class:`~femupdate.testdata.FRFData` (receptance, ``omega`` in rad/s);
* **164** -- units, into :attr:`TestData.units`.

Other datasets (trace lines 82, elements 2412, ...) and other kinds of records (coherences,
operating shapes, static data at nodes) are skipped with a log message.

Directions
----------
UFF direction codes 1..6 map to ``x y z rx ry rz`` (:mod:`femupdate.dofs`). A negative code
means that the transducer points the negative way: its data are negated and stored under the
positive label. In dataset 55 the components ``r1 .. r6`` of each node are ``x .. rz``.

Values are kept in the file's units (dataset 164 says which); only the abscissa of FRFs is
converted from Hz to rad/s.

Every malformed or inconsistent file raises :class:`~femupdate.InputError` with one message that
names the file and the record (``"test.uff: dataset 55 record 2: ..."``, records counted
from 1 among the datasets of that type).

Writing goes through a temporary file in the target directory that replaces the target only
when complete (:func:`os.replace`), so a failed write never leaves a truncated file.

Layout: :mod:`.conventions` (dataset numbers, direction and unit codes shared by both ways),
:mod:`.read` (:func:`read_uff`) and :mod:`.write` (:func:`write_uff_modes`, :func:`write_uff_frf`).
"""

from .conventions import UNIT_SYSTEMS
from .read import read_uff
from .write import write_uff_frf, write_uff_modes

__all__ = ["read_uff", "write_uff_modes", "write_uff_frf"]
