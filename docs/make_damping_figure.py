"""Draw docs/img/damping-frf-overlay.png, the FRF overlay of docs/damping.md.

The damped truss of the example files (``femupdate demo --write-files``: ``truss_damped.toml``
and its noise-free FRFs ``truss_damped_frf.json``) is updated by ``frf-update`` from the start
of the page (E, b, c1, c2 = 6e10, 5e-5, 100, 600); the measured receptances are drawn with the
model's before and after, by femupdate's own plotting (:func:`femupdate.plot.frf.frf_axes`).

Usage (from the repository root)::

    PYTHONPATH=src python docs/make_damping_figure.py [OUT.png]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from femupdate import load_test_data  # noqa: E402
from femupdate.damping import load_damped_model  # noqa: E402
from femupdate.damping.frf import damped_response  # noqa: E402
from femupdate.examples import TRUSS_DAMPED_START, write_example_files  # noqa: E402
from femupdate.plot.frf import frf_axes  # noqa: E402
from femupdate.updating import frf_update  # noqa: E402

OUT = Path(__file__).resolve().parent / "img" / "damping-frf-overlay.png"


def main(out: Path = OUT) -> Path:
    ex = Path(tempfile.mkdtemp())
    write_example_files(ex)
    truth = load_damped_model(ex / "truss_damped.toml")
    start = truth.with_values(TRUSS_DAMPED_START)
    data = load_test_data(ex / "truss_damped_frf.json", truth.model)
    res = frf_update(start, data)
    print({n: round(v, 6) for n, v in res.parameters.items()}, "FRAC", res.frac)
    frf = data.frf
    force = dict(frf.force)
    before, _ = damped_response(start, frf.omega, force, frf.dofs)
    after, _ = damped_response(truth, frf.omega, force, frf.dofs, res.parameters)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [2, 1]})
    frf_axes(frf.omega, frf.dofs, frf.response, after, axes[0], start=before, hz=True)
    axes[0].set_title("damped truss: FRFs (force at 4:y) before and after frf-update")
    # the first peak, where the damper c1 and the Rayleigh damping act most
    near = (frf.omega / (2 * np.pi) > 30) & (frf.omega / (2 * np.pi) < 70)
    frf_axes(frf.omega[near], frf.dofs, frf.response[near], after[near], axes[1], start=before[near], hz=True)
    axes[1].set_title("the first peak")
    axes[1].get_legend().remove()
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


if __name__ == "__main__":
    print(main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT))
