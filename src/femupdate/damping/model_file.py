"""The ``[damping]`` table of a model file (docs/file-formats.md, "Damping")::

    [damping]
    alpha = 0.8                  # Rayleigh C = alpha M + beta K: numbers >= 0 or damping parameter names
    beta = "b"
    modal = [0.02, 0.015]        # modal damping ratios of the first modes (fractions, not percent),
                                 # numbers or damping parameters; or a table {"1" = 0.02, "2-4" = "z"}
    C0 = "C0.mtx"                # a constant C matrix (file relative to the TOML), optional

    [damping.parameters.b]       # damping parameters: value, bounds (lower >= 0), fixed, C (dC/db)
    value = 1.0e-4

    [damping.parameters.c1]
    value = 12.0
    bounds = [0.0, 1.0e4]

    [[damping.damper]]           # a viscous damper between two dofs (one dof: to the ground)
    dofs = ["3:x", "5:x"]
    c = "c1"                     # N s/m: a number or a damping parameter

    [[damping.loss]]             # structural damping: loss factor eta on the stiffness of K or of
    eta = 0.02                   # one stiffness parameter (an element set or material)
    on = "E1"

The rest of the file is any model :func:`femupdate.io.load_model` reads.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path

from .._checks import path_arg
from .._errors import InputError
from ..model import Parameter
from ..priors import parse_prior
from .model import DampedModel, Damper, LossFactor

log = logging.getLogger(__name__)

_TOP = {"alpha", "beta", "modal", "C0", "parameters", "damper", "loss"}


def load_damped_model(path) -> DampedModel:
    """Read a model file with a ``[damping]`` table into a :class:`DampedModel`.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.toml`` model file; without a ``[damping]`` table the model is undamped.

    Returns
    -------
    DampedModel

    Raises
    ------
    InputError
        Anything :func:`femupdate.io.load_model` refuses; in ``[damping]``: an unknown key, a
        negative coefficient, a damping ratio above 1 (a percentage), a name that is no damping
        parameter, a damper dof that is no model dof (the message names the table).
    """
    from ..io.model_file import build_model, load_matrix, read_toml

    path = path_arg(path, "path", "load_damped_model")
    if path.suffix.lower() != ".toml":
        raise InputError(f"{path}: model files are TOML (.toml)")
    data = read_toml(path)
    raw = data.pop("damping", {})
    model = build_model(data, path)
    where = f"{path}: [damping]"
    if not isinstance(raw, Mapping):
        raise InputError(f"{where} must be a table")
    unknown = sorted(set(raw) - _TOP)
    if unknown:
        raise InputError(f"{where}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(_TOP))})")
    base = Path(path).parent
    params, dC = _parameters(raw.get("parameters", {}), where, base, load_matrix)
    try:
        dampers = tuple(Damper(_list(s, "dofs", f"{where} damper #{i}"), _needed(s, "c", f"{where} damper #{i}"))
                        for i, s in _tables(raw.get("damper", []), f"{where} damper", {"dofs", "c"}))
        losses = tuple(LossFactor(_needed(s, "eta", f"{where} loss #{i}"), s.get("on", "K"))
                       for i, s in _tables(raw.get("loss", []), f"{where} loss", {"eta", "on"}))
        modal = modal_ratios(raw.get("modal", []), model.n_dofs, [p.name for p in params])
        C0 = load_matrix(raw["C0"], base, f"{where} C0") if "C0" in raw else None
        dm = DampedModel(model, params, raw.get("alpha", 0.0), raw.get("beta", 0.0), dampers, losses, C0,
                         dC if any(A is not None for A in dC) else (), tuple(modal))
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith(str(path)) else f"{where}: {msg}") from None
    _large_loss_factors(dm, where)
    return dm


def _large_loss_factors(dm: DampedModel, where: str) -> None:
    """Say (a warning: some viscoelastic layers reach η ≈ 1) a loss factor of 1 or more, which looks
    like a percentage: η is a fraction, about 2ζ at resonance."""
    values = {p.name: p.value for p in dm.parameters}
    for i, lf in enumerate(dm.losses):
        eta = float(values[lf.eta] if isinstance(lf.eta, str) else lf.eta)
        if eta >= 1:
            name = f" ({lf.eta!r})" if isinstance(lf.eta, str) else ""
            log.warning("%s: loss #%d eta%s = %g is 1 or more: loss factors are fractions (about twice the damping "
                        "ratio at resonance; 2 %% is 0.02); if it was meant as a percentage, write %g", where, i + 1,
                        name, eta, eta / 100)


def _needed(table: Mapping, key: str, where: str):
    """``table[key]``, refused by name when missing (a damper without ``c``, a loss without ``eta``
    would otherwise damp nothing without a word)."""
    if key not in table:
        raise InputError(f"{where}: needs {key} (a number >= 0 or the name of a damping parameter)")
    return table[key]


def modal_ratios(raw, n_dofs: int, names) -> list:
    """The ``modal`` entry as one ratio per mode: a list (a number or a damping parameter's name
    per mode, from mode 1), or a table {"mode" or "first-last": ratio} covering modes 1 to N."""
    if isinstance(raw, list):
        return raw
    if not isinstance(raw, Mapping):
        raise InputError(f"modal must be a list of damping ratios (one per mode from mode 1) or a table "
                         f"{{\"1\" = 0.02, \"2-4\" = \"z\"}}, got {raw!r}")
    given: dict[int, tuple[str, object]] = {}
    for key, ratio in raw.items():
        first, dash, last = str(key).partition("-")
        if not (first.strip().isdigit() and (not dash or last.strip().isdigit())):
            raise InputError(f"modal: {key!r} is not a mode or a range of modes (write \"3\" or \"2-4\"; modes "
                             "counted from 1)")
        a, b = int(first), int(last or first)
        if a < 1 or b < a or b > n_dofs:
            raise InputError(f"modal: modes {key!r} are not modes of the model (modes 1 to {n_dofs}, a range "
                             "first-last with first <= last)")
        if isinstance(ratio, str) and ratio not in names:
            raise InputError(f"modal: modes {key} = {ratio!r} is not a damping parameter (declared: "
                             f"{', '.join(names) or 'none'})")
        for k in range(a, b + 1):
            if k in given:
                raise InputError(f"modal: mode {k} is given twice ({given[k][0]!r} and {key!r})")
            given[k] = (str(key), ratio)
    missing = [k for k in range(1, max(given, default=0) + 1) if k not in given]
    if missing:
        raise InputError(f"modal: mode(s) {', '.join(map(str, missing))} have no ratio: modal damping acts on the "
                         f"first {max(given)} modes, each with a ratio (0 for none)")
    return [given[k][1] for k in sorted(given)]


def _tables(raw, where: str, keys: set):
    if isinstance(raw, Mapping) or not isinstance(raw, list):
        raise InputError(f"{where} must be an array of tables ([[...]])")
    for i, spec in enumerate(raw, start=1):
        if not isinstance(spec, Mapping):
            raise InputError(f"{where} #{i} must be a table")
        unknown = sorted(set(spec) - keys)
        if unknown:
            raise InputError(f"{where} #{i}: unknown key(s) {', '.join(unknown)} (allowed: {', '.join(sorted(keys))})")
        yield i, spec


def _list(spec, key: str, where: str):
    v = spec.get(key)
    if isinstance(v, str):
        return (v,)
    if not isinstance(v, list):
        raise InputError(f"{where}: {key} must be one or two dof labels, got {v!r}")
    return tuple(v)


def _parameters(raw, where: str, base: Path, load_matrix) -> tuple[tuple, tuple]:
    if not isinstance(raw, Mapping):
        raise InputError(f"{where}: parameters must be a table of tables ([damping.parameters.c1] value = ...)")
    params, dC = [], []
    for name, spec in raw.items():
        w = f"{where} parameters.{name}"
        if not isinstance(spec, Mapping) or "value" not in spec:
            raise InputError(f"{w} must be a table with at least 'value'")
        unknown = sorted(set(spec) - {"value", "bounds", "fixed", "prior", "C"})
        if unknown:
            raise InputError(f"{w}: unknown key(s) {', '.join(unknown)} (allowed: value, bounds, fixed, prior, C)")
        bounds = spec.get("bounds", [float("-inf"), float("inf")])  # DampedModel: lower bound 0
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise InputError(f"{w}: bounds must be [lower, upper], got {bounds!r}")
        try:
            prior = parse_prior(spec["prior"], f"{w} prior") if "prior" in spec else None
            params.append(Parameter(name, spec["value"], tuple(bounds), spec.get("fixed", False), prior=prior))
        except InputError as exc:  # the prior's own messages name w already
            raise InputError(str(exc) if str(exc).startswith(w) else f"{w}: {exc}") from None
        dC.append(load_matrix(spec["C"], base, f"{w} C") if "C" in spec else None)
    return tuple(params), tuple(dC)


__all__ = ["load_damped_model"]
