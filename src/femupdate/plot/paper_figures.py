"""Figures of the reference paper's sections."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..io.results import atomic_write_bytes  # noqa: E402


def _save(fig, path) -> str:
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix.lstrip(".") or "png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path).name


def characteristic_axes(a1, a0, m1, m2, solutions, ax=None):
    """Curves a1(k1, k2) = a1 and a0(k1, k2) = a0 in the (k1, k2) plane: their crossings are
    every stiffness pair with the measured eigenvalues (eqs. 11-12)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(5.5, 4.5))
    k1 = np.linspace(3, 13, 400)
    ax.plot(k1, (a1 - m2 * k1) / (m1 + m2), label=r"$m_2k_1+(m_1+m_2)k_2=a_1$")
    ax.plot(k1, a0 / k1, label=r"$k_1k_2=a_0$")
    for s in solutions:
        ax.plot(*s, "ko")
        ax.annotate(f"({s[0]:.4g}, {s[1]:.4g})", s, textcoords="offset points", xytext=(6, 6))
    ax.set(xlabel=r"$k_1$ [N/m]", ylabel=r"$k_2$ [N/m]", xlim=(3, 13), ylim=(1, 11),
           title="two stiffness sets, identical eigenvalues")
    ax.legend(loc="upper right")
    return ax


def characteristic_curves(path, a1, a0, m1, m2, solutions) -> str:
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    characteristic_axes(a1, a0, m1, m2, solutions, ax=ax)
    return _save(fig, path)
