"""Posterior samples on disk: CSV (``pandas.read_csv``, ``numpy.genfromtxt``) or NumPy ``.npz``
(``numpy.load``), written atomically."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .._errors import InputError
from .model_write import csv_text
from .results import atomic_write_bytes, atomic_write_text

#: the suffixes :func:`write_samples` takes
SAMPLE_SUFFIXES = (".csv", ".npz")


def sample_columns(result) -> tuple[list[str], np.ndarray]:
    """The columns of a :class:`~femupdate.bayes.PosteriorResult`'s samples table and its values:
    ``sample`` (0-based), for MCMC ``ensemble``, ``step`` (after burn-in, 0-based from the first
    kept step) and ``walker``, then one column per parameter and ``log_likelihood``."""
    S, L = result.samples.shape
    cols = ["sample"]
    parts = [np.arange(S, dtype=float)[:, None]]
    if result.method == "mcmc" and result.chain is not None:
        E, n, W, _ = result.chain.shape
        kept = n - int(result.diagnostics.get("burn", 0))
        e, k, w = np.meshgrid(np.arange(E), np.arange(kept), np.arange(W), indexing="ij")
        cols += ["ensemble", "step", "walker"]
        parts.append(np.column_stack([e.ravel(), k.ravel(), w.ravel()]).astype(float))
    cols += list(result.names) + ["log_likelihood"]
    parts += [result.samples, np.asarray(result.log_likelihood, float)[:, None]]
    return cols, np.hstack(parts)


def write_samples(path, result) -> Path:
    """Write the samples of ``result`` to ``path``: ``.csv`` (a header row, then one row per
    sample: :func:`sample_columns`; integers as integers, numbers in full precision, a log
    likelihood not evaluated empty) or ``.npz`` (``names``, ``samples`` (S, L), ``log_likelihood``
    (S,), ``method``, and for MCMC ``chain`` (E, n, W, L) with the burn-in and ``burn``).

    Raises
    ------
    InputError
        Another suffix.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SAMPLE_SUFFIXES:
        raise InputError(f"{path}: samples are written as .csv or .npz")
    if suffix == ".npz":
        arrays = {"names": np.array(result.names), "samples": result.samples,
                  "log_likelihood": np.asarray(result.log_likelihood, float), "method": np.array(result.method)}
        if result.chain is not None:
            arrays["chain"] = result.chain
            arrays["burn"] = np.array(int(result.diagnostics.get("burn", 0)))
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        atomic_write_bytes(path, buf.getvalue())
        return path
    cols, values = sample_columns(result)
    n_int = 4 if "walker" in cols else 1
    rows = [[int(v) for v in row[:n_int]] + [float(v) for v in row[n_int:]] for row in values]
    atomic_write_text(path, csv_text(cols, rows))
    return path


__all__ = ["write_samples", "sample_columns", "SAMPLE_SUFFIXES"]
