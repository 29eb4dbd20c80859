"""Structures and simulated tests of the damage studies (paper sections, tests).

* :func:`concentrated_mass_truss` — a plane truss with concentrated masses on flexible mounts
  (instrument packages), cantilevered or free-free: the Doebling et al. (1993) setting, in
  which the local modes of the masses crowd the low frequencies of the free-free structure.
* :func:`noisy_modes` — measured modes from a model: the lowest elastic modes at chosen dofs,
  shapes scaled to 1 at their largest entry, with Gaussian noise.

The full-field examples (:func:`~femupdate.fullfield.examples.segmented_cantilever`,
:func:`~femupdate.fullfield.examples.scan_beam`) are in :mod:`femupdate.fullfield.examples`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..modal import model_modes
from ..structure import Structure
from ..testdata import MeasuredMode, TestData


# concentrated masses: (top-chord bay, mount frequency in Hz)
PACKAGES = ((2, 22.0), (4, 28.0), (6, 34.0), (8, 40.0))


def concentrated_mass_truss(support: str = "cantilever", n_bays: int = 8, bay: float = 1.0, A: float = 4e-4,
                            E: float = 7.0e10, rho: float = 2700.0, joint_mass: float = 2.0, package_mass: float = 15.0,
                            packages=PACKAGES) -> Structure:
    """Plane aluminium truss with instrument packages on flexible mounts.

    Bottom-chord nodes 1..n+1 at y = 0, top-chord nodes 101..101+n at y = ``bay``; chords, posts
    and one diagonal per bay (rods, lumped mass) and a lumped ``joint_mass`` on the x and y dofs of
    every joint.  Package i (node 200+i, dof ``y`` only) of mass ``package_mass`` hangs on a spring
    from top node 101+bay_i, of stiffness ``package_mass (2π f_i)^2`` (tuned to its mount frequency
    f_i): a local mode.

    Parameters
    ----------
    support : {"cantilever", "free"}, default ``"cantilever"``
        ``"cantilever"``: both nodes of the left end fixed; ``"free"``: unsupported (three
        rigid-body modes).
    n_bays : int, default 8
        Number of bays.
    bay : float, default 1.0
        Bay length and truss height (m).
    A : float, default 4e-4
        Cross-section area of every member (m^2).
    E : float, default 7.0e10
        Young's modulus (N/m^2).
    rho : float, default 2700.0
        Density (kg/m^3).
    joint_mass : float, default 2.0
        Lumped mass at each joint (kg).
    package_mass : float, default 15.0
        Mass of each package (kg).
    packages : sequence of (int, float), default ``PACKAGES``
        (top-chord bay index, mount frequency in Hz) of each package.

    Returns
    -------
    Structure

    Raises
    ------
    ValueError
        An unknown ``support``.
    """
    if support not in ("cantilever", "free"):
        raise ValueError(f"support must be 'cantilever' or 'free', got {support!r}")
    s = Structure(f"{n_bays}-bay truss with concentrated masses ({support})")
    bot = np.arange(1, n_bays + 2)
    top = 100 + bot
    s.add_nodes(bot, np.c_[np.arange(n_bays + 1) * bay, np.zeros(n_bays + 1)])
    s.add_nodes(top, np.c_[np.arange(n_bays + 1) * bay, np.full(n_bays + 1, bay)])
    pairs = np.r_[np.c_[bot[:-1], bot[1:]], np.c_[top[:-1], top[1:]], np.c_[bot, top], np.c_[bot[:-1], top[1:]]]
    s.rod(pairs, E=E, A=A, rho=rho, dim=2, mass="lumped", where="truss members")
    for n in np.r_[bot, top]:
        s.mass([f"{n}:x", f"{n}:y"], m=joint_mass, where=f"joint {n}")
    for i, (b, f) in enumerate(packages):
        node = 200 + i
        s.spring([f"{node}:y", f"{top[b]}:y"], k=package_mass * (2 * np.pi * f) ** 2, where=f"package {i + 1} mount")
        s.mass([f"{node}:y"], m=package_mass, where=f"package {i + 1}")
    if support == "cantilever":
        s.support_node([int(bot[0]), int(top[0])])
    return s


def noisy_modes(model, dofs: Sequence[str], n_modes: int, values=None, frequency_noise: float = 0.0,
                shape_noise: float = 0.0, seed: int = 0) -> TestData:
    """Simulated measured modes: the lowest elastic modes of a model at chosen dofs, with noise.

    The modes with eigenvalue > 0 are taken in order; each shape is restricted to ``dofs`` and
    scaled to 1 at its largest-magnitude entry, then Gaussian noise is added.

    Parameters
    ----------
    model : Model
        The model.
    dofs : sequence of str
        Measured dofs, ``"node:dir"`` labels.
    n_modes : int
        Number of elastic modes.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Parameter values (default: nominal).
    frequency_noise : float, default 0.0
        Standard deviation of the relative frequency noise (the eigenvalue is multiplied by
        ``(1 + frequency_noise z)^2``, z standard normal).
    shape_noise : float, default 0.0
        Standard deviation of the noise added to each shape entry (relative to the unit largest
        entry).
    seed : int, default 0
        Seed of the random generator.

    Returns
    -------
    TestData
        Modes named ``"mode 1"``, ``"mode 2"``, ...

    Raises
    ------
    InputError, NumericalError
        As :func:`femupdate.modal.model_modes` and :meth:`Model.dof_index` (an unknown dof).
    """
    modes = model_modes(model, values)
    rng = np.random.default_rng(seed)
    pos = model.dof_index(dofs)
    out: list[MeasuredMode] = []
    for r in [r for r in range(modes.n_modes) if modes.eigenvalues[r] > 0][:n_modes]:
        sh = modes.shapes[pos, r] / np.max(np.abs(modes.shapes[pos, r]))
        lam = modes.eigenvalues[r] * (1 + frequency_noise * rng.standard_normal()) ** 2
        out.append(MeasuredMode(lam, tuple(dofs), sh + shape_noise * rng.standard_normal(sh.size), f"mode {len(out) + 1}"))
    return TestData(modes=tuple(out))
