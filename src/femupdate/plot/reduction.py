"""Figures of the model-reduction paper sections (Tan's truss, Lin's super-element beam)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._docs import PLOT_DOCS, shared_docs  # noqa: E402
from .paper_figures import save_figure  # noqa: E402


@shared_docs(**PLOT_DOCS)
def truss_metrics_axes(table: dict, methods, axes=None):
    """Accuracy (max frequency error) and robustness (self-orthogonality) per method and scenario.

    Parameters
    ----------
    table : dict of str to dict
        Scenario -> method -> dict like :meth:`femupdate.reduction.metrics.TamMetrics.summary`, with
        ``max_frequency_error`` and ``self_orthogonality_max_offdiag``; one bar colour per scenario.
    methods : sequence of str
        Methods, in the order of the bar groups.
    {{AXES_PAIR}}
    """
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(10, 4))
    x = np.arange(len(methods))
    w = 0.8 / len(table)
    for k, (name, t) in enumerate(table.items()):
        axes[0].bar(x + k * w, [max(t[m]["max_frequency_error"], 1e-16) for m in methods], w, label=name)
        axes[1].bar(x + k * w, [t[m]["self_orthogonality_max_offdiag"] for m in methods], w, label=name)
    axes[0].set(yscale="log", ylabel="max |f_r / f - 1|", title="accuracy: reduced vs full frequencies")
    axes[1].set(ylabel="max |off-diagonal|", title="robustness: test self-orthogonality")
    axes[1].axhline(0.1, color="k", lw=0.8, ls="--")
    for ax in axes:
        ax.set_xticks(x + 0.4 - w / 2, methods)
        ax.legend()
    return axes


@shared_docs(**PLOT_DOCS)
def truss_metrics_figure(path, table, methods, sweep: dict | None = None) -> str:
    """Save :func:`truss_metrics_axes` to ``path`` (with a third panel for ``sweep``).

    Parameters
    ----------
    {{FIGURE_PATH}}
    table, methods
        As :func:`truss_metrics_axes`.
    sweep : dict of float to dict, optional
        Model error sigma -> method -> metrics dict: self-orthogonality against sigma per method.

    {{FIGURE_NAME}}
    """
    fig, axes = plt.subplots(1, 3 if sweep else 2, figsize=(15 if sweep else 10, 4))
    truss_metrics_axes(table, methods, axes[:2])
    if sweep:
        sig = sorted(sweep)
        for m in methods:
            axes[2].plot(sig, [sweep[s][m]["self_orthogonality_max_offdiag"] for s in sig], "o-", label=m)
        axes[2].set(xlabel="model error sigma of the member moduli", ylabel="max |off-diagonal|",
                    title="robustness vs model error (6 modes)")
        axes[2].legend()
    fig.tight_layout()
    return save_figure(fig, path)


@shared_docs(**PLOT_DOCS)
def superelement_figure(path, true, updated, direct, K) -> str:
    """Updated super-element moduli against the truth, and the banded reduced stiffness.

    Parameters
    ----------
    {{FIGURE_PATH}}
    true : array_like, shape ``(n_groups,)``
        True modulus of each super-element, Pa.
    updated, direct : array_like, shape ``(n_groups,)``
        Moduli from the iterative and the direct update, Pa (plotted as % error).
    K : array_like or sparse matrix
        Reduced stiffness, whose sparsity pattern is drawn.

    {{FIGURE_NAME}}
    """
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(10, 4))
    k = np.arange(1, len(true) + 1)
    a0.plot(k, (np.asarray(updated) / true - 1) * 100, "o-", label="iterative, 10 modes")
    a0.plot(k, (np.asarray(direct) / true - 1) * 100, "s--", label="direct on reduced model")
    a0.set(xlabel="super-element", ylabel="error of the updated modulus [%]", title="52-dof super-element model")
    a0.axhline(0, color="k", lw=0.8)
    a0.legend()
    a1.spy(K, markersize=2)
    a1.set_title("reduced stiffness: banded")
    return save_figure(fig, path)
