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
    yield from _damage_results(ex)
    yield from _posterior_results(two)
    from femupdate.paper import run_sections

    yield run_sections(ex / "paper", ["two_dof_characteristic"], figures=False, jobs=1)


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
