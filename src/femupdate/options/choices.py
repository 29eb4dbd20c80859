"""The choices the option objects accept, in one place (the modules that implement them import
them from here)."""

from __future__ import annotations

# ---------------------------------------------------------------------------------- choices
#: how test modes are paired with model modes (:class:`PairingOptions`)
PAIRING_RULES = ("auto", "mac", "order", "frequency")
#: the residuals of measured modes, the default first (:class:`ModalOptions`)
FORMULATIONS = ("shapes", "mac", "dynamic")
#: how compared shapes are scaled (:class:`ModalOptions`)
SHAPE_SCALINGS = ("unit", "ref", "max")
#: routes of the eigenvector derivatives (:func:`femupdate.sensitivity.jacobian`)
SENSITIVITY_ROUTES = ("auto", "nelson", "modal", "static", "subspace", "adjoint", "fd")
#: the variables the solver works in (:class:`SolverOptions`)
PARAMETRISATIONS = ("relative", "log", "absolute")
#: SciPy's least-squares methods (:class:`SolverOptions`)
LSQ_METHODS = ("trf", "dogbox", "lm")
#: the rules that choose a Tikhonov factor (:class:`SolverOptions`)
REGULARIZATION_RULES = ("gcv", "lcurve")
#: FRF residual forms (:class:`FRFOptions`); ``"auto"``: a log-magnitude stage, then linear
FRF_RESIDUALS = ("linear", "relative", "log", "auto")
#: what to do with FRF lines near a resonance (:class:`FRFOptions`)
RESONANCE_POLICIES = ("skip", "error", "keep")
#: the equations whose conditioning chooses FRF lines (:class:`SelectionOptions`)
SELECTION_EQUATIONS = ("direct", "sensitivity")
#: solvers of the FRF line systems (:class:`FRFOptions`)
FRF_SOLVERS = ("auto", "dense", "sparse")
#: the kinds of test data, in the order their residual blocks are stacked
DATA_KINDS = ("modes", "frf", "static")
#: the keys of :attr:`NoiseOptions.std`, and the kind of data each belongs to
STD_KEYS = {"eigenvalue": "modes", "shape": "modes", "damping_ratio": "modes", "frf": "frf", "static": "static"}
#: what standard deviations rest on (:class:`NoiseOptions`)
NOISE_BASES = ("auto", "stated", "estimate")
#: the posterior's methods (:class:`~femupdate.options.SamplerOptions`)
SAMPLER_METHODS = ("laplace", "mcmc", "tmcmc")
#: how likelihoods are evaluated (:class:`~femupdate.options.SamplerOptions`)
LIKELIHOOD_ROUTES = ("auto", "compiled", "local")
