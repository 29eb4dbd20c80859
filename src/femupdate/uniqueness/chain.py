"""Identifiability of a grounded spring chain from m modes at a set of measured dofs.

The chain is ``ground -k1- m1 -k2- m2 ... -kN- mN`` (:func:`femupdate.examples.chain`), masses
known, springs unknown, as the paper's six-dof simulation.  Two things are computed here:

* :func:`chain_rank_bound` — the rank of the sensitivity matrix that the *layout* allows, from a
  counting (matching) argument; it is the generic rank, and the criterion the paper's counting
  rules miss;
* :func:`chain_sensitivity` — the sensitivity matrix itself, densely and independently of
  :mod:`femupdate.sensitivity` (modal sum over all modes, or central finite differences), under
  the definitions the paper mixes: eq. 17 or eq. 19 rows, scaled or mass-normalised shapes.

The rank argument
-----------------
With the measured dofs ``j_1 < ... < j_n`` the chain falls into *segments*: the springs up to
``j_1`` (grounded head), those between two consecutive measured dofs, and those beyond ``j_n``
(free tail).  Every mode gives exactly n equations of motion, one at each measured dof (the
eigenvalue is measured, the shape is known up to a scale and the equations are homogeneous in
it); the unmeasured masses of a segment are condensed into its frequency-dependent dynamic
stiffness, so a segment's springs enter only the equations at the measured dofs it touches.  The
rank of the sensitivity matrix is therefore at most the largest number of springs that can be
matched to distinct equations, each measured dof supplying at most m equations and each segment
absorbing at most its number of springs: a maximum flow, source → measured dof (capacity m) →
adjacent segment → sink (capacity: the segment's springs).  It equals, generically, the
numerical rank (checked over every layout of the six-dof chain in ``tests``).  Full rank needs,
by Hall's theorem, that every group of segments has no more springs than m times the number of
measured dofs that touch it.  Two consequences:

* consecutive sensors at dofs 1..n: rank = min(mn, n + min(m, N − n)), full iff m + n >= N and
  mn >= N;
* consecutive sensors at the free end, dofs N−n+1..N: rank = min(mn, n − 1 + min(m, N − n + 1)),
  full iff m + n >= N + 1 and mn >= N.

So mn >= L (the data count) is necessary but not sufficient: the data must also reach every
segment.  Full rank is local identifiability; a single sensor (n = 1) can be full rank and still
admit several solutions (the paper's two-dof example), hence the paper's extra n > 1.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def chain_segments(n_dofs: int, measured: Sequence[int]) -> list[tuple[int, tuple[int, ...]]]:
    """Segments of the chain cut at the measured dofs: ``(springs, measured dofs touched)``.

    Parameters
    ----------
    n_dofs : int
        N, the number of masses (and springs).
    measured : sequence of int
        Measured dofs, 1-based (dof j is mass j), distinct, within 1..N.

    Returns
    -------
    list of (int, tuple of int)
        Head segment first (springs 1..j_1), then the gaps, then the free tail (if any).
    """
    meas = sorted({int(j) for j in measured})
    if not meas or meas[0] < 1 or meas[-1] > n_dofs:
        raise ValueError(f"chain_segments: measured dofs must lie in 1..{n_dofs}, got {list(measured)}")
    segs: list[tuple[int, tuple[int, ...]]] = []
    prev = 0
    for j in meas:
        segs.append((j - prev, (j,) if prev == 0 else (prev, j)))
        prev = j
    if prev < n_dofs:
        segs.append((n_dofs - prev, (prev,)))
    return segs


def chain_rank_bound(n_dofs: int, measured: Sequence[int], n_modes: int) -> int:
    """Largest rank of the chain's sensitivity matrix that the layout allows (module docstring).

    Parameters
    ----------
    n_dofs : int
        N.
    measured : sequence of int
        Measured dofs, 1-based.
    n_modes : int
        m, the number of measured modes.

    Returns
    -------
    int
        The maximum flow source → measured dof (capacity m) → adjacent segment → sink (capacity:
        its springs); at most N.
    """
    segs = chain_segments(n_dofs, measured)
    meas = sorted({int(j) for j in measured})
    E, S = len(meas), len(segs)
    n = 2 + E + S
    cap = np.zeros((n, n), dtype=np.int64)
    big = n_dofs * max(1, n_modes) + 1
    for a in range(E):
        cap[0, 2 + a] = n_modes
    for b, (size, touch) in enumerate(segs):
        cap[2 + E + b, 1] = size
        for j in touch:
            cap[2 + meas.index(j), 2 + E + b] = big
    flow = 0
    while True:  # Edmonds-Karp: shortest augmenting paths (the graph has at most 2N + 3 nodes)
        parent = np.full(n, -1)
        parent[0] = 0
        queue = [0]
        while queue and parent[1] < 0:
            u = queue.pop(0)
            for w in np.flatnonzero((cap[u] > 0) & (parent < 0)):
                parent[w] = u
                queue.append(int(w))
        if parent[1] < 0:
            return int(min(flow, n_dofs))
        f, v = big, 1
        while v != 0:
            f = min(f, int(cap[parent[v], v]))
            v = int(parent[v])
        v = 1
        while v != 0:
            cap[parent[v], v] -= f
            cap[v, parent[v]] += f
            v = int(parent[v])
        flow += f


def _chain_matrices(k, m):
    k = np.asarray(k, dtype=float)
    N = k.size
    dK = np.zeros((N, N, N))
    dK[0, 0, 0] = 1.0
    for j in range(1, N):
        dK[j, j - 1, j - 1] = dK[j, j, j] = 1.0
        dK[j, j - 1, j] = dK[j, j, j - 1] = -1.0
    return np.einsum("j,jab->ab", k, dK), np.diag(np.asarray(m, dtype=float)), dK


def _chain_data(k, m, idx, n_modes, shapes, eigen, lam0, phi0):
    """The measured quantities of eq. 17/19 at stiffnesses k (signs matched to phi0)."""
    import scipy.linalg as sl

    K, M, _ = _chain_matrices(k, m)
    lam, P = sl.eigh(K, M)
    P = P * np.sign(np.sum(P * phi0, axis=0))
    out = []
    for i in range(n_modes):
        out.append(lam[i] / lam0[i] if eigen == "relative" else lam[i])
        ph = P[idx, i]
        out.extend(ph[1:] / ph[0] if shapes == "scaled" else ph)
    return np.array(out)


def chain_sensitivity(k, m, measured: Sequence[int], n_modes: int, *, shapes: str = "scaled",
                      eigen: str = "relative", derivative: str = "analytic", rel_step: float = 1e-6) -> np.ndarray:
    """Sensitivity matrix of a grounded chain's modal data to its springs, per unit relative change.

    Parameters
    ----------
    k, m : array_like, shape ``(N,)``
        Springs (N/m) and masses (kg).
    measured : sequence of int
        Measured dofs, 1-based; the first is the scaling reference for ``shapes="scaled"``.
    n_modes : int
        The lowest m modes.
    shapes : {"scaled", "mass"}
        ``"scaled"``: shape entries divided by the first measured one (n − 1 rows per mode: the
        scaling removes one, the paper's argument for mn); ``"mass"``: the measured entries of
        mass-normalised eigenvectors (n rows per mode: eq. 17's m(n + 1) count, which needs an
        absolute scale a test gives only with a measured driving point).
    eigen : {"relative", "absolute"}
        Eigenvalue rows ∂λ/λ (eq. 19) or ∂λ (eq. 17).
    derivative : {"analytic", "central"}
        Fox & Kapoor's modal sum over all N modes (exact), or central differences of the
        eigensolution with step ``rel_step`` × k_j (the paper's "perturbation").
    rel_step : float, default 1e-6

    Returns
    -------
    ndarray, shape ``(m n, N)`` (scaled shapes) or ``(m (n + 1), N)`` (mass-normalised)
        Rows per mode: the eigenvalue, then the shape rows; columns ∂/∂(k_j / k_j0).
    """
    import scipy.linalg as sl

    if shapes not in ("scaled", "mass") or eigen not in ("relative", "absolute") or derivative not in ("analytic", "central"):
        raise ValueError(f"chain_sensitivity: unknown option in shapes={shapes!r}, eigen={eigen!r}, derivative={derivative!r}")
    k = np.asarray(k, dtype=float)
    N = k.size
    idx = [int(j) - 1 for j in measured]
    K, M, dK = _chain_matrices(k, m)
    lam, P = sl.eigh(K, M)
    if derivative == "central":
        cols = []
        for j in range(N):
            h = rel_step * k[j]
            kp, km = k.copy(), k.copy()
            kp[j] += h
            km[j] -= h
            d = (_chain_data(kp, m, idx, n_modes, shapes, eigen, lam, P)
                 - _chain_data(km, m, idx, n_modes, shapes, eigen, lam, P)) / (2 * h)
            cols.append(d * k[j])
        return np.array(cols).T
    rows = []
    for i in range(n_modes):
        F = np.einsum("a,jab,bc->jc", P[:, i], dK, P) * k[:, None]  # (N params, N modes): k_j φ_r' K_j φ_i
        dlam = F[:, i]
        gap = lam[i] - lam
        gap[i] = np.inf
        dphi = P @ (F / gap).T  # (N dofs, N params); K_j leaves M, so no φ_i term (Fox & Kapoor)
        rows.append((dlam / lam[i] if eigen == "relative" else dlam)[None, :])
        ph, d = P[idx, i], dphi[idx]
        rows.append((d[1:] - np.outer(ph[1:], d[0]) / ph[0]) / ph[0] if shapes == "scaled" else d)
    return np.vstack(rows)
