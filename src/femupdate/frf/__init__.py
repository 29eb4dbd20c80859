"""Frequency response functions (the reference paper's "Frequency Response Functions" section,
eqs. 23-34): simulation, line selection, Brandon's sensitivity and the residual surfaces.
Updating from FRFs — alone or together with modes and static deflections — is part of the updating
core: :func:`femupdate.update` (or :func:`femupdate.updating.frf_update` for FRFs alone),
:func:`femupdate.updating.frf_multistart` and :func:`femupdate.updating.global_search`.

==========================================  ===================================================
:func:`receptance`, :func:`frf`,            receptance / mobility / accelerance of the model
:func:`simulate`, :func:`add_noise`          (eq. 23; Rayleigh and structural damping), noise
:func:`resonances`                          distance of each line to the nearest resonance
:func:`condition_study`                     cond(X) of eq. 28 against lowest line and spacing
                                            (Figure 4)
:func:`select_frequencies`                  best-conditioned lines away from resonances
                                            (He 1993; Ren & Beards 1993)
:func:`receptance_sensitivity` (=           Brandon's eq. 32, one factorisation per line for
:func:`brandon`), :func:`receptance_fd`     every parameter; central differences (test oracle)
:func:`modal_surface`, :func:`frf_surface`  residual surfaces of eqs. 33 and 34 (Figures 5-7)
==========================================  ===================================================
"""

from .damping import Damping
from .resonance import Resonances, resonances
from .selection import ConditionStudy, Selection, condition_study, select_frequencies
from .sensitivity import ReceptanceSensitivity, brandon, first_order_check, receptance_fd, receptance_sensitivity
from .simulate import SimulatedFRF, add_noise, convert, frf, from_channels, receptance, simulate
from .surfaces import Surface, distinct_minima, frf_surface, local_minima, modal_surface

__all__ = [
    "Damping", "Resonances", "resonances",
    "receptance", "frf", "simulate", "SimulatedFRF", "convert", "add_noise", "from_channels",
    "receptance_sensitivity", "brandon", "receptance_fd", "first_order_check", "ReceptanceSensitivity",
    "condition_study", "ConditionStudy", "select_frequencies", "Selection",
    "frf_surface", "modal_surface", "local_minima", "distinct_minima", "Surface",
]

#: names that moved to the updating core (femupdate.updating), and where they are now
MOVED = {name: "femupdate.updating" for name in
         ("frf_update", "frf_multistart", "FRFUpdateResult", "global_search", "GlobalSearchResult")}


def __getattr__(name: str):
    if name in MOVED:
        raise AttributeError(f"femupdate.frf.{name} moved to {MOVED[name]}.{name} (FRF updating is part of the "
                             "updating core; femupdate.update takes FRF data too)")
    raise AttributeError(f"module 'femupdate.frf' has no attribute {name!r}")
