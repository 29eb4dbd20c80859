"""FRF-based updating (the reference paper's "Frequency Response Functions" section, eqs. 23-34).

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
:func:`frf_update`, :func:`frf_multistart`  iterative updating from incomplete FRFs (eqs. 30-31)
:func:`modal_surface`, :func:`frf_surface`  residual surfaces of eqs. 33 and 34 (Figures 5-7)
:func:`global_search`                       differential evolution / basin hopping / dual
                                            annealing, local or on Dask
==========================================  ===================================================
"""

from ._lines import Damping, Resonances, resonances
from .search import GlobalSearchResult, global_search
from .selection import ConditionStudy, Selection, condition_study, select_frequencies
from .sensitivity import ReceptanceSensitivity, brandon, first_order_check, receptance_fd, receptance_sensitivity
from .simulate import add_noise, convert, frf, from_channels, receptance, simulate
from .surfaces import Surface, distinct_minima, frf_surface, local_minima, modal_surface
from .updating import FRFUpdateResult, frf_multistart, frf_update

__all__ = [
    "Damping", "Resonances", "resonances",
    "receptance", "frf", "simulate", "convert", "add_noise", "from_channels",
    "receptance_sensitivity", "brandon", "receptance_fd", "first_order_check", "ReceptanceSensitivity",
    "condition_study", "ConditionStudy", "select_frequencies", "Selection",
    "frf_update", "frf_multistart", "FRFUpdateResult",
    "frf_surface", "modal_surface", "local_minima", "distinct_minima", "Surface",
    "global_search", "GlobalSearchResult",
]
