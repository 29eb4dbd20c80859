r"""The direct solution (paper eqs. 1-10, 23-29) on data completed from a full-field scan:
pointwise, or projected onto the measured vectors (:func:`project_system`).
"""

from __future__ import annotations

import numpy as np

from .._errors import InputError
from ..direct import DirectResult, LinearSystem, build_system, direct_update, solve_system
from ..testdata import TestData
from .mapping import FullFieldMapping, map_scan
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

    ``vectors``: (n, w) real, columns of unit length.
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
    """Unit-length real vectors of the complete test data (mode shapes, FRF real and imaginary parts)."""
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
    """Direct solution from complete data, pointwise (paper eqs. 4-10, 24-29) or projected
    (:func:`project_system`)."""
    if form not in FORMS:
        raise InputError(f"unknown form {form!r}: use {', '.join(FORMS)}")
    if form == "pointwise":
        return direct_update(model, data, use=use, values=values, unknowns=unknowns, bounded=bounded)
    notes: list[str] = []
    kinds = [u for u in use if u != "static"]
    system = project_system(build_system(model, data, kinds, values, unknowns, notes), measured_vectors(data))
    return solve_system(model, system, values, bounded, notes)


def full_field_direct(model, scan: ScanData, *, form: str = "projected", use=("modes", "frf"), values=None, unknowns=None,
                      bounded: bool = False, **mapping) -> tuple[DirectResult, FullFieldMapping]:
    """Map the scan onto the model's dofs (:func:`map_scan`) and solve directly.

    ``form``: ``"projected"`` (default: the pointwise equations projected onto the measured
    vectors, :func:`project_system`) or ``"pointwise"`` (the paper's eqs. 4-10 and 24-29 as
    printed).  Other keyword arguments go to :func:`map_scan`.
    """
    m = map_scan(model, scan, **mapping)
    kinds = [u for u in use if (u == "modes" and m.data.modes) or (u == "frf" and m.data.frf is not None)]
    if not kinds:
        raise InputError(f"the scan holds none of the data kinds asked for ({', '.join(use)})")
    res = complete_direct(model, m.data, form=form, use=kinds, values=values, unknowns=unknowns, bounded=bounded)
    return res, m
