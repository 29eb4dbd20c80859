"""The model file's ``[blackbox]`` table (docs/file-formats.md, docs/blackbox.md)::

    [blackbox]
    command = "{python} {base}/opensees_frame.py E_cols={E_cols} h={h}"
    K = "K.mtx"              # the files the command writes in its folder
    M = "M.mtx"
    dofs = "dofs.txt"
    inputs = ["opensees_frame.py"]   # part of the cache key
    cache = "frame.runs"     # default: <model file name>.runs beside the model file
    jobs = 2

    [parameters.h]
    value = 0.3
    bounds = [0.1, 0.6]

Paths are relative to the model file; the keys and their defaults are in docs/blackbox.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from .._errors import InputError
from .probe import BlackBox, ProbeOptions
from .runs import FORMATS, Cache, Command

#: the keys of the table: the command's, the run's and the probing options'
COMMAND_KEYS = ("command", "K", "M", "dofs", "format", "file", "set", "inputs", "timeout")
RUN_KEYS = ("cache", "jobs", "scheduler")
OPTION_KEYS = tuple(ProbeOptions.__dataclass_fields__)


def black_box_from_table(data: Mapping, path: Path) -> BlackBox:
    """The :class:`BlackBox` of a model file's ``[blackbox]`` and ``[parameters]`` tables."""
    from ..model import Parameter
    from ..priors import parse_prior

    src = f"{path}: [blackbox]"
    table = data["blackbox"]
    if not isinstance(table, Mapping):
        raise InputError(f"{src} must be a table")
    other = sorted(set(data) - {"model", "blackbox", "parameters", "provenance"})
    if other:
        raise InputError(f"{path}: a [blackbox] model cannot also have {', '.join(other)}")
    unknown = sorted(set(table) - {*COMMAND_KEYS, *RUN_KEYS, *OPTION_KEYS})
    if unknown:
        raise InputError(f"{src}: unknown key(s) {', '.join(unknown)} (allowed: "
                         f"{', '.join((*COMMAND_KEYS, *RUN_KEYS, *OPTION_KEYS))})")
    if not isinstance(table.get("command"), str):
        raise InputError(f"{src}: 'command' must be the command template (a string with {{name}} placeholders)")
    if table.get("format", "matrices") not in FORMATS:
        raise InputError(f"{src}: format must be one of {', '.join(FORMATS)}, got {table['format']!r}")
    for key in ("K", "M", "dofs", "file", "set"):
        if key in table and not isinstance(table[key], str):
            raise InputError(f"{src}: '{key}' must be a file or matrix name (a string), got {table[key]!r}")
    inputs = table.get("inputs", [])
    if not isinstance(inputs, list) or not all(isinstance(x, str) for x in inputs):
        raise InputError(f"{src}: inputs must be a list of file names, got {inputs!r}")
    timeout = table.get("timeout")
    if timeout is not None and (isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or timeout <= 0):
        raise InputError(f"{src}: timeout must be a positive number of seconds, got {timeout!r}")
    fmt = table.get("format", "matrices")
    default_dofs = "dofs.txt" if fmt == "matrices" else None
    kw = {k: table[k] for k in ("K", "M", "file", "set") if k in table}
    try:
        runner = Command(table["command"], dofs=table.get("dofs", default_dofs), format=fmt, base=str(path.parent),
                         inputs=tuple(inputs), timeout=timeout, **kw)
        options = ProbeOptions(**{k: table[k] for k in OPTION_KEYS if k in table})
    except InputError as exc:
        raise InputError(f"{src}: {exc}") from None
    params = []
    raw = data.get("parameters", {})
    if not isinstance(raw, Mapping) or not raw:
        raise InputError(f"{path}: a [blackbox] model needs [parameters.NAME] tables (value, bounds)")
    for name, spec in raw.items():
        where = f"{path}: [parameters.{name}]"
        if not isinstance(spec, Mapping) or "value" not in spec:
            raise InputError(f"{where} must be a table with at least 'value'")
        unknown = sorted(set(spec) - {"value", "bounds", "fixed", "prior"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: value, bounds, fixed, prior)")
        try:
            prior = parse_prior(spec["prior"], f"{where} prior") if "prior" in spec else None
            params.append(Parameter(name, spec["value"], tuple(spec.get("bounds", (float("-inf"), float("inf")))),
                                    spec.get("fixed", False), prior=prior))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    cache = table.get("cache", f"{path.name}.runs")
    jobs = table.get("jobs", 1)
    scheduler = table.get("scheduler")
    if not isinstance(cache, str) or not cache:
        raise InputError(f"{src}: cache must be a folder name, got {cache!r}")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"{src}: jobs must be a positive integer, got {jobs!r}")
    if scheduler is not None and not isinstance(scheduler, str):
        raise InputError(f"{src}: scheduler must be an address such as \"tcp://host:8786\", got {scheduler!r}")
    name = data.get("model", {}).get("name", path.stem) if isinstance(data.get("model", {}), Mapping) else path.stem
    try:
        return BlackBox(runner, tuple(params), name=name, cache=Cache(path.parent / cache), jobs=jobs,
                        scheduler=scheduler, options=options)
    except InputError as exc:
        raise InputError(f"{src}: {exc}") from None


def load_black_box(path) -> BlackBox:
    """The :class:`BlackBox` of a model file with a ``[blackbox]`` table.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.toml`` model file.

    Returns
    -------
    BlackBox
    """
    from ..io.model_file import read_toml

    path = Path(path)
    data = read_toml(path)
    if "blackbox" not in data:
        raise InputError(f"{path}: no [blackbox] table")
    return black_box_from_table(data, path)


__all__ = ["black_box_from_table", "load_black_box"]
