"""The baseline against the undamaged structure's test data (frequency errors and MAC within
limits) before damage is localised from it."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import InputError
from ..correlation import correlate
from ..modal import model_modes
from ..model import Model
from ..testdata import TestData


@dataclass(frozen=True, eq=False)
class BaselineCheck:
    """Correlation of the baseline model with the undamaged structure's test data.

    Returned by :func:`check_baseline`; each parameter is stored as the attribute of the same name.

    Parameters
    ----------
    ok : bool
        True when no mode is beyond the limits (``reasons`` empty).
    frequency_error : ndarray, shape ``(n_test_modes,)``
        Relative frequency error ``(f_model - f_test) / f_test`` of each undamaged test mode with its
        paired model mode; NaN for a mode without a shape (at two or more dofs) or left unpaired.
    mac : ndarray, shape ``(n_test_modes,)``
        MAC of each test mode with its paired model mode; NaN where ``frequency_error`` is.
    pairs : list of (int, int, float)
        (test mode, model mode, MAC) pairs, 0-based, by the one rule (:func:`paired_modes`).
    reasons : list of str
        One message per mode and limit exceeded.
    max_frequency_error : float
        The relative frequency-error limit that was applied.
    min_mac : float
        The MAC limit that was applied.
    """

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


def paired_modes(model, data: TestData, values, min_pair: float = 0.5):
    """Model modes (enough of them) and the test modes paired with them by the one rule
    (:func:`femupdate.correlation.correlate`: the rule ``update`` pairs by, ``auto``, with its
    frequency check and its groups of repeated or close modes).

    Parameters
    ----------
    model : Model
        The parametrised model.
    data : TestData
        Test modes; those without a shape are paired by frequency order.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``
        Parameter values as :func:`femupdate.modal.model_modes` reads them (None: nominal).
    min_pair : float, default 0.5
        The MAC that confirms a pair (a pair below it is listed in ``unconfirmed``).

    Returns
    -------
    modes : Modes
        The model modes: :func:`~femupdate.modal.model_modes`'s default number up to 1500 dofs,
        else ``min(n_dofs - 2, 2 n_test + 12)``.
    correlation : Correlation
        The pairing: ``pairs`` (test mode, model mode, MAC), ``mac``, ``frequency_error``,
        ``unconfirmed``, and the :class:`~femupdate.correlation.Pairing` (``large_change``).

    Raises
    ------
    InputError, NumericalError
        As :func:`femupdate.modal.model_modes` (e.g. an unknown test dof).
    """
    n = len(data.modes)
    modes = model_modes(model, values, n_modes=None if model.n_dofs <= 1500 else min(model.n_dofs - 2, 2 * n + 12))
    return modes, correlate(data, modes, min_mac=min_pair, pairing="auto")


def check_baseline(model: Model, undamaged: TestData, values=None, *, max_frequency_error: float = 0.02,
                   min_mac: float = 0.9, raise_on_failure: bool = True) -> BaselineCheck:
    """Check that the baseline model reproduces the undamaged structure's test data.

    Every undamaged test mode with a shape must pair (by the rule ``update`` pairs by,
    :func:`paired_modes`) with a model mode with
    ``MAC >= min_mac`` and ``|f_model - f_test| / f_test <= max_frequency_error``.

    Parameters
    ----------
    model : Model
        The baseline model.
    undamaged : TestData
        Modes of the undamaged structure; those with a shape at two or more dofs are checked.
    values : None, mapping of str to float, or array_like of shape ``(n_parameters,)``, optional
        Parameter values of the baseline (default: nominal).
    max_frequency_error : float, default 0.02
        Largest relative frequency error (0.02: 2 %).
    min_mac : float, default 0.9
        Smallest MAC of a test mode with its paired model mode.
    raise_on_failure : bool, default True
        Raise when a mode is beyond the limits; otherwise return the check with ``ok`` False.

    Returns
    -------
    BaselineCheck

    Raises
    ------
    InputError
        When the undamaged data hold no mode shape (at two or more dofs); and (with
        ``raise_on_failure``) naming every mode beyond the limits: localising damage from a
        baseline that does not match the undamaged structure would report its modelling errors
        as damage.
    """
    if not undamaged.modes or not any(m.has_shape and len(m.dofs) >= 2 for m in undamaged.modes):
        raise InputError("the undamaged data hold no mode shapes: the baseline cannot be checked")
    modes, corr = paired_modes(model, undamaged, values)
    pairs = [p for p in corr.pairs if np.isfinite(p[2])]
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
