"""The JSON results' schema is the one place their keys are described: the documentation is
generated from it, and the results write exactly the keys it describes, with the types it says."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import femupdate as fu
from femupdate import schema
from femupdate.cli import main

DOCS = Path(__file__).resolve().parents[1] / "docs" / "file-formats.md"


def test_the_documentation_is_the_schema():
    text = DOCS.read_text(encoding="utf-8")
    assert schema.rewrite(text) == text, "docs/file-formats.md: run python -m femupdate.schema docs/file-formats.md"
    for name in schema.kinds():
        assert f"<!-- schema: {name} -->" in text, f"kind {name} is not in docs/file-formats.md"


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    d = tmp_path_factory.mktemp("ex")
    with pytest.raises(SystemExit):
        main(["demo", "--write-files", str(d)])
    return d


def _results(ex):
    two = fu.load_model(ex / "two_dof.toml")
    fig2 = fu.load_model(ex / "figure2.toml")
    yield fu.update(fig2, fu.load_test_data(ex / "figure2_test.json", fig2))
    yield fu.update(fig2, fu.load_test_data(ex / "figure2_test.json", fig2), formulation="dynamic")
    yield fu.multistart(two, fu.load_test_data(ex / "two_dof_frequencies.json", two), starts=6)
    yield fu.frf_update(two, fu.load_test_data(ex / "two_dof_frf.json", two))
    yield fu.update(two, fu.load_test_data(ex / "two_dof_frf.json", two))
    yield from _frf_and_uniqueness_results(ex, two, fig2)
    yield from _modal_results(ex)
    yield from _damage_results(ex)
    yield from _posterior_results(two)
    yield _Summary(ex / "truss.toml")
    from femupdate.planning import plan

    yield plan(two, n_modes=2, points=2, monte_carlo=3)
    from femupdate.paper import run_sections

    yield run_sections(ex / "paper", ["two_dof_characteristic"], figures=False, jobs=1)



class _Summary:
    """``femupdate summary``'s JSON (a plain dict, not a result object) as the loop above takes it."""

    def __init__(self, path):
        from femupdate.io.model_file import read_toml
        from femupdate.summary import model_summary

        s = fu.Structure.from_dict(read_toml(path))
        self.obj = model_summary(s.build(), s)

    def to_json(self) -> dict:
        return self.obj


def _frf_and_uniqueness_results(ex, two, fig2):
    """The kinds frf, frf-select, surface, frf-update (multi-start, global) and uniqueness."""
    import numpy as np

    from femupdate.frf import frf_surface, modal_surface, select_frequencies
    from femupdate.uniqueness import define_study, run_study

    frf_data = fu.load_test_data(ex / "two_dof_frf.json", two)
    yield fu.simulate_frf(two, [0.5, 1.0], {"1:x": 1.0}, damping={"eta": 0.02}, noise=0.01, seed=1)
    yield select_frequencies(two, np.linspace(0.1, 3, 30), 4, {"1:x": 1.0}, kind="sensitivity", response=["2:x"])
    yield frf_surface(two, frf_data.frf, ["k1", "k2"], [3.0, 8.0, 13.0], [1.0, 6.0, 11.0])
    yield modal_surface(fig2, fu.load_test_data(ex / "figure2_test.json", fig2), ["k1", "k2"], [500.0, 1000.0],
                        [1500.0, 2000.0])
    yield fu.frf_multistart(two, frf_data, starts=4, seed=1)
    yield fu.global_search(two, frf_data, runs=1, seed=0, method_options={"maxiter": 5})
    study = define_study(two, [(("1:x",), 2), (("1:x", "2:x"), 1)], starts=8, seed=3, noise=[0.01])
    yield run_study(study).with_exact().with_figure("uniqueness.png")

def _modal_results(ex):
    """modes, correlate, direct, demo, reduce and fullfield (with damping, units and notes where they can be)."""
    from femupdate.examples import demo
    from femupdate.frf import Damping
    from femupdate.fullfield import full_field_direct, structure_segments
    from femupdate.fullfield.files import load_scan
    from femupdate.io.model_file import read_toml
    from femupdate.reduction import reduce_model

    fig2, truss = fu.load_model(ex / "figure2.toml"), fu.load_model(ex / "truss.toml")
    data = fu.load_test_data(ex / "figure2_test.json", fig2)
    yield fu.model_modes(fig2)
    yield fu.model_modes(truss, n_modes=3, method="sparse")
    yield fu.correlate(data, fu.model_modes(fig2)).with_context(damping=Damping(alpha=0.5))
    yield fu.correlate(fu.load_test_data(ex / "truss_damaged.json", truss), fu.model_modes(truss), pairing="mac")
    yield fu.direct_update(fig2, data)
    yield fu.direct_update(fig2, data, bounded=True, unknowns=["k1", "k2"])
    yield demo()
    yield reduce_model(truss, ["4:x", "4:y", "104:x", "104:y", "3:y", "103:y"])
    from femupdate.damping import DampedModel, Damper, complex_modes

    yield complex_modes(DampedModel(truss, alpha=0.5, dampers=(Damper(("4:x", "104:y"), 40.0),)), n_modes=3)
    inputs = Path(__file__).resolve().parent / "behaviour" / "inputs"
    structure = fu.Structure.from_dict(read_toml(inputs / "beam.toml"))
    yield full_field_direct(structure.build(), load_scan(inputs / "beam_scan.json"),
                            segments=structure_segments(structure))


def _damage_results(ex):
    """damage (confirmed, and refused without refinement), update-multi (iterative and direct) and
    rank-modifications."""
    from femupdate.damage import damage_unknowns, detect_damage
    from femupdate.io.model_file import read_toml
    from femupdate.updating.multiconfig import Configuration, configure, rank_modifications, simulate, solve_configurations
    from femupdate.updating.multiconfig.files import load_candidates, load_modification

    du = damage_unknowns(fu.Structure.from_dict(read_toml(ex / "truss.toml")))
    data = fu.load_test_data(ex / "truss_damaged.json", du.model)
    yield detect_damage(du, data, undamaged=fu.load_test_data(ex / "truss_undamaged.json", du.model), bootstrap=2)
    yield detect_damage(du, data, refine=False, bootstrap=0, localise_min_mac=0.9999)
    two = fu.load_model(ex / "two_dof.toml")
    mod = load_modification(ex / "plus_2kg.toml")
    cfgs = [Configuration(fu.load_test_data(ex / "two_dof_frequencies.json", two)),
            Configuration(fu.load_test_data(ex / "two_dof_plus_2kg.json", configure(two, mod).model), mod)]
    yield solve_configurations(two, cfgs)
    complete = [Configuration(simulate(two, None, ["1:x", "2:x"], 2)), Configuration(simulate(two, mod, ["1:x", "2:x"], 2), mod)]
    yield solve_configurations(two, complete)
    yield rank_modifications(two, load_candidates(ex / "candidates.toml"), ["1:x"], 2, select=2)


def _posterior_results(two):
    data = fu.TestData(modes=tuple(fu.MeasuredMode(v, std_eigenvalue=0.01)
                                   for v in fu.model_modes(two).eigenvalues))
    yield fu.posterior(two, data, seed=0, starts=4)
    yield fu.posterior(two, data, method="tmcmc", samples=200, tmcmc_steps=2, starts=4, seed=0)


def test_results_write_the_keys_the_schema_describes(ex):
    kinds = set()
    for result in _results(ex):
        obj = json.loads(json.dumps(result.to_json()))
        kinds.add(obj["kind"])
        kind = schema.kinds()[obj["kind"]]
        described = {n.strip() for k in (*schema.COMMON, *kind.all_keys()) for n in k.name.split(",")}
        assert set(obj) <= described, (obj["kind"], sorted(set(obj) - described))
        schema.check(obj, obj["kind"])  # every key holds the type the schema says
    assert kinds == set(schema.kinds()), sorted(set(schema.kinds()) - kinds)  # every described kind written


def test_a_key_of_the_wrong_type_is_named():
    with pytest.raises(fu.InputError, match="/success: expected boolean, got string"):
        schema.check({"kind": "update", "success": "yes"}, "update")
    with pytest.raises(fu.InputError, match="/frac: expected object"):
        schema.check({"kind": "frf-update", "frac": [1, 2]}, "frf-update")
