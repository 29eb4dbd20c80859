"""Structures and simulated scans of the full-field studies (paper sections, tests).

* :func:`segmented_cantilever` — a plane cantilever beam whose bending stiffness is unknown per
  segment (Young's modulus ``E1 .. En``): the full-field direct identification example.
* :func:`scan_beam` — a scanning-vibrometer test of a beam along x: transverse motion at points
  that are not nodes, from the element shape functions (cubic Hermite) of a (finer) truth model.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from ..modal import model_modes
from ..structure import Structure
from .scan import ScanData, ScanMode


def segmented_cantilever(n_el: int = 12, E: Sequence[float] = (2.1e11,) * 4, length: float = 1.0, A: float = 1e-3,
                         I: float = 8.33e-8, rho: float = 7850.0, bounds=(1e10, 5e11)) -> Structure:
    """Cantilever (node 0 clamped) of ``n_el`` beam2d elements along x; E per segment (equal lengths)."""
    s = Structure(f"segmented cantilever ({n_el} elements)")
    x = np.linspace(0.0, length, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    for k, e in enumerate(E, start=1):
        s.parameter(f"E{k}", e, bounds)
    seg = np.minimum(np.arange(n_el) * len(E) // n_el, len(E) - 1)
    s.beam2d(np.c_[np.arange(n_el), np.arange(1, n_el + 1)], E=[f"E{k + 1}" for k in seg], A=A, I=I, rho=rho)
    s.support_node([0])
    return s


def scan_beam(truth, points_x: np.ndarray, n_modes: int = 4, noise: float = 0.0, seed: int = 0) -> ScanData:
    """Scan of a beam along x (nodes 0..n at x_i, node 0 clamped): ``y`` at ``points_x``.

    The truth's mode shapes are evaluated between its nodes by their own cubic Hermite shape
    functions (the beam element's displacement field), scaled to 1 at the largest scanned value,
    and perturbed by Gaussian noise of standard deviation ``noise``.  Axial motion is declared
    zero (bending modes).
    """
    ids = sorted(truth.nodes)
    x = np.array([truth.nodes[i][0] for i in ids])
    modes = model_modes(truth, n_modes=n_modes)
    rng = np.random.default_rng(seed)
    out = []
    for r in range(n_modes):
        v = np.array([modes.shapes[truth.dofs.index(f"{i}:y"), r] if f"{i}:y" in truth.dofs else 0.0 for i in ids])
        th = np.array([modes.shapes[truth.dofs.index(f"{i}:rz"), r] if f"{i}:rz" in truth.dofs else 0.0 for i in ids])
        f = CubicHermiteSpline(x, v, th)(points_x)
        f = f / np.max(np.abs(f))
        out.append(ScanMode(float(modes.eigenvalues[r]), {"y": f + noise * rng.standard_normal(f.size)}, f"mode {r + 1}"))
    pts = np.column_stack([points_x, np.zeros(len(points_x)), np.zeros(len(points_x))])
    return ScanData(pts, tuple(out), zero=("x",))
