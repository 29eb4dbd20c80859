import os

import numpy as np
import pytest

from femupdate import Structure


#: the long versions of the heavier checks run with FEMUPDATE_HEAVY=1 (CI runs the short ones)
HEAVY = bool(os.environ.get("FEMUPDATE_HEAVY"))
heavy = pytest.mark.skipif(not HEAVY, reason="set FEMUPDATE_HEAVY=1 for the long versions")


@pytest.fixture(scope="module")
def ex(tmp_path_factory):
    """The example files of ``femupdate demo --write-files`` (models .toml, test data .json),
    written once per test module (a module may define its own ``ex``)."""
    from femupdate.cli import main

    d = tmp_path_factory.mktemp("ex")
    with pytest.raises(SystemExit) as info:
        main(["demo", "--write-files", str(d)])
    assert info.value.code in (0, None)
    return d


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def spring_chain(k, m, name="chain"):
    """Grounded spring-mass chain; parameters k1..kN."""
    s = Structure(name)
    for i, (ki, mi) in enumerate(zip(k, m), start=1):
        s.parameter(f"k{i}", ki, (0.0, 1e9))
        s.spring([f"{i}:x"] if i == 1 else [f"{i - 1}:x", f"{i}:x"], k=f"k{i}")
        s.mass([f"{i}:x"], m=mi)
    return s


def cantilever_beam2d(n_el=20, length=1.0, E=2.1e11, A=1e-3, I=8.33e-8, rho=7850.0, mass="consistent"):
    s = Structure("cantilever")
    x = np.linspace(0.0, length, n_el + 1)
    s.add_nodes(range(n_el + 1), np.c_[x, 0 * x])
    s.beam2d(np.c_[np.arange(n_el), np.arange(1, n_el + 1)], E=E, A=A, I=I, rho=rho, mass=mass)
    s.support_node([0])
    return s
