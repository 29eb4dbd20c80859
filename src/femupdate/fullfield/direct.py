r"""The direct solution (paper eqs. 1-10, 23-29) on data completed from a full-field scan:
pointwise, or projected onto the measured vectors (:func:`project_system`).
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError
from ..direct import DirectResult, LinearSystem, build_system, direct_update, solve_system
from ..serialise import RunContext
from ..testdata import TestData
from .mapping import FullFieldMapping, map_scan  # noqa: F401  (FullFieldMapping named here too)
from .result import FullFieldResult
from .scan import ScanData


FORMS = ("projected", "pointwise")


def project_system(system: LinearSystem, vectors: np.ndarray) -> LinearSystem:
    r"""Galerkin projection of pointwise direct equations onto the measured vectors.

    Each block of the pointwise system (one mode: :math:`(K(p) - \lambda_k M)\phi_k = 0` at every
    dof; one FRF line, real and imaginary parts) is premultiplied by :math:`W^T`, W the measured
    shapes and responses (unit length): for modes, :math:`\phi_i^T K(p)\phi_k = \lambda_k\phi_i^T M\phi_k`,
    the energy and orthogonality relations.  Still linear in p; the pointwise rows apply the
    stiffness to the measured shapes (a discrete fourth derivative along a beam), so their noise
    is amplified and the least-squares estimate shrinks towards zero (errors in variables), while
    the projected rows integrate it.

    Parameters
    ----------
    system : LinearSystem
        Pointwise equations (:func:`femupdate.direct.build_system`): every block a whole number of
        n-row parts, one row per dof.
    vectors : ndarray, shape ``(n_dofs, w)``
        Real projection vectors, columns of unit length (:func:`measured_vectors`).

    Returns
    -------
    LinearSystem
        ``w`` rows per n-row part of each block, blocks labelled ``"... (projected)"``; same unknowns.

    Raises
    ------
    InputError
        A block whose row count is not a multiple of ``n_dofs``.
    """
    n = vectors.shape[0]
    A, b = np.asarray(system.A), system.b
    rows_A, rows_b, blocks, at = [], [], [], 0
    for desc, k in system.blocks:
        parts = k // n
        if parts * n != k:
            raise InputError(f"block {desc!r}: {k} rows is not a multiple of {n} dofs")
        for q in range(parts):
            sl = slice(at + q * n, at + (q + 1) * n)
            rows_A.append(vectors.T @ A[sl])
            rows_b.append(vectors.T @ b[sl])
        blocks.append((f"{desc} (projected)", parts * vectors.shape[1]))
        at += k
    return LinearSystem(np.vstack(rows_A), np.concatenate(rows_b), system.unknowns, blocks)


def measured_vectors(data: TestData) -> np.ndarray:
    """Unit-length real vectors of the complete test data.

    Parameters
    ----------
    data : TestData
        Complete test data: mode shapes and/or FRF responses at every model dof.

    Returns
    -------
    ndarray, shape ``(n_dofs, w)``
        One column per mode with a shape (its real part), then per FRF response row its real part
        and, when non-zero, its imaginary part; each column scaled to unit length.
    """
    cols = [np.real(m.shape) for m in data.modes if m.has_shape]
    if data.frf is not None:
        for x in np.atleast_2d(data.frf.response):
            cols.append(np.real(x))
            if np.iscomplexobj(x) and np.any(np.imag(x)):
                cols.append(np.imag(x))
    W = np.column_stack(cols)
    return W / np.linalg.norm(W, axis=0)


def complete_direct(model, data: TestData, *, form: str = "projected", use=("modes", "frf", "static"), values=None,
                    unknowns=None, bounded: bool = False) -> DirectResult:
    """Direct solution from complete data, pointwise or projected.

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : TestData
        Test data at every model dof (e.g. ``FullFieldMapping.data``).
    form : {"projected", "pointwise"}, default ``"projected"``
        ``"pointwise"``: :func:`femupdate.direct.direct_update` (paper eqs. 4-10, 24-29);
        ``"projected"``: those equations projected onto the measured vectors
        (:func:`project_system`, :func:`measured_vectors`).
    use : sequence of str, default ``("modes", "frf", "static")``
        Kinds of data to stack; ``"static"`` is dropped by the projected form.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Values of the known (fixed) parameters (default nominal).
    unknowns : sequence of str, optional
        Parameters to identify (default: every parameter not fixed).
    bounded : bool, default False
        Honour the parameters' bounds with a bounded least-squares solve.

    Returns
    -------
    DirectResult

    Raises
    ------
    InputError
        An unknown ``form``; otherwise as :func:`femupdate.direct.direct_update`.
    """
    if form not in FORMS:
        raise InputError(f"unknown form {form!r}: use {', '.join(FORMS)}")
    if form == "pointwise":
        return direct_update(model, data, use=use, values=values, unknowns=unknowns, bounded=bounded)
    notes: list[str] = []
    kinds = [u for u in use if u != "static"]
    system = project_system(build_system(model, data, kinds, values, unknowns, notes), measured_vectors(data))
    return solve_system(model, system, values, bounded, notes)


def full_field_direct(model, scan: ScanData, *, form: str = "projected", use=("modes", "frf"), values=None, unknowns=None,
                      bounded: bool = False, **mapping) -> FullFieldResult:
    """Map the scan onto the model's dofs (:func:`map_scan`) and solve directly.

    Parameters
    ----------
    model : Model
        The parametrised model, with node coordinates.
    scan : ScanData
        The full-field scan.
    form : {"projected", "pointwise"}, default ``"projected"``
        ``"projected"``: the pointwise equations projected onto the measured vectors
        (:func:`project_system`); ``"pointwise"``: the paper's eqs. 4-10 and 24-29 as printed.
    use : sequence of str, default ``("modes", "frf")``
        Kinds of data to use; those the mapped scan does not hold are skipped.
    values, unknowns, bounded
        As :func:`complete_direct`.
    **mapping
        Keyword arguments of :func:`map_scan` (``method``, ``smoothing``, ...).

    Returns
    -------
    FullFieldResult
        The direct solution (``.direct``) and the mapping (``.mapping``), with the model as its
        context; it unpacks as ``result, mapping = full_field_direct(...)``.

    Raises
    ------
    InputError
        The scan holds none of the kinds in ``use``; otherwise as :func:`map_scan` and
        :func:`complete_direct`.
    """
    m = map_scan(model, scan, **mapping)
    kinds = [u for u in use if (u == "modes" and m.data.modes) or (u == "frf" and m.data.frf is not None)]
    if not kinds:
        raise InputError(f"the scan holds none of the data kinds asked for ({', '.join(use)})")
    res = complete_direct(model, m.data, form=form, use=kinds, values=values, unknowns=unknowns, bounded=bounded)
    return FullFieldResult(res, m, form, context=RunContext(model=model))
