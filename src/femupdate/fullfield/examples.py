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
    """Plane cantilever of ``n_el`` beam2d elements along x, Young's modulus unknown per segment.

    Nodes 0..n_el equally spaced on ``[0, length]`` at y = 0, node 0 clamped.  The elements are split
    into ``len(E)`` consecutive segments: element i (0-based) takes the parameter
    ``"E<k>"``, ``k = i * len(E) // n_el + 1``.

    Parameters
    ----------
    n_el : int, default 12
        Number of elements.
    E : sequence of float, default ``(2.1e11,) * 4``
        Nominal Young's modulus of each segment (N/m^2); its length is the number of segments.
    length : float, default 1.0
        Beam length (m).
    A : float, default 1e-3
        Cross-section area (m^2).
    I : float, default 8.33e-8
        Second moment of area (m^4).
    rho : float, default 7850.0
        Density (kg/m^3).
    bounds : (float, float), default ``(1e10, 5e11)``
        Bounds of every ``E<k>`` parameter (N/m^2).

    Returns
    -------
    Structure
    """
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
    """Simulated scan of a beam along x: the ``y`` motion at ``points_x``.

    The truth's lowest ``n_modes`` mode shapes are evaluated between its nodes by the cubic Hermite
    interpolation of their ``y`` and ``rz`` nodal values (the beam element's displacement field;
    a missing dof counts as zero), scaled to 1 at the largest scanned magnitude, and perturbed by
    Gaussian noise.  Axial motion is declared zero (bending modes).  The eigenvalues are the truth's,
    without noise.

    Parameters
    ----------
    truth : Model
        Beam model with nodes along x (e.g. a finer :func:`segmented_cantilever`).
    points_x : ndarray, shape ``(n_points,)``
        x coordinates of the scan points (m), within the nodes' range; y = z = 0.
    n_modes : int, default 4
        Number of modes.
    noise : float, default 0.0
        Standard deviation of the noise added to each scanned value (relative to the unit largest value).
    seed : int, default 0
        Seed of the random generator.

    Returns
    -------
    ScanData
        Modes labelled ``"mode 1"``, ... with ``values = {"y": (n_points,)}``, ``zero=("x",)``.
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
