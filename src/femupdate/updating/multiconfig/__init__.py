r"""Perturbed-boundary (multi-configuration) updating and pre-test ranking of modifications.

The structure is tested in several configurations (Barney et al. 1992, Li & Brown 1992,
Lammens et al. 1993; the reference paper's "Improving experimental data"): each differs from the
others by *known* changes — added lumped masses, added springs, changed supports, known
parameters set to other values — while the unknown parameters stay the same.  Configuration c's
model is

.. math:: K_c(p) = K(p) + \Delta K_c, \qquad M_c(p) = M(p) + \Delta M_c

restricted to the dofs left free by its supports.  All configurations are updated jointly:

* **directly** when every configuration's data are complete (eqs. 4-10 of the paper stacked over
  the configurations: each configuration contributes its own rows
  :math:`\sum_j p_j (K_j - \lambda M_j)\phi = (\lambda M_{f,c} - K_{f,c})\phi` to one system
  :math:`A p = b`, solved by the pseudo-inverse, eq. 10);
* **iteratively** otherwise: the residuals and Jacobians of the configurations
  (:class:`femupdate.updating.Problem`, relative eigenvalues and scaled shapes, eq. 19) are
  stacked and minimised by SciPy's least squares (eq. 20).

The conditioning the added configurations buy is reported (each configuration alone, and the
configurations added one by one).  Before testing, :func:`rank_modifications` ranks candidate
modifications by the new, independent information they would bring.

=================================  ==========================================================
:mod:`.configurations`             :class:`Modification`, :class:`Configuration`,
                                   :func:`configure`, :func:`simulate`
:mod:`.direct`                     :func:`direct_configurations` (complete data)
:mod:`.iterative`                  :func:`update_configurations` (incomplete data),
                                   :func:`solve_configurations` (either, by the data)
:mod:`.results`                    :class:`MultiConfigResult`, :func:`conditioning`
:mod:`.ranking`                    :func:`rank_modifications`, :class:`Ranking`
:mod:`.files`                      modification and candidate files (TOML or JSON)
=================================  ==========================================================
"""

from .configurations import Configuration, ConfiguredModel, Modification, configure, simulate
from .direct import direct_configurations
from .iterative import solve_configurations, update_configurations
from .ranking import CRITERIA, Ranking, rank_modifications
from .results import MultiConfigResult, conditioning

__all__ = [
    "Modification", "Configuration", "ConfiguredModel", "configure", "simulate", "direct_configurations",
    "update_configurations", "solve_configurations", "rank_modifications", "Ranking", "CRITERIA",
    "MultiConfigResult", "conditioning",
]
