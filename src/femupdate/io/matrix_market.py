"""A strict Matrix Market reader for exported stiffness and mass matrices.

SciPy's ``mmread`` reads what the header says, which turns common exporter mistakes into wrong
matrices without a word.  :func:`read_matrix_market` reads the header itself and refuses, naming
the file (and the line of an offending entry):

* a ``symmetric`` (or ``hermitian``) header over a file that stores **both triangles**: the
  format stores one triangle and mirrors it, so every off-diagonal term would be counted twice;
* a ``pattern`` field (positions without values): no stiffness or mass can be read from it;
* a ``complex`` field with a non-zero imaginary part (a structural-damping stiffness ``K(1 + iη)``
  is not a stiffness: export the real part); one whose imaginary parts are all zero is read as real,
  with a logged warning saying so;
* a ``skew-symmetric`` header (a stiffness or mass matrix is symmetric);
* indices outside ``1 .. n`` -- in particular an index 0, the mark of a writer that counted from 0
  (Matrix Market counts from 1) -- and a count of entries other than the size line announces.

Files in the ``array`` (dense) format are passed to SciPy after the same header checks.
"""

from __future__ import annotations

import io
import logging
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from .._errors import InputError

log = logging.getLogger(__name__)

_FORMATS = ("coordinate", "array")
_FIELDS = ("real", "double", "integer", "complex", "pattern")
_SYMMETRIES = ("general", "symmetric", "skew-symmetric", "hermitian")


def _header(p: Path, what: str) -> tuple[str, str, str, list[str], int]:
    """The banner's format, field and symmetry, the remaining lines and the 1-based line number
    of the first of them."""
    try:
        text = p.read_bytes().decode("ascii")
    except UnicodeDecodeError:
        raise InputError(f"{what}: {p} is not a Matrix Market text file (non-ASCII bytes)") from None
    except OSError as exc:
        raise InputError(f"{what}: {p} cannot be read ({exc.strerror or exc})") from None
    lines = text.splitlines()
    banner = lines[0].split() if lines else []
    if len(banner) != 5 or banner[0].lower() != "%%matrixmarket" or banner[1].lower() != "matrix":
        raise InputError(f"{what}: {p} does not begin with a Matrix Market banner "
                         "('%%MatrixMarket matrix coordinate real symmetric' or the like)")
    fmt, fld, sym = (w.lower() for w in banner[2:])
    for word, allowed, kind in ((fmt, _FORMATS, "format"), (fld, _FIELDS, "field"), (sym, _SYMMETRIES, "symmetry")):
        if word not in allowed:
            raise InputError(f"{what}: {p}: unknown Matrix Market {kind} {word!r} (one of {', '.join(allowed)})")
    if fld == "pattern":
        raise InputError(f"{what}: {p} is a 'pattern' file: it lists where the matrix has entries but not their "
                         "values; export the matrix with its values (field real)")
    if sym == "skew-symmetric":
        raise InputError(f"{what}: {p} is declared skew-symmetric; a stiffness or mass matrix is symmetric")
    return fmt, fld, sym, lines[1:], 2


def _body(lines: list[str], first: int, p: Path, what: str) -> tuple[tuple[int, int, int], np.ndarray, np.ndarray]:
    """The size line and the entries' table of a coordinate file, with each entry's line number."""
    numbers = [(k, ln) for k, ln in enumerate(lines, start=first) if ln.strip() and not ln.lstrip().startswith("%")]
    if not numbers:
        raise InputError(f"{what}: {p} has no size line")
    k0, size = numbers[0]
    try:
        n_rows, n_cols, nnz = (int(w) for w in size.split())
    except ValueError:
        raise InputError(f"{what}: {p}: line {k0}: expected the size line 'rows columns entries', got "
                         f"{size.strip()!r}") from None
    rows = numbers[1:]
    if len(rows) != nnz:
        raise InputError(f"{what}: {p}: the size line (line {k0}) announces {nnz} entries, the file has {len(rows)}")
    if not rows:
        return (n_rows, n_cols, nnz), np.zeros((0, 3)), np.zeros(0, dtype=int)
    try:
        table = np.loadtxt(io.StringIO("\n".join(r for _, r in rows)), ndmin=2, dtype=float)
    except ValueError as exc:
        raise InputError(f"{what}: {p}: an entry is not 'row column value' numbers ({exc})") from None
    return (n_rows, n_cols, nnz), table, np.array([k for k, _ in rows])


def _indices(table: np.ndarray, line_no: np.ndarray, shape: tuple[int, int], p: Path, what: str):
    """0-based row and column indices of the entries; an index outside 1..n refused by line."""
    ij = table[:, :2]
    if np.any(ij != np.round(ij)):
        k = int(np.flatnonzero(np.any(ij != np.round(ij), axis=1))[0])
        raise InputError(f"{what}: {p}: line {line_no[k]}: indices must be integers")
    ij = ij.astype(np.int64)
    for axis, n, name in ((0, shape[0], "row"), (1, shape[1], "column")):
        bad = np.flatnonzero((ij[:, axis] < 1) | (ij[:, axis] > n))
        if bad.size:
            k = int(bad[0])
            hint = (" (Matrix Market counts from 1: the file looks written with 0-based indices)"
                    if ij[k, axis] == 0 else "")
            raise InputError(f"{what}: {p}: line {line_no[k]}: {name} index {ij[k, axis]} outside 1..{n}{hint}")
    return ij[:, 0] - 1, ij[:, 1] - 1


def _both_triangles(i, j, line_no, p: Path, what: str, sym: str) -> None:
    """Refuse a symmetric file that stores entries on both sides of the diagonal."""
    lower, upper = i > j, i < j
    if not (lower.any() and upper.any()):
        return
    n = int(max(i.max(), j.max())) + 1
    low_keys = set((i[lower] * n + j[lower]).tolist())
    mirrored = np.flatnonzero(upper & np.isin(j * n + i, list(low_keys)))
    k = int(mirrored[0]) if mirrored.size else int(np.flatnonzero(upper)[0])
    twin = "; its mirror entry is also stored" if mirrored.size else ""
    raise InputError(f"{what}: {p} is declared {sym} but stores both triangles (line {line_no[k]}: entry "
                     f"({i[k] + 1}, {j[k] + 1}) above the diagonal{twin}); the format stores one triangle and "
                     "mirrors it, so reading it would count every off-diagonal term twice: write the header as "
                     "'general', or store one triangle")


def _real_values(values, line_no, p: Path, what: str):
    """Real values of a complex field, refused when an imaginary part is not zero."""
    if not np.any(values.imag):
        log.warning("%s: %s holds complex values whose imaginary parts are all zero: read as real", what, p)
        return values.real
    k = int(np.argmax(np.abs(values.imag)))
    raise InputError(f"{what}: {p} holds complex values (line {line_no[k]}: imaginary part {values.imag[k]:.4g}); "
                     "K and M must be real: a structural-damping stiffness K(1 + iη) is not read, export the real "
                     "part (and give damping as test data)")


def read_matrix_market(p, what: str = "matrix"):
    """Read a Matrix Market file strictly (module docstring).

    Parameters
    ----------
    p : str or os.PathLike
        The ``.mtx`` file.
    what : str, default ``"matrix"``
        What the matrix is, for messages.

    Returns
    -------
    scipy.sparse.csr_array or numpy.ndarray
        The matrix (real); coordinate files as CSR with a symmetric file's triangle mirrored and
        duplicate entries summed, array files as SciPy reads them.

    Raises
    ------
    InputError
        As the module docstring lists; a malformed banner, size line or entry.
    """
    p = Path(p)
    fmt, fld, sym, lines, first = _header(p, what)
    if fmt == "array":
        try:
            A = scipy.io.mmread(p)
        except Exception as exc:  # noqa: BLE001 - SciPy's reader raises several types
            raise InputError(f"{what}: cannot read {p}: {exc}") from None
        if np.iscomplexobj(A):
            A = _real_values(np.asarray(A).ravel(), np.zeros(A.size, int), p, what).reshape(A.shape)
        return A
    shape3, table, line_no = _body(lines, first, p, what)
    shape = shape3[:2]
    if not table.shape[0]:
        return sp.csr_array(shape, dtype=float)
    width = 4 if fld == "complex" else 3
    if table.shape[1] != width:
        raise InputError(f"{what}: {p}: expected {width} numbers per entry for a {fld} field, found {table.shape[1]}")
    i, j = _indices(table, line_no, shape, p, what)
    values = table[:, 2] + 1j * table[:, 3] if fld == "complex" else table[:, 2]
    if sym in ("symmetric", "hermitian"):
        _both_triangles(i, j, line_no, p, what, sym)
    if fld == "complex":
        values = _real_values(values, line_no, p, what)
    if sym in ("symmetric", "hermitian"):
        off = i != j
        i, j, values = np.r_[i, j[off]], np.r_[j, i[off]], np.r_[values, values[off]]
    A = sp.coo_array((values.astype(float), (i, j)), shape=shape).tocsr()
    A.sum_duplicates()
    return A


__all__ = ["read_matrix_market"]
