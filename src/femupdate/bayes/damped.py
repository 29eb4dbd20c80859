"""The posterior of a damped model (:class:`~femupdate.damping.DampedModel`, a ``[damping]``
table): its predictions of the paired complex modes (:func:`predict_damped`); the likelihood is
:class:`~femupdate.bayes.likelihood.Posterior`'s on the damped residuals of
:func:`~femupdate.updating.damped_run.damped_problem`."""

from __future__ import annotations

import numpy as np

from .._errors import FemupdateError


def predict_damped(post, X) -> dict | None:
    """:meth:`Posterior.predict <femupdate.bayes.likelihood.Posterior.predict>` of a damped model:
    the paired complex modes' natural frequencies ``abs(λ)/2π``, MACs (of complex shapes; NaN without a
    shape) and damping ratios ``−Re λ/abs(λ)`` (``"damping_ratio"``, (S, T)); None without measured modes."""
    from ..updating.damped import DampedModesProblem

    modal = next((b.problem for b in post.problems[0].blocks if isinstance(b.problem, DampedModesProblem)), None)
    if modal is None:
        return None
    X = np.atleast_2d(np.asarray(X, float))
    S, T = X.shape[0], modal.lam_e.size
    freq, macs, zeta = (np.full((S, T), np.nan) for _ in range(3))
    for i, x in enumerate(X):
        try:
            _, modes, pairs = modal.evaluate(x)
        except FemupdateError:
            continue
        for k, j, mac in pairs:
            freq[i, k] = modes.natural_frequencies_hz[j]
            macs[i, k] = mac
            zeta[i, k] = modes.damping_ratios[j]
    return {"frequencies_hz": freq, "mac": macs, "eigenvalue_std": 1.0 / modal.w_f, "damping_ratio": zeta}


__all__ = ["predict_damped"]
