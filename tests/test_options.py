"""The option objects as the functions that take them receive them: every verb whose options
include an update's (``multistart``, ``posterior``) takes the update's option objects by the same
keywords as :func:`femupdate.update` (``modal=``, ``pairing=``, ``noise=``, ``solver=``, ``frf=``),
as docs/python-api.md ("Options as objects") says."""

from __future__ import annotations

import pytest

import femupdate as fu
from femupdate.examples import two_dof
from femupdate.options import (FRFOptions, ModalOptions, NoiseOptions, PairingOptions, SolverOptions,
                               UpdateOptions)


def test_update_options_take_the_parts_by_their_keywords():
    o = UpdateOptions.of("f", {"modal": ModalOptions(use_shapes=False), "solver": SolverOptions(max_nfev=7),
                               "pairing": PairingOptions(rule="order"), "noise": NoiseOptions(basis="estimate"),
                               "frf": {"residual": "log"}, "min_mac": 0.8})
    assert o.modal == ModalOptions(use_shapes=False)
    assert o.solver.max_nfev == 7
    assert o.pairing == PairingOptions(rule="order", min_mac=0.8)   # the shorthand changes the part given
    assert o.noise.basis == "estimate"
    assert o.frf.residual == "log"
    # a plain value is still the shorthand of a field: solver="dense" is FRFOptions.solver
    assert UpdateOptions.of("f", {"solver": "dense"}).frf.solver == "dense"
    assert UpdateOptions.of("f", {"pairing": "mac"}).pairing.rule == "mac"


def test_a_part_of_the_wrong_class_is_named():
    with pytest.raises(TypeError, match=r"f\(solver=\.\.\.\): expected SolverOptions, got ModalOptions"):
        UpdateOptions.of("f", {"solver": ModalOptions()})
    with pytest.raises(TypeError, match="modal"):
        UpdateOptions.of("f", {"modal": ModalOptions()}, modal=ModalOptions())


def _freq_data():
    model = two_dof()
    modes = fu.model_modes(model, {"k1": 8.0, "k2": 6.0})
    return model, fu.TestData(modes=tuple(fu.MeasuredMode(lam) for lam in modes.eigenvalues))


def test_multistart_takes_the_update_option_objects():
    model, data = _freq_data()
    by_object = fu.multistart(model, data, starts=3, seed=2, batched=False, solver=SolverOptions(max_nfev=2))
    by_options = fu.multistart(model, data, starts=3, seed=2, batched=False,
                               options=UpdateOptions(solver=SolverOptions(max_nfev=2)))
    assert [r.nfev for r in by_object.runs] == [r.nfev for r in by_options.runs]
    assert max(r.nfev for r in by_object.runs) <= 2                  # the solver's options reached the runs


def test_posterior_takes_the_update_option_objects():
    model, data = _freq_data()
    kw = dict(starts=4, seed=1, samples=200, predictive=0)
    by_object = fu.posterior(model, data, noise=NoiseOptions(std={"eigenvalue": 0.002}), **kw)
    by_keyword = fu.posterior(model, data, measurement_std={"eigenvalue": 0.002}, **kw)
    assert by_object.median == by_keyword.median


def test_frf_options_reach_multistart_as_an_object():
    model, _ = _freq_data()
    with pytest.raises(fu.InputError, match="FRF options"):
        fu.multistart(model, _freq_data()[1], starts=2, frf=FRFOptions(residual="log"))


@pytest.mark.parametrize("std, shown", [
    ({"eigenvalue": "x"}, "'x'"), ({"eigenvalue": float("nan")}, "nan"), ({"shape": -1}, "-1"),
    ({"eigenvalue": 0}, "0"), ({"eigenvalue": [1e-3, float("inf")]}, "inf"), ({"frf": [[1.0], [None]]}, "None"),
])
def test_a_standard_deviation_is_checked_when_the_noise_options_are_made(std, shown):
    """Before, NoiseOptions took any value: 'x' reached update as 'ValueError: could not convert
    string to float', and a multi-start recorded the same refusal as the failure of every start
    (a result with no solution, no error)."""
    key = next(iter(std))
    with pytest.raises(fu.InputError, match=rf"^measurement_std\['{key}'\] must be positive and finite \(.*\), got .*{shown}"):
        NoiseOptions(std=std)
    model, data = _freq_data()
    with pytest.raises(fu.InputError, match=r"^measurement_std"):
        fu.multistart(model, data, starts=2, measurement_std=std)


@pytest.mark.parametrize("weights", [{"eigenvalue": -1}, {"shape": float("inf")}, {"eigenvalue": [1, float("nan")]},
                                     {"shape": "heavy"}])
def test_a_weight_is_checked_when_the_noise_options_are_made(weights):
    key = next(iter(weights))
    with pytest.raises(fu.InputError, match=rf"^weights\['{key}'\] must be finite and non-negative"):
        NoiseOptions(weights=weights)


def test_valid_noise_options_are_kept_as_given():
    o = NoiseOptions(std={"eigenvalue": [1e-3, 2e-3], "shape": 0.01, "frf": None}, weights={"shape": 0})
    assert o.std == {"eigenvalue": [1e-3, 2e-3], "shape": 0.01, "frf": None}
    assert o.weights == {"shape": 0}


@pytest.mark.parametrize("given", [[1, 2], "max_nfev=3", 3, None])
def test_from_dict_of_no_mapping_is_named(given):
    """SolverOptions.from_dict([1, 2]) raised "cannot convert dictionary update sequence element
    #0 to a sequence", naming neither the method nor what it got."""
    with pytest.raises(TypeError, match=r"^SolverOptions\.from_dict: expected a mapping of SolverOptions' fields, got"):
        SolverOptions.from_dict(given)
    assert SolverOptions.from_dict({"max_nfev": 3}) == SolverOptions(max_nfev=3)


def test_a_misspelt_field_of_an_option_object_gets_the_closest_named():
    """SolverOptions(max_nfevs=3) raised Python's own "SolverOptions.__init__() got an unexpected
    keyword argument 'max_nfevs'"; the functions' shorthand keywords already named the closest."""
    with pytest.raises(TypeError, match=r"^SolverOptions\(\) got an unexpected keyword argument 'max_nfevs'; did you "
                                        r"mean 'max_nfev'\? \(its options: method, max_nfev, "):
        SolverOptions(max_nfevs=3)
    with pytest.raises(TypeError, match=r"^PairingOptions\(\) got an unexpected keyword argument 'pairing'; it is the "
                                        r"functions' shorthand of the field 'rule'"):
        PairingOptions(pairing="mac")
    import pickle

    o = SolverOptions(max_nfev=3)
    assert pickle.loads(pickle.dumps(o)) == o and o.replace(ftol=1e-6).max_nfev == 3


@pytest.mark.parametrize("make, message", [
    (lambda: fu.SamplerOptions(walkers=16), "walkers=16 applies to method=mcmc only, not method=laplace"),
    (lambda: fu.SamplerOptions(method="tmcmc", burn=5), "burn=5 applies to method=mcmc only, not method=tmcmc"),
    (lambda: fu.SamplerOptions(method="mcmc", walkers=33), "walkers=33: the ensemble sampler needs an even number"),
])
def test_sampler_options_that_would_do_nothing_are_refused_when_made(make, message):
    with pytest.raises(fu.InputError, match=message):
        make()
    assert fu.SamplerOptions(method="mcmc", walkers=32, burn=5).walkers == 32


def test_damage_alpha_is_refused_with_the_tikhonov_localisation():
    from femupdate.damage import DamageOptions

    with pytest.raises(fu.InputError, match="alpha=0.3 .* applies to method=l1 only, not method=tikhonov"):
        DamageOptions(method="tikhonov", alpha=0.3)
    assert DamageOptions(method="l1", alpha=0.3).alpha == 0.3
