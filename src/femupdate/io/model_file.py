"""Model files: the TOML schema of docs/file-formats.md, and models from plain matrices.

A TOML file either describes a physical-parameter structure (``[[node]]``, ``[[element]]``,
``[[support]]``) or, with a ``[matrices]`` table, points at matrices exported from another FE
code::

    [model]
    name = "exported plate"

    [matrices]
    dofs = "dofs.txt"        # one label per line, or an inline list ["1:x", "1:y", ...]
    K0 = "K0.mtx"            # Matrix Market, .npz (scipy.sparse.save_npz or numpy), .npy,
    M0 = "M0.mtx"            # or .mat ("file.mat:VARIABLE")

    [parameters.E_skin]
    value = 7.0e10
    K = "K_skin.mtx"         # dK/dp: K = K0 + sum_j p_j K_j
    # M = "M_skin.mtx"       # dM/dp, optional

Paths are relative to the TOML file.
"""

from __future__ import annotations

import logging
import tomllib
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from .._checks import path_arg
from .._errors import InputError
from .._limits import MAX_MAGNITUDE
from .matrix_market import read_matrix_market
from .numbers import check_magnitudes, long_integer_line, parse_float
from .outputs import note_input
from ..dofs import canonical_all
from ..model import Model, Parameter
from ..penalty import eliminate_penalty_links
from ..priors import parse_prior
from ..structure import Structure

log = logging.getLogger(__name__)


def read_toml(path) -> dict:
    """Parse a TOML file.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    dict
        The parsed tables.

    Raises
    ------
    InputError
        The file is missing, a directory, not UTF-8 text, or not valid TOML; a number above
        1e150 in magnitude (the field named); arrays or tables nested too deeply.
    """
    path = Path(path)
    note_input(path, "a TOML file")
    try:
        with open(path, "rb") as fh:
            text = fh.read().decode("utf-8")
        data = tomllib.loads(text, parse_float=parse_float)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, not a model file") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: malformed TOML: {exc}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text (UTF-8) TOML file") from None
    except RecursionError:
        raise InputError(f"{path}: TOML nested too deeply") from None
    except ValueError:  # Python's limit of 4,300 digits for converting an integer string
        line = long_integer_line(text)
        raise InputError(f"{path}: line {line}: an integer too long to read (numbers must be at most "
                         f"{MAX_MAGNITUDE:g} in magnitude)") from None
    try:
        check_magnitudes(data, str(path))
    except RecursionError:
        raise InputError(f"{path}: TOML nested too deeply") from None
    return data


def load_model(path) -> Model:
    """Read a model file (TOML structure or TOML ``[matrices]`` model) into a :class:`Model`.

    The schema is in docs/file-formats.md: a physical-parameter structure (``[[node]]``,
    ``[[element]]``, ``[[support]]``) is built by :meth:`Structure.build`; a ``[matrices]`` table
    names matrix files, read by :func:`load_matrix`, relative to the TOML file.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.toml`` model file.

    Returns
    -------
    Model

    Raises
    ------
    InputError
        A suffix other than ``.toml``; an unreadable or malformed file; anything the structure,
        the matrix files or :class:`Model` reject (the message names the file).
    """
    path = path_arg(path, "path", "load_model")
    if path.suffix.lower() != ".toml":
        raise InputError(f"{path}: model files are TOML (.toml); for plain matrices write a small TOML with a [matrices] table")
    data = read_toml(path)
    if "damping" in data:
        log.warning("%s: the [damping] table is read by complex modes, update, frf-update and posterior (femupdate "
                    "complex-modes, update, frf-update, posterior, femupdate.damping.load_damped_model); here the model's "
                    "undamped K and M are used", path)
        data.pop("damping")
    return build_model(data, path)


def build_model(data: dict, path: Path) -> Model:
    """The :class:`Model` of a parsed model file (``data`` without a ``[damping]`` table)."""
    if "matrices" in data:
        return _matrix_model(data, path)
    if "blackbox" in data:
        from ..blackbox import probe_model
        from ..blackbox.table import black_box_from_table

        model = probe_model(black_box_from_table(data, path)).model
        stiffness = f"{path}: the stiffness the [blackbox] command writes"
        model = eliminate_penalty_links(model, stiffness)
        _definite(model, stiffness)
        return model
    for table in EXTERNAL:
        if table in data:
            return _external_model(data, path, table)
    try:
        return Structure.from_dict(data, source=str(path)).build()
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if str(path) in msg else f"{path}: {msg}") from None


def load_matrix(spec: str, base: Path, what: str):
    """Load one matrix: ``.mtx`` (Matrix Market), ``.npz``, ``.npy`` or ``file.mat:VAR``.

    Parameters
    ----------
    spec : str
        File name, relative to ``base`` unless absolute; for MATLAB files optionally
        ``"file.mat:VARIABLE"`` (needed when the file holds more than one variable).  A ``.npz``
        is read as a SciPy sparse matrix, else as the single array it holds.
    base : pathlib.Path
        Folder that relative names are resolved against.
    what : str
        What the matrix is, for error messages.

    Returns
    -------
    numpy.ndarray or scipy sparse matrix
        The matrix as stored (real, numeric).

    Raises
    ------
    InputError
        File not found; unsupported suffix; unreadable file; a ``.npz`` with several arrays or
        a ``.mat`` whose variable is ambiguous or missing; non-numeric or complex contents.
    """
    if not isinstance(spec, str):
        raise InputError(f"{what}: expected a matrix file name, got {spec!r}")
    name, _, var = str(spec).partition(":") if ".mat:" in str(spec) else (str(spec), "", "")
    p = (base / name) if not Path(name).is_absolute() else Path(name)
    if not p.exists():
        raise InputError(f"{what}: matrix file {p} not found")
    note_input(p, f"the matrix file of {what}")
    suffix = p.suffix.lower()
    try:
        if suffix == ".mtx":
            A = read_matrix_market(p, what)
        elif suffix == ".npz":
            try:
                A = sp.load_npz(p)
            except (ValueError, KeyError):
                with np.load(p, allow_pickle=False) as z:
                    if len(z.files) != 1:
                        raise InputError(f"{what}: {p} holds {len(z.files)} arrays ({', '.join(z.files)}); expected one matrix") from None
                    A = z[z.files[0]]
        elif suffix == ".npy":
            A = np.load(p, allow_pickle=False)
        elif suffix == ".mat":
            m = scipy.io.loadmat(p)
            names = [k for k in m if not k.startswith("__")]
            if not var:
                if len(names) != 1:
                    raise InputError(f"{what}: {p} holds variables {', '.join(names)}; name one as '{name}:VARIABLE'")
                var = names[0]
            if var not in m:
                raise InputError(f"{what}: variable {var!r} not in {p} (it holds {', '.join(names)})")
            A = m[var]
        else:
            raise InputError(f"{what}: unsupported matrix format {suffix!r} ({p}); use .mtx, .npz, .npy or .mat")
    except InputError:
        raise
    except Exception as exc:  # malformed binary files raise many different types
        raise InputError(f"{what}: cannot read {p}: {exc}") from None
    if not sp.issparse(A):
        A = np.asarray(A)
        if A.dtype == object or not np.issubdtype(A.dtype, np.number):
            raise InputError(f"{what}: {p} does not hold a numeric matrix")
        if A.ndim != 2:
            raise InputError(f"{what}: {p} holds a {A.ndim}-dimensional array of shape {A.shape}; expected a square matrix")
    return _real(A, what, p)


def _real(A, what: str, p: Path):
    """A real matrix: complex values refused unless every imaginary part is zero (then said)."""
    values = A.data if sp.issparse(A) else A
    if not np.iscomplexobj(values):
        return A
    if np.any(values.imag):
        raise InputError(f"{what}: {p} holds a complex matrix (largest imaginary part {np.abs(values.imag).max():.4g}); "
                         "K and M must be real: a structural-damping stiffness K(1 + iη) is not read, export the real part")
    log.warning("%s: %s holds complex values whose imaginary parts are all zero: read as real", what, p)
    return A.real


def _read_dofs_file(p: Path, src: str) -> list[str]:
    """The dof labels of a dofs file: one per line, blank lines and ``#`` comments skipped; UTF-8,
    with or without a byte-order mark (as editors on Windows write it)."""
    if p.is_dir():
        raise InputError(f"{src}: dofs file {p} is a folder; give the file of dof labels (one per line)")
    if not p.exists():
        raise InputError(f"{src}: dofs file {p} not found")
    note_input(p, f"the dofs file of {src}")
    try:
        text = p.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{src}: dofs file {p} is not UTF-8 text (one dof label per line)") from None
    except OSError as exc:
        raise InputError(f"{src}: dofs file {p} cannot be read ({exc.strerror or exc})") from None
    return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]


def _matrix_model(data: Mapping, path: Path) -> Model:
    base = path.parent
    mt = data["matrices"]
    src = f"{path}: [matrices]"
    if not isinstance(mt, Mapping):
        raise InputError(f"{src} must be a table")
    unknown = sorted(set(mt) - {"dofs", "K0", "M0"})
    if unknown:
        raise InputError(f"{src}: unknown key(s) {', '.join(unknown)} (allowed: dofs, K0, M0)")
    for k in ("dofs", "K0", "M0"):
        if k not in mt:
            raise InputError(f"{src}: missing '{k}'")
    other = sorted(set(data) - {"model", "matrices", "parameters", "provenance", "term"})
    if other:
        raise InputError(f"{path}: a [matrices] model cannot also have {', '.join(other)}")
    dofs, dofs_from = _dofs(mt["dofs"], base, src)
    files = {"K0": mt["K0"], "M0": mt["M0"]}
    K0 = _sized(load_matrix(mt["K0"], base, f"{src} K0"), len(dofs), f"{src} K0 ({mt['K0']})", dofs_from)
    M0 = _sized(load_matrix(mt["M0"], base, f"{src} M0"), len(dofs), f"{src} M0 ({mt['M0']})", dofs_from)
    if not isinstance(data.get("parameters", {}), Mapping):
        raise InputError(f"{path}: [parameters] must be a table of tables ([parameters.k1] value = ...)")
    if not isinstance(data.get("model", {}), Mapping):
        raise InputError(f"{path}: [model] must be a table (name = ...)")
    if not isinstance(data.get("provenance", {}), Mapping):
        raise InputError(f"{path}: [provenance] must be a table (it records where an updated model came from)")
    params: list[Parameter] = []
    dK: list = []
    dM: list = []
    terms = _terms(data.get("term", []), path, base, len(dofs), dofs_from)
    in_terms = {x for t in terms for x in t.parameters}
    for name, spec in data.get("parameters", {}).items():
        where = f"{path}: [parameters.{name}]"
        if not isinstance(spec, Mapping) or "value" not in spec:
            raise InputError(f"{where} must be a table with at least 'value'")
        unknown = sorted(set(spec) - {"value", "bounds", "fixed", "prior", "K", "M", "card"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: value, bounds, fixed, prior, K, M, card)")
        if "K" not in spec and "M" not in spec and name not in in_terms:
            raise InputError(f"{where}: a matrix-model parameter needs K and/or M (its derivative matrices) or a "
                             "[[term]] that names it in its factors")
        bounds = spec.get("bounds", [-np.inf, np.inf])
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise InputError(f"{where}: bounds must be [lower, upper], got {bounds!r}")
        if not isinstance(spec.get("fixed", False), bool):
            raise InputError(f"{where}: fixed must be true or false, got {spec['fixed']!r}")
        try:
            prior = parse_prior(spec["prior"], f"{where} prior") if "prior" in spec else None
            params.append(Parameter(name, spec["value"], tuple(bounds), spec.get("fixed", False), prior=prior))
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        for key, out in (("K", dK), ("M", dM)):
            out.append(_sized(load_matrix(spec[key], base, f"{where} {key}"), len(dofs), f"{where} {key} ({spec[key]})",
                              dofs_from) if key in spec else None)
            if key == "K" and key in spec:
                files[name] = spec[key]
    name = data.get("model", {}).get("name", path.stem)
    try:
        model = Model(tuple(dofs), K0, M0, tuple(params), tuple(dK), tuple(dM), name=name, terms=terms)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    stiffness = f"{path}: the stiffness of {', '.join(str(f) for f in files.values() if f != files['M0'])}"
    model = eliminate_penalty_links(model, stiffness)
    _definite(model, stiffness)
    return model


#: model-file tables of matrices as an FE code writes them, and the keys that name their files
EXTERNAL = {"abaqus": ("stiffness", "mass", "deck"), "nastran": ("op4", "op2", "dmig", "deck"), "ansys": ("full", "deck")}


def _terms(raw, path: Path, base: Path, n: int, dofs_from: str) -> tuple:
    """The ``[[term]]`` tables of a matrices model: ``factors = [["E", 1], ["t", 3]]`` (a factor is
    ``[name, power]``, ``[name, {exp = a}]`` or ``[name, {poly = [c0, c1, ...]}]``) and ``K`` and/or
    ``M`` files, the matrices the product multiplies (:mod:`femupdate.coefficients`)."""
    from ..coefficients import Term, factor_from_table

    if isinstance(raw, Mapping) or not isinstance(raw, list):
        raise InputError(f"{path}: term must be an array of tables ([[term]] factors = [[\"t\", 3]] K = \"file\")")
    out = []
    for i, spec in enumerate(raw, start=1):
        where = f"{path}: [[term]] #{i}"
        if not isinstance(spec, Mapping):
            raise InputError(f"{where} must be a table")
        unknown = sorted(set(spec) - {"factors", "K", "M"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: factors, K, M)")
        if "factors" not in spec or ("K" not in spec and "M" not in spec):
            raise InputError(f"{where}: a term needs factors = [[\"name\", power], ...] and K and/or M")
        fs = spec["factors"]
        if not isinstance(fs, list) or not fs:
            raise InputError(f"{where}: factors must be a non-empty list of pairs [parameter, power], got {fs!r}")
        factors = [factor_from_table(f, f"{where} factors") for f in fs]
        mats = {k: _sized(load_matrix(spec[k], base, f"{where} {k}"), n, f"{where} {k} ({spec[k]})", dofs_from)
                for k in ("K", "M") if k in spec}
        try:
            out.append(Term(tuple(factors), **mats))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    return tuple(out)


def _external_model(data: Mapping, path: Path, table: str) -> Model:
    """A model from an FE code's own files (:func:`femupdate.io.abaqus.abaqus_model`,
    :func:`femupdate.io.nastran.nastran_model`, :func:`femupdate.io.ansys.ansys_model`), through the same door as a ``[matrices]`` model
    (penalty ties, a definite stiffness)."""
    other = sorted(set(data) - {"model", table, "parameters", "provenance"})
    if other:
        raise InputError(f"{path}: an [{table}] model cannot also have {', '.join(other)}")
    for key in (table, "parameters", "model"):
        if not isinstance(data.get(key, {}), Mapping):
            raise InputError(f"{path}: [{key}] must be a table")
    for key in EXTERNAL[table]:
        if isinstance(data[table].get(key), str):
            note_input(path.parent / data[table][key], f"the {table} file of {path}")
    if table == "abaqus":
        from .abaqus import abaqus_model as build
        stiffness = f"{path}: the stiffness of {data['abaqus'].get('stiffness')}"
    elif table == "ansys":
        from .ansys import ansys_model as build
        stiffness = f"{path}: the stiffness of {data['ansys'].get('full')}"
    else:
        from .nastran import nastran_model as build
        t = data["nastran"]
        stiffness = f"{path}: the stiffness {t.get('K')} of {t.get('op4', t.get('dmig'))}"
    model = build(data[table], data.get("parameters", {}), path, data.get("model", {}).get("name", path.stem))
    model = eliminate_penalty_links(model, stiffness)
    _definite(model, stiffness)
    return model


def _dofs(dofs, base: Path, src: str) -> tuple[tuple[str, ...], str]:
    """The dof map of a [matrices] table (canonical, each dof once) and how messages name it."""
    if isinstance(dofs, str):
        where = f"dofs file {dofs}"
        dofs = _read_dofs_file(base / dofs, src)
    elif not isinstance(dofs, list) or not all(isinstance(d, str) for d in dofs):
        raise InputError(f"{src}: dofs must be a file name or a list of dof labels such as [\"1:x\", \"1:y\"], "
                         f"got {dofs!r}")
    else:
        where = "the dofs list"
    return canonical_all(dofs, f"{src} {where}"), where


def _sized(A, n: int, what: str, dofs_from: str):
    """The matrix, if it is n × n; else refused naming its file, with a hint at index bases."""
    if A.shape == (n, n):
        return A
    hint = ""
    if A.ndim == 2 and A.shape == (n + 1, n + 1):
        S = sp.csr_array(A)
        for k, side in ((0, "first"), (n, "last")):
            if S[[k], :].nnz == 0 and S[:, [k]].nnz == 0:
                hint = (f"; its {side} row and column are empty: the matrix looks written with indices counted from "
                        f"{'0' if k == 0 else '1'} where the dof map counts from {'1' if k == 0 else '0'}")
                break
    raise InputError(f"{what}: a matrix of shape {A.shape}, but the model has {n} dofs ({dofs_from}){hint}")


def _definite(model: Model, stiffness: str) -> None:
    """Refuse, naming the files, a stiffness that is not positive semi-definite at the nominal values."""
    from ..modal import solve_modes

    try:
        solve_modes(model.K(), model.M(), n_modes=1, dofs=model.dofs)
    except InputError as exc:
        if "not positive semi-definite" not in str(exc):
            return  # (massless dofs without stiffness, ...): said where the modes are computed, as before
        low = str(exc).split("negative eigenvalue", 1)[1].split("(")[0].strip()
        raise InputError(f"{stiffness} at the nominal parameter values is not positive semi-definite (negative "
                         f"eigenvalue {low}): check the files' signs and symmetry headers, and the parameters' "
                         "values") from None
