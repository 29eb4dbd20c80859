r"""Universal files (UFF / UNV) through :mod:`pyuff`: nodes, modes, FRFs and units.

Datasets read
-------------
* **15**, **2411** -- node coordinates, into :attr:`TestData.nodes` ``{id: (x, y, z)}`` (global,
  SI), with each node's definition and displacement coordinate systems;
* **2420**, **18** -- coordinate systems (:mod:`.systems`): coordinates and data given in local
  Cartesian systems are brought into the global axes; other systems are refused by name;
* **55** -- data at nodes: real normal modes (analysis type 2) and complex modes (analysis
  types 3 and 7), into :class:`~femupdate.testdata.MeasuredMode`, ordered by frequency; the
  measured components are the sensor list's, the FRF records' dofs, or those not zero in every
  mode (padding of the 3- and 6-value records is left out, with a note);
* **58** -- functions at nodal dofs: frequency response functions (function type 4), one
  :class:`~femupdate.testdata.FRFData` per excitation dof (receptance, ``omega`` in rad/s), into
  :attr:`TestData.frf_sets`;
* **164** -- units, into :attr:`TestData.units`; coordinates, shape translations and FRFs are
  converted to SI with its factors.

Other datasets (trace lines 82, elements 2412, ...) and other kinds of records (coherences,
operating shapes, static data at nodes) are skipped with a log message.

Directions
----------
UFF direction codes 1..6 map to ``x y z rx ry rz`` (:mod:`femupdate.dofs`). A negative code
means that the transducer points the negative way: its data are negated and stored under the
positive label. In dataset 55 the components ``r1 .. r6`` of each node are ``x .. rz``, along
the axes of the node's displacement system.

What the reader decided (components left out, units converted, systems applied) is listed in
:attr:`TestData.notes`.

Every malformed or inconsistent file raises :class:`~femupdate.InputError` with one message that
names the file and the record (``"test.uff: dataset 55 record 2: ..."``, records counted
from 1 among the datasets of that type).

Writing goes through :func:`femupdate.io.results.atomic_write_bytes`: a regular file is replaced
only when the new one is complete, so a failed write never leaves a truncated file; devices,
symbolic links and the inputs of a run are handled as for every output.

Layout: :mod:`.conventions` (dataset numbers, direction and unit codes shared by both ways),
:mod:`.read` (:func:`read_uff`) and :mod:`.write` (:func:`write_uff_modes`, :func:`write_uff_frf`).
"""

from .conventions import UNIT_SYSTEMS
from .read import read_uff
from .write import write_uff_frf, write_uff_modes

__all__ = ["read_uff", "write_uff_modes", "write_uff_frf"]
