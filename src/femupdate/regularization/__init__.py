r"""Tikhonov regularisation of the linearised updating step, with the factor chosen by GCV or the L-curve.

At each Gauss–Newton step of sensitivity-based updating the linearised problem
:math:`J\,\Delta p \approx -r` (``J`` the (m, L) sensitivity matrix in scaled parameters, ``r``
the m residuals) is often ill-conditioned (condition numbers of 1e5..1e13 occur).  Tikhonov
regularisation solves instead

.. math::

    \min_{\Delta p}\; \|J\,\Delta p + r\|^2 + \alpha^2\,\|\Gamma\,(p + \Delta p - p_\mathrm{ref})\|^2 ,

which pulls the *parameters* toward a reference ``p_ref`` (usually the nominal model), not only
the step toward zero.  With ``offset`` :math:`o = p - p_\mathrm{ref}` and :math:`z = \Delta p + o`
this is the general-form problem

.. math::

    \min_z\; \|J z - b\|^2 + \alpha^2 \|\Gamma z\|^2, \qquad b = J o - r .        \tag{1}

**Standard form.**  :math:`\Gamma` is replaced by a matrix :math:`G` (k, L) of full row rank with
:math:`\|\Gamma z\| = \|G z\|` (``G = Γ`` for the identity or an invertible diagonal; otherwise from
the SVD of :math:`\Gamma`).  For an invertible :math:`\Gamma` (k = L), :math:`y = G z` and
:math:`\bar A = J G^{-1}` turn (1) into :math:`\min_y \|\bar A y - b\|^2 + \alpha^2\|y\|^2`.  A
:math:`\Gamma` with a null space (a semi-norm: a zero weight, a difference operator) is handled
by Eldén's transformation with the A-weighted pseudo-inverse
:math:`G_J^\dagger = (I - W (JW)^\dagger J)\,G^\dagger` (W a basis of the null space of
:math:`\Gamma`), :math:`\bar A = J G_J^\dagger`, :math:`\bar b = b - J x_0`,
:math:`x_0 = W (JW)^\dagger b` and :math:`z = G_J^\dagger y + x_0`.  This is equivalent to the
generalised SVD of :math:`(J, \Gamma)` used in Hansen's *Regularization Tools* (Hansen 1994,
2007); the unregularised components of z (those in the null space of :math:`\Gamma`) are then
fitted exactly.

**Filter factors.**  With the SVD :math:`\bar A = \sum_i s_i u_i v_i^T` (numerical rank q),
:math:`\beta_i = u_i^T \bar b` and the filter factors :math:`f_i = s_i^2 / (s_i^2 + \alpha^2)`,

.. math::

    y_\alpha &= \sum_i f_i \frac{\beta_i}{s_i} v_i, \\
    \rho^2(\alpha) &= \|J\,\Delta p_\alpha + r\|^2 = \sum_i (1 - f_i)^2 \beta_i^2 + \delta_0^2,
        \qquad \delta_0^2 = \|\bar b - U U^T \bar b\|^2, \\
    \eta^2(\alpha) &= \|\Gamma(p + \Delta p_\alpha - p_\mathrm{ref})\|^2 = \sum_i f_i^2 \beta_i^2 / s_i^2 .

**GCV** (Golub, Heath & Wahba 1979) minimises

.. math::

    G(\alpha) = \frac{\|J\,\Delta p_\alpha + r\|^2}{\mathrm{trace}(I - A(\alpha))^2}
             = \frac{\rho^2(\alpha)}{\big(m - (L - k) - \sum_i f_i\big)^2},

:math:`A(\alpha) = J (J^T J + \alpha^2 \Gamma^T\Gamma)^{-1} J^T` the influence matrix.

**L-curve** (Hansen 1992; Hansen & O'Leary 1993): the corner of the curve
:math:`(\ln\rho(\alpha), \ln\eta(\alpha))` is the point of maximum curvature.  With
:math:`\hat\eta = \eta^2`, :math:`\hat\rho = \rho^2` and
:math:`\hat\eta' = d\hat\eta/d\alpha = -4\alpha\sum_i s_i^2\beta_i^2/(s_i^2+\alpha^2)^3`
(so that :math:`\hat\rho' = -\alpha^2\hat\eta'`) the curvature is, in closed form,

.. math::

    \kappa(\alpha) = -\,\frac{2\,\hat\eta\,\hat\rho}{\hat\eta'}\;
      \frac{\alpha^2\hat\eta'\hat\rho + 2\alpha\hat\eta\hat\rho + \alpha^4\hat\eta\hat\eta'}
           {(\alpha^4\hat\eta^2 + \hat\rho^2)^{3/2}},

positive where the curve turns counter-clockwise (down its vertical leg, then right along its
horizontal leg).  Both criteria are evaluated on a grid of α at once (arrays of shape
(n_alpha, q), no loop per α) and the grid optimum is polished by a bounded scalar search between
its neighbours, as Regularization Tools' ``gcv`` and ``l_corner`` do with ``fminbnd``.

Layout: :mod:`.tikhonov` (input checks, the standard form and :func:`tikhonov_step`) and
:mod:`.choice` (:func:`gcv`, :func:`l_curve`, :func:`choose_alpha` and :class:`RegularizationChoice`).

References
----------
P. C. Hansen, "Analysis of discrete ill-posed problems by means of the L-curve", SIAM Review
34 (1992) 561-580.
P. C. Hansen, D. P. O'Leary, "The use of the L-curve in the regularization of discrete
ill-posed problems", SIAM J. Sci. Comput. 14 (1993) 1487-1503.
G. H. Golub, M. Heath, G. Wahba, "Generalized cross-validation as a method for choosing a good
ridge parameter", Technometrics 21 (1979) 215-223.
P. C. Hansen, "Regularization Tools: a Matlab package for analysis and solution of discrete
ill-posed problems", Numer. Algorithms 6 (1994) 1-35; version 4.0, 46 (2007) 189-194.
P. C. Hansen, *Discrete Inverse Problems: Insight and Algorithms*, SIAM, 2010 (ch. 5).
L. Eldén, "A weighted pseudoinverse, generalized singular values, and constrained least squares
problems", BIT 22 (1982) 487-502.
"""

from .choice import RegularizationChoice, choose_alpha, gcv, l_curve
from .tikhonov import N_ALPHA, tikhonov_step

__all__ = ["RegularizationChoice", "tikhonov_step", "gcv", "l_curve", "choose_alpha"]
