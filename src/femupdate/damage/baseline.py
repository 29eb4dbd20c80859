"""The baseline against the undamaged structure's test data (frequency errors and MAC within
limits) before damage is localised from it."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ..correlation import mac, pair_modes
from ..modal import model_modes
from ..model import Model
from ..testdata import TestData


@dataclass(frozen=True, eq=False)
class BaselineCheck:
    """Correlation of the baseline model with the undamaged structure's test data."""

    ok: bool
    frequency_error: np.ndarray
    mac: np.ndarray
    pairs: list
    reasons: list[str]
    max_frequency_error: float
    min_mac: float

    def as_dict(self) -> dict:
        return {"ok": self.ok, "frequency_error": self.frequency_error, "mac": self.mac,
                "pairs": [list(p) for p in self.pairs], "reasons": self.reasons,
                "limits": {"max_frequency_error": self.max_frequency_error, "min_mac": self.min_mac}}


def paired_modes(model, data: TestData, values, min_pair: float):
    """Model modes (enough of them) and the MAC pairing of the test modes with shapes."""
    n = len(data.modes)
    modes = model_modes(model, values, n_modes=None if model.n_dofs <= 1500 else min(model.n_dofs - 2, 2 * n + 12))
    rows = []
    for m in data.modes:
        if m.has_shape and len(m.dofs) >= 2:
            rows.append(mac(np.real(m.shape), modes.at(m.dofs))[0])
        else:
            rows.append(np.zeros(modes.n_modes))
    M = np.array(rows)
    M[:, modes.eigenvalues <= 0] = 0.0  # never pair with rigid-body modes
    return modes, M, pair_modes(M, min_pair)


def check_baseline(model: Model, undamaged: TestData, values=None, *, max_frequency_error: float = 0.02,
                   min_mac: float = 0.9, raise_on_failure: bool = True) -> BaselineCheck:
    """Check that the baseline model reproduces the undamaged structure's test data.

    Every undamaged test mode with a shape must pair (MAC) with a model mode with
    ``MAC >= min_mac`` and ``|f_model - f_test| / f_test <= max_frequency_error``.

    Raises
    ------
    InputError
        (with ``raise_on_failure``) naming every mode beyond the limits: localising damage from a
        baseline that does not match the undamaged structure would report its modelling errors
        as damage.
    """
    if not undamaged.modes or not any(m.has_shape and len(m.dofs) >= 2 for m in undamaged.modes):
        raise InputError("the undamaged data hold no mode shapes: the baseline cannot be checked")
    modes, M, pairs = paired_modes(model, undamaged, values, 0.0)
    by_test = {k: (j, m) for k, j, m in pairs}
    errs, macs, reasons = [], [], []
    for k, tm in enumerate(undamaged.modes):
        if k not in by_test or not (tm.has_shape and len(tm.dofs) >= 2):
            errs.append(math.nan)
            macs.append(math.nan)
            continue
        j, m = by_test[k]
        e = (modes.frequencies_hz[j] - tm.frequency_hz) / tm.frequency_hz
        errs.append(e)
        macs.append(m)
        if abs(e) > max_frequency_error:
            reasons.append(f"mode {k + 1}: frequency error {e * 100:+.2f} % (limit {max_frequency_error * 100:g} %)")
        if m < min_mac:
            reasons.append(f"mode {k + 1}: MAC {m:.3f} with its best model mode (limit {min_mac:g})")
    chk = BaselineCheck(not reasons, np.array(errs), np.array(macs), pairs, reasons, max_frequency_error, min_mac)
    if reasons and raise_on_failure:
        raise InputError("the baseline model does not match the undamaged data, so its differences would be "
                         "reported as damage; validate (update) the baseline first: " + "; ".join(reasons))
    return chk
