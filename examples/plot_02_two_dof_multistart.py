"""
Two solutions from two frequencies: multi-start updating
========================================================

The paper's Figure 3 system, ground –k1– m1 –k2– m2 with m = (2, 4) kg, measured for its two
natural frequencies only (k1 = 8, k2 = 6 N/m in truth).  Two numbers for two unknowns look
enough, but the eigenvalue equations are quadratic: a second pair of stiffnesses, (9, 16/3),
has exactly the same frequencies (paper eq. 11).  A single local update finds whichever
solution is nearer its start; random starts within the bounds find both.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femupdate as fu
from femupdate.examples import write_example_files
from femupdate.frf.surfaces import modal_surface

# %%
# The example files of ``femupdate demo --write-files ex``: ``two_dof.toml`` starts at
# k = (7, 6.5); ``two_dof_frequencies.json`` holds the two measured eigenvalues.
ex = Path(tempfile.mkdtemp())
write_example_files(ex)
model = fu.load_model(ex / "two_dof.toml")
data = fu.load_test_data(ex / "two_dof_frequencies.json", model)

# %%
# One update from the model's values converges to the truth...
res = fu.update(model, data)
print(res)

# %%
# ...and from another start, to the other solution, which fits the data just as well:
other = fu.update(model, data, x0={"k1": 11.0, "k2": 4.0})
print(other)

# %%
# 40 random starts within the bounds, clustered into distinct solutions (this is
# ``femupdate update ex/two_dof.toml ex/two_dof_frequencies.json --starts 40``):
study = fu.multistart(model, data, starts=40, seed=1)
for s in study.solutions:
    print(s.count, "starts:", {k: round(v, 6) for k, v in s.parameters.items()}, f"cost {s.cost:.2g}")

# %%
# The residual of eq. 33 over (k1, k2) has two zeros on a valley of equal fit; each start
# (dot) is coloured by the solution it reached.
surface = modal_surface(model, data, ("k1", "k2"), np.linspace(3, 13, 121), np.linspace(1, 11, 121))
fig, ax = plt.subplots(figsize=(5.5, 4.5))
cs = ax.contourf(surface.x, surface.y, np.log10(surface.values.T + 1e-12), levels=30, cmap="viridis")
fig.colorbar(cs, ax=ax, label="log10 residual (eq. 33)")
colours = ["tab:red", "tab:orange", "tab:pink"]
for start, run in zip(study.starts, study.runs):
    reached = np.array([run.parameters["k1"], run.parameters["k2"]])
    k = min(range(len(study.solutions)), key=lambda i: np.linalg.norm(
        reached - [study.solutions[i].parameters["k1"], study.solutions[i].parameters["k2"]]))
    ax.plot(*start, "o", ms=3, color=colours[k % 3])
for i, s in enumerate(study.solutions):
    ax.plot(s.parameters["k1"], s.parameters["k2"], "*", ms=16, mec="k", color=colours[i % 3],
            label=f"({s.parameters['k1']:.3g}, {s.parameters['k2']:.3g}): {s.count} starts")
ax.set_xlabel("k1 [N/m]")
ax.set_ylabel("k2 [N/m]")
ax.set_xlim(3, 13)
ax.set_ylim(1, 11)
ax.legend(loc="upper right", fontsize=8)
ax.set_title("two frequencies, two exact solutions")
fig.tight_layout()
