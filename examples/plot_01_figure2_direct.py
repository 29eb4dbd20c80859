"""
The Figure 2 chain identified from a modal test
===============================================

The reference paper's Figure 2 system is a chain of three masses held by four springs (k4
joins the first and the last mass).  Its modal test measured all three modes at every dof,
so the equations of motion are linear in the stiffnesses and the direct method solves them in
one step (paper eqs. 1–10).  This is what ``femupdate demo`` runs.
"""

import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femupdate as fu
from femupdate.examples import FIGURE2_TRUE, figure2_model_toml, figure2_test_data

# %%
# The model file and the test data are those ``femupdate demo --write-files ex`` writes
# (``ex/figure2.toml``, ``ex/figure2_test.json``): the model starts at wrong stiffnesses, the
# test was simulated at the true ones with 1 % noise on the shapes.
ex = Path(tempfile.mkdtemp())
(ex / "figure2.toml").write_text(figure2_model_toml())
(ex / "figure2_test.json").write_text(json.dumps(figure2_test_data()))

model = fu.load_model(ex / "figure2.toml")
data = fu.load_test_data(ex / "figure2_test.json", model)
print(model.parameter_names, [m.frequency_hz for m in data.modes])

# %%
# Before updating, the model's frequencies are 2 to 11 % off the test's:
before = fu.correlate(data, fu.model_modes(model))
print(before.frequency_error)

# %%
# The direct solution from all three modes, with its standard errors:
res = fu.direct_update(model, data)
for name, value, se in zip(res.unknowns, res.x, res.standard_error):
    print(f"{name}: {value:8.1f} ± {se:5.1f} N/m   (true {FIGURE2_TRUE[name]:.0f})")
print(f"condition number {res.condition_number:.3g}, rank {res.rank}/{len(res.unknowns)}")

# %%
# The identified stiffnesses against the truth, with two standard errors:
names = list(res.unknowns)
x = np.arange(len(names))
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.bar(x - 0.2, [FIGURE2_TRUE[n] for n in names], 0.4, label="true", color="0.75")
ax.bar(x + 0.2, res.x, 0.4, yerr=2 * res.standard_error, capsize=4, label="identified (± 2 s.e.)")
ax.bar(x, [model.values[model.parameter_index(n)] for n in names], 0.9, fill=False, ls="--",
       label="model's start")
ax.set_xticks(x, names)
ax.set_ylabel("stiffness [N/m]")
ax.legend(loc="upper right", fontsize=8)
ax.set_title("Figure 2 chain: direct identification from 3 modes")
fig.tight_layout()
