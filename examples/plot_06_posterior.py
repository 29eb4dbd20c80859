"""
How far to trust the update: the posterior of the two-dof system
================================================================

The two frequencies of the Figure 3 system, measured with a stated 0.2 % uncertainty on each
eigenvalue, admit two exact solutions (see the multi-start example).  Bayesian updating turns
"two solutions" into probabilities: with a uniform prior within the bounds both are equally
probable, and the samples show the curved ridge of equal fit that joins them.  Transitional
MCMC (``method="tmcmc"``) samples it and estimates the evidence; it needs no optional package.
This is ``femupdate posterior ex/two_dof.toml ex/two_dof_frequencies.json --std-eigenvalue
0.002 --method tmcmc``.
"""

import matplotlib.pyplot as plt

import femupdate as fu
from femupdate.examples import two_dof

model = two_dof()  # k1 = 8, k2 = 6 N/m, bounds [0, 100]
lam = fu.model_modes(model).eigenvalues
data = fu.TestData(modes=tuple(fu.MeasuredMode(v, std_eigenvalue=0.002) for v in lam))

# %%
# 2,000 samples; the solutions found by multi-start carry their probabilities:
post = fu.posterior(model, data, method="tmcmc", samples=2000, seed=1)
print(post.summary())
for m in post.modes:
    print({k: round(v, 4) for k, v in m.parameters.items()}, "probability", round(m.probability, 3))

# %%
# The samples over (k1, k2), with the two solutions:
s = post.samples
fig, ax = plt.subplots(figsize=(5.5, 4.2))
ax.plot(s[:, 0], s[:, 1], ".", ms=2, alpha=0.3, color="tab:blue", label="posterior samples")
for m in post.modes:
    ax.plot(m.parameters["k1"], m.parameters["k2"], "*", ms=14, mec="k", color="tab:red")
    ax.annotate(f"P = {m.probability:.2f}", (m.parameters["k1"], m.parameters["k2"]),
                textcoords="offset points", xytext=(8, 8))
ax.set_xlabel("k1 [N/m]")
ax.set_ylabel("k2 [N/m]")
ax.set_title("two frequencies at 0.2 %: two equally probable solutions")
ax.legend(loc="upper right", fontsize=8)
fig.tight_layout()
