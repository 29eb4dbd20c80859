"""Record femupdate's command-line behaviour on the example files as normalised JSON.

    PYTHONPATH=<baseline tree>/src python tests/behaviour/record.py [OUTPUT_DIR [WORK_DIR [NAME ...]]]

runs ``python -m femupdate demo --write-files WORK_DIR/ex`` and then every command of
:data:`COMMANDS` on those example files (and on the fixed inputs in ``tests/behaviour/inputs``)
with ``--json``, normalises each result (:func:`normalise`) and writes it to
``OUTPUT_DIR/<name>.json`` (default ``tests/behaviour/recorded``; NAMEs: only those entries, no
manifest), plus ``MANIFEST.json``: for
every file, the command line with placeholders, the expected exit code and where the JSON is
read from.  ``tests/test_behaviour.py`` re-runs the manifest with the current code and compares.

The femupdate that runs is the one ``python -m femupdate`` imports: put ``PYTHONPATH=<tree>/src``
in front to record another checkout (e.g. a pristine ``git worktree`` of a baseline commit).

Placeholders in the manifest's command lines:

* ``{ex}``     the folder ``demo --write-files`` wrote the example files to;
* ``{inputs}`` ``tests/behaviour/inputs`` (fixed inputs the examples lack: a full-field scan);
* ``{work}``   a scratch folder for this command (side outputs such as ``paper --out``);
* ``{out}``    the ``--json`` output file.

Run to run, femupdate's output is bit-for-bit the same except for

* ``seconds`` (wall-clock time of a uniqueness study): dropped by :func:`normalise`;
* ``paper.json``'s ``eigenvector_derivatives`` section (CPU timings and the savings and verdict
  computed from them): dropped by :func:`normalise` (``tests/test_paper.py`` checks its errors);
* every result that goes through ARPACK (``scipy.sparse.linalg.eigsh``: the sparse modal solver,
  the reduction criteria, ...): femupdate passes neither ``v0`` nor ``rng``, so SciPy (>= 1.15)
  draws ARPACK's start vector from OS entropy at every call.  The eigenpairs then differ by
  round-off (~1e-14 relative) from run to run, and quantities that are round-off themselves (e.g.
  ``paper.json``'s ``reduction_truss`` modal/hybrid ``max_frequency_error`` ~1e-11, which also
  appears in that section's ``summary`` string) change completely.  :func:`pinned_arpack` makes
  that start vector a fixed function of the problem size (``default_rng(0)``) for every call;
  the recorder and the test both run femupdate under it.
"""

from __future__ import annotations

import contextlib
import inspect
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
INPUTS = HERE / "inputs"
RECORDED = HERE / "recorded"

TWO_DOF = ["{ex}/two_dof.toml"]
FIG2 = ["{ex}/figure2.toml", "{ex}/figure2_test.json"]
TRUSS_KEEP = "4:x,4:y,104:x,104:y,3:y,103:y"

# name -> command line (after ``python -m femupdate``).  "{out}" is the --json file unless the
# entry gives "result" (the file to read instead).  "exit" is the expected exit code (default 0).
COMMANDS: dict[str, dict] = {
    # ------------------------------------------------------------------ demo
    "demo": {"args": ["demo", "--json", "{out}"]},
    # ------------------------------------------------------------------ modes
    "modes_figure2": {"args": ["modes", "{ex}/figure2.toml", "--json", "{out}"]},
    "modes_two_dof": {"args": ["modes", *TWO_DOF, "--json", "{out}"]},
    "modes_two_dof_set_ref": {"args": ["modes", *TWO_DOF, "--set", "k1=9,k2=5.333333333333333", "--normalise", "ref:1:x",
                                       "--json", "{out}"]},
    "modes_truss": {"args": ["modes", "{ex}/truss.toml", "--json", "{out}"]},
    "modes_truss_sparse_unit": {"args": ["modes", "{ex}/truss.toml", "--method", "sparse", "--n-modes", "4",
                                         "--normalise", "unit", "--json", "{out}"]},
    # ------------------------------------------------------------------ direct
    "direct_figure2": {"args": ["direct", *FIG2, "--json", "{out}"]},
    "direct_figure2_bounded": {"args": ["direct", *FIG2, "--bounded", "--json", "{out}"]},
    # ------------------------------------------------------------------ correlate
    "correlate_figure2": {"args": ["correlate", *FIG2, "--json", "{out}"]},
    "correlate_truss": {"args": ["correlate", "{ex}/truss.toml", "{ex}/truss_damaged.json", "--json", "{out}"]},
    # ------------------------------------------------------------------ update
    "update_figure2": {"args": ["update", *FIG2, "--json", "{out}"]},
    "update_figure2_log_shapes_ref": {"args": ["update", *FIG2, "--parametrisation", "log", "--shape-scaling", "ref",
                                               "--std-eigenvalue", "0.001", "--std-shape", "0.01", "--json", "{out}"]},
    "update_two_dof": {"args": ["update", *TWO_DOF, "{ex}/two_dof_frequencies.json", "--json", "{out}"]},
    "update_two_dof_starts": {"args": ["update", *TWO_DOF, "{ex}/two_dof_frequencies.json", "--starts", "40", "--seed", "1",
                                       "--json", "{out}"]},
    # ------------------------------------------------------------------ frf
    "frf_two_dof": {"args": ["frf", *TWO_DOF, "--force", "1:x", "--omega", "0.4:2.8:7", "--json", "{out}"]},
    "frf_two_dof_damped_noisy": {"args": ["frf", *TWO_DOF, "--force", "2:x=2", "--omega", "0.5,1.0,1.5,2.5",
                                          "--kind", "accelerance", "--damping", "alpha=0.01,beta=0.001", "--noise", "0.01",
                                          "--seed", "3", "--json", "{out}"]},
    # ------------------------------------------------------------------ frf-select
    "frf_select_two_dof": {"args": ["frf-select", *TWO_DOF, "--force", "1:x", "--candidates", "0.1:3:30", "--lines", "5",
                                    "--json", "{out}"]},
    "frf_select_two_dof_sensitivity": {"args": ["frf-select", *TWO_DOF, "--force", "1:x", "--candidates", "0.1:3:30",
                                                "--lines", "4", "--kind", "sensitivity", "--dofs", "2:x", "--json", "{out}"]},
    # ------------------------------------------------------------------ frf-update
    "frf_update_two_dof": {"args": ["frf-update", *TWO_DOF, "{ex}/two_dof_frf.json", "--json", "{out}"]},
    "frf_update_two_dof_starts": {"args": ["frf-update", *TWO_DOF, "{ex}/two_dof_frf.json", "--starts", "10", "--seed", "2",
                                           "--residual", "log", "--json", "{out}"]},
    # ------------------------------------------------------------------ surface
    "surface_two_dof_frf": {"args": ["surface", *TWO_DOF, "{ex}/two_dof_frf.json", "--params", "k1,k2", "--x", "3:13:101",
                                     "--y", "1:11:101", "--truth", "k1=8,k2=6", "--json", "{out}"]},
    "surface_figure2_modal": {"args": ["surface", *FIG2, "--kind", "modal", "--params", "k1,k2", "--x", "500:1500:21",
                                       "--y", "1500:2500:21", "--json", "{out}"]},
    # ------------------------------------------------------------------ reduce
    "reduce_truss": {"args": ["reduce", "{ex}/truss.toml", "--keep", TRUSS_KEEP, "--json", "{out}"]},
    "reduce_truss_irs": {"args": ["reduce", "{ex}/truss.toml", "--keep", TRUSS_KEEP, "--method", "irs", "--json", "{out}"]},
    # ------------------------------------------------------------------ uniqueness
    "uniqueness_two_dof": {"args": ["uniqueness", *TWO_DOF, "--starts", "20", "--seed", "3", "--exact", "--json", "{out}"]},
    "uniqueness_figure2_noise": {"args": ["uniqueness", "{ex}/figure2.toml", "--measured-dofs", "1:x;1:x,2:x,3:x",
                                          "--modes", "1-2", "--starts", "10", "--seed", "5", "--noise", "0.01",
                                          "--json", "{out}"]},
    # ------------------------------------------------------------------ update-multi
    "update_multi_two_dof": {"args": ["update-multi", *TWO_DOF, "--config", "{ex}/two_dof_frequencies.json", "--config",
                                      "{ex}/two_dof_plus_2kg.json:{ex}/plus_2kg.toml", "--json", "{out}"]},
    # ------------------------------------------------------------------ rank-modifications
    "rank_modifications_two_dof": {"args": ["rank-modifications", *TWO_DOF, "{ex}/candidates.toml", "--measured-dofs", "1:x",
                                            "--modes", "2", "--eigenvalues-only", "--json", "{out}"]},
    "rank_modifications_two_dof_select": {"args": ["rank-modifications", *TWO_DOF, "{ex}/candidates.toml", "--measured-dofs",
                                                   "1:x,2:x", "--modes", "1", "--criterion", "logdet", "--select", "2",
                                                   "--json", "{out}"]},
    # ------------------------------------------------------------------ fullfield
    "fullfield_beam": {"args": ["fullfield", "{inputs}/beam.toml", "{inputs}/beam_scan.json", "--json", "{out}"]},
    "fullfield_beam_elements_pointwise": {"args": ["fullfield", "{inputs}/beam.toml", "{inputs}/beam_scan.json", "--method",
                                                   "elements", "--form", "pointwise", "--json", "{out}"]},
    # ------------------------------------------------------------------ damage
    "damage_truss": {"args": ["damage", "{ex}/truss.toml", "{ex}/truss_damaged.json", "--undamaged",
                              "{ex}/truss_undamaged.json", "--bootstrap", "4", "--json", "{out}"]},
    # ------------------------------------------------------------------ paper (every section)
    "paper": {"args": ["paper", "--out", "{work}/paper"], "result": "{work}/paper/paper.json"},
}


# ---------------------------------------------------------------------------------- normalisation
# Keys (at any depth) whose values change from run to run of the same code: wall-clock times.
#: dropped wherever they occur: wall-clock and CPU times, and the paper's eigenvector-derivative section, whose
#: results are CPU timings and the savings and verdict computed from them
VOLATILE_KEYS = frozenset({"seconds", "cpu_seconds", "eigenvector_derivatives"})


def normalise(obj, places: dict[str, str]):
    """``obj`` without :data:`VOLATILE_KEYS`; strings that contain one of the folders of
    ``places`` ({placeholder: folder}) get the placeholder instead (so absolute paths of temporary
    folders compare equal from run to run)."""
    if isinstance(obj, dict):
        return {k: normalise(v, places) for k, v in obj.items() if k not in VOLATILE_KEYS}
    if isinstance(obj, list):
        return [normalise(v, places) for v in obj]
    if isinstance(obj, str):
        for ph, folder in sorted(places.items(), key=lambda kv: -len(kv[1])):  # longest first
            obj = obj.replace(folder, ph)
        return obj
    return obj


def expand(text: str, places: dict[str, str]) -> str:
    for ph, folder in places.items():
        text = text.replace(ph, folder)
    return text


def _placeholders(ex: Path, work: Path, out: Path) -> dict[str, str]:
    return {"{ex}": str(ex), "{inputs}": str(INPUTS), "{work}": str(work), "{out}": str(out)}


# ---------------------------------------------------------------------------------- ARPACK start vector
@contextlib.contextmanager
def pinned_arpack(seed: int = 0):
    """ARPACK's random vectors (the start vector when no ``v0`` is given, and restarts) drawn from
    a fresh ``np.random.default_rng(seed)`` at every call instead of from OS entropy: same input,
    same eigenpairs, bit for bit.

    Patches SciPy's ARPACK parameter classes, through which every ``eigsh``/``eigs`` call goes
    however it was imported; restored on exit.

    The sparse factorisation backend is pinned too: SuperLU, with which the baseline was recorded
    (the CHOLMOD backend, where scikit-sparse is installed, gives the same eigenpairs to round-off,
    not bit for bit; tests/test_workspace.py compares the two) — through ``FEMUPDATE_FACTORISATION``,
    which every command reads as it starts (in this process or in a subprocess), and through the
    library's settings for anything called directly."""
    import os

    import numpy as np
    from scipy.sparse.linalg._eigen.arpack import arpack

    from femupdate import settings
    from femupdate.cli._entry import FACTORISATION_VARIABLE as BACKEND_VARIABLE

    saved_backend = os.environ.get(BACKEND_VARIABLE)
    os.environ[BACKEND_VARIABLE] = "superlu"
    saved_settings = settings.configure(factorisation="superlu")
    saved = {}
    for cls in (arpack._SymmetricArpackParams, arpack._UnsymmetricArpackParams):
        init = cls.__init__

        def pinned(self, *args, _init=init, _sig=inspect.signature(init), **kwargs):
            bound = _sig.bind(self, *args, **kwargs)  # eigsh/eigs pass everything by position
            bound.arguments["rng"] = np.random.default_rng(seed)
            return _init(*bound.args, **bound.kwargs)

        saved[cls] = init
        cls.__init__ = pinned
    try:
        yield
    finally:
        for cls, init in saved.items():
            cls.__init__ = init
        settings.install(saved_settings)
        if saved_backend is None:
            os.environ.pop(BACKEND_VARIABLE, None)
        else:
            os.environ[BACKEND_VARIABLE] = saved_backend


def _cli(argv: list[str]) -> None:
    """``python -m femupdate ARGV`` with :func:`pinned_arpack`."""
    from femupdate.cli import main

    with pinned_arpack():
        main(argv)


# ---------------------------------------------------------------------------------- environment
def environment() -> dict:
    """What the recorded round-off depends on besides femupdate: the processor (numba compiles for
    the host's instruction set, OpenBLAS picks its kernels by it), Python and the numerical
    libraries.  ``tests/test_behaviour.py`` compares bit for bit (1e-12) only where this equals
    the manifest's ``environment``."""
    import platform

    import llvmlite
    import numba
    import numpy
    import scipy
    import scipy.linalg  # noqa: F401  (SciPy's own BLAS is listed once loaded)
    from threadpoolctl import threadpool_info

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), cpu)
    except OSError:
        pass
    blas = sorted({f"{i.get('internal_api')} {i.get('version')} {i.get('architecture')}" for i in threadpool_info()
                   if i.get("user_api") == "blas"})
    return {"cpu": cpu, "machine": platform.machine(), "python": platform.python_version(),
            "numpy": numpy.__version__, "scipy": scipy.__version__, "numba": numba.__version__,
            "llvmlite": llvmlite.__version__, "blas": blas}


# ---------------------------------------------------------------------------------- fixed inputs
def write_inputs(directory: Path = INPUTS) -> None:
    """The full-field inputs the example files lack (a 12-element cantilever in four segments and a
    noisy 90-point scan of its first four modes); written once, then kept as they are."""
    beam, scan = directory / "beam.toml", directory / "beam_scan.json"
    if beam.exists() and scan.exists():
        return
    import tomllib

    import numpy as np

    from femupdate import Structure
    from femupdate.fullfield.examples import scan_beam

    directory.mkdir(parents=True, exist_ok=True)
    E = (2.0e11, 2.2e11, 1.9e11, 2.1e11)
    lines = ['[model]\nname = "segmented cantilever"']
    lines += [f"[parameters.E{k}]\nvalue = 2.1e11\nbounds = [1e10, 5e11]" for k in range(1, 5)]
    lines += [f"[[node]]\nid = {i}\nxyz = [{i / 12!r}, 0.0]" for i in range(13)]
    lines += [f'[[element]]\ntype = "beam2d"\nnodes = [{i}, {i + 1}]\nE = "E{i // 3 + 1}"\nA = 1e-3\nI = 8.33e-8\nrho = 7850.0'
              for i in range(12)]
    lines += ["[[support]]\nnodes = [0]"]
    beam.write_text("\n".join(lines) + "\n")
    s = Structure.from_dict(tomllib.loads(beam.read_text()))
    truth = s.build().with_values(dict(zip([f"E{k}" for k in range(1, 5)], E)))
    sc = scan_beam(truth, np.linspace(0.004, 1.0, 90), 4, noise=1e-3, seed=1)
    scan.write_text(json.dumps({"points": np.asarray(sc.points).tolist(), "zero": list(sc.zero),
                                "modes": [{"eigenvalue": float(m.eigenvalue), "values": {d: np.asarray(v).tolist()
                                                                                        for d, v in m.values.items()}}
                                          for m in sc.modes]}, indent=1) + "\n")


# ---------------------------------------------------------------------------------- running
def run_command(entry: dict, ex: Path, work: Path, out: Path) -> tuple[int, dict | None, str]:
    """Run one manifest entry in a subprocess; (exit code, raw JSON result or None, stderr)."""
    places = _placeholders(ex, work, out)
    args = [expand(a, places) for a in entry["args"]]
    work.mkdir(parents=True, exist_ok=True)
    # = python -m femupdate ARGS, with ARPACK's start vector pinned (module docstring)
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--cli", *args], capture_output=True, text=True,
                          cwd=work)
    result = Path(expand(entry.get("result", "{out}"), places))
    data = json.loads(result.read_text()) if result.exists() else None
    return proc.returncode, data, proc.stderr


def record(output_dir: Path, work_dir: Path, only: list[str] | None = None) -> dict:
    output_dir, work_dir = Path(output_dir).resolve(), Path(work_dir).resolve()
    output_dir.mkdir(parents=True, exist_ok=True)
    work_dir.mkdir(parents=True, exist_ok=True)
    write_inputs()
    ex = work_dir / "ex"
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--cli", "demo", "--write-files", str(ex)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"demo --write-files failed:\n{proc.stderr}")
    import femupdate

    src = Path(femupdate.__file__).resolve().parent
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=src).stdout.strip()
    manifest = {"recorded_from_commit": commit or None, "environment": environment(),
                "arpack_start_vector": "pinned: np.random.default_rng(0)",
                "placeholders": {
        "{ex}": "folder written by 'python -m femupdate demo --write-files {ex}'",
        "{inputs}": "tests/behaviour/inputs", "{work}": "scratch folder of the command", "{out}": "the --json file"},
        "volatile_keys_dropped": sorted(VOLATILE_KEYS), "entries": {}}
    for name, entry in COMMANDS.items():
        if only and name not in only:
            continue
        work = work_dir / "runs" / name
        if work.exists():
            shutil.rmtree(work)
        out = work / f"{name}.json"
        t0 = time.perf_counter()
        code, data, err = run_command(entry, ex, work, out)
        dt = time.perf_counter() - t0
        print(f"{name:40s} exit {code}  {dt:6.1f} s", flush=True)
        if data is None:
            raise SystemExit(f"{name}: no JSON written (exit {code}):\n{err}")
        if code != entry.get("exit", 0):
            print(f"  unexpected exit code {code}: {err.strip()[-500:]}", flush=True)
        fname = f"{name}.json"
        (output_dir / fname).write_text(json.dumps(normalise(data, _placeholders(ex, work, out)), indent=1,
                                                   allow_nan=False) + "\n")
        manifest["entries"][fname] = {"command": ["python", "-m", "femupdate", *entry["args"]],
                                      "result": entry.get("result", "{out}"), "exit": code}
    if not only:
        (output_dir / "MANIFEST.json").write_text(json.dumps(manifest, indent=1) + "\n")
    return manifest


if __name__ == "__main__":
    argv = sys.argv[1:]
    if argv[:1] == ["--cli"]:
        _cli(argv[1:])
    out_dir = Path(argv[0]) if argv else RECORDED
    work_dir = Path(argv[1]) if len(argv) > 1 else Path(os.environ.get("TMPDIR", "/tmp")) / "femupdate_behaviour"
    record(out_dir, work_dir, argv[2:] or None)
