"""
Updating from frequency response functions
==========================================

The Figure 3 system again, now measured by its receptances: a unit force at dof 1, the
responses of both masses at 7 spectral lines from 0.4 to 2.8 rad/s (Figure 7's lines) with
0.1 % noise.  FRF updating (paper eqs. 30–32) fits the model's receptances to them; the
default residual, ``auto``, first fits log-magnitudes (wide basin) and then the linear
residual (eq. 34) from there.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import femupdate as fu
from femupdate.examples import write_example_files

ex = Path(tempfile.mkdtemp())
write_example_files(ex)  # as `femupdate demo --write-files ex`
model = fu.load_model(ex / "two_dof.toml")  # starts at k = (7, 6.5); the truth is (8, 6)
data = fu.load_test_data(ex / "two_dof_frf.json", model)
print(data.frf.omega, data.frf.dofs)

# %%
# ``femupdate frf-update ex/two_dof.toml ex/two_dof_frf.json`` in Python:
res = fu.frf_update(model, data)
print(res.summary())
print("residual:", res.residual, "| lines used:", res.omega)

# %%
# The measured receptances against the model's before and after, on a fine grid:
omega = np.linspace(0.05, 3.0, 600)
start = fu.simulate_frf(model, omega, {"1:x": 1.0})
updated = fu.simulate_frf(model, omega, {"1:x": 1.0}, values=res.parameters)
fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
for k, (ax, dof) in enumerate(zip(axes, data.frf.dofs)):
    j = list(start.dofs).index(dof)
    ax.semilogy(omega, np.abs(start.response[:, j]), "--", color="0.5", label="model, start (7, 6.5)")
    ax.semilogy(omega, np.abs(updated.response[:, j]), color="tab:blue", label="model, updated")
    ax.semilogy(data.frf.omega, np.abs(data.frf.response[:, k]), "o", color="tab:red", label="measured")
    ax.set_xlabel("ω [rad/s]")
    ax.set_title(f"response at {dof}, force at 1:x")
axes[0].set_ylabel("|receptance| [m/N]")
axes[0].legend(fontsize=8)
fig.tight_layout()
