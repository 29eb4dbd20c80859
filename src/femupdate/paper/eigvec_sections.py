"""Paper section on eigenvector derivatives (the text after eq. 21): Nelson's direct method, the
modal method (full and truncated), Wang's static correction and the iterative (subspace) route,
each timed and checked against finite differences on models of growing size; Ting's (1992)
saving of about 70 % against Nelson measured beside it.

The models are grounded spring chains of N masses whose springs share L stiffness parameters
(consecutive groups): banded (tridiagonal) like the models Nelson's method is praised for, well
conditioned so that finite differences are a sharp reference, and cheap to grow.
"""

from __future__ import annotations

import time

import numpy as np

ORDER = 25
SIZES = (100, 400, 1600)  #: chain lengths N (dofs)
N_PARAMS = (2, 16)  #: L: few parameters (Ting's case) and many
N_DIFF = 3  #: modes differentiated (the lowest)
FULL_MODAL_MAX = 400  #: the full modal method needs all N modes: dense, run up to this size
REPEATS = 3
PAPER_SAVING = 0.70  # Ting (1992) via the paper: "decreases in computational cost ... of order 70%"


def grouped_chain(N: int, L: int):
    """Grounded chain of N unequal masses; spring i belongs to group ``i * L // N`` (L parameters)."""
    from ..structure import Structure

    s = Structure(f"chain of {N} masses, {L} spring groups")
    for g in range(L):
        s.parameter(f"k{g + 1}", 1000.0 * (1.0 + 0.3 * np.sin(g + 1)), (1.0, 1e6))
    grp = np.minimum(np.arange(N) * L // N, L - 1)
    s.spring(["1:x"], k="k1")
    s.springs([[f"{i}:x", f"{i + 1}:x"] for i in range(1, N)], k=[f"k{grp[i] + 1}" for i in range(1, N)])
    for i in range(1, N + 1):
        s.mass([f"{i}:x"], m=1.0 + 0.2 * np.cos(i))
    return s.build()


def _best(f, repeats=REPEATS):
    """(smallest CPU time over ``repeats`` runs, the last result)."""
    best, out = np.inf, None
    for _ in range(repeats):
        t = time.process_time()
        out = f()
        best = min(best, time.process_time() - t)
    return float(best), out


def eigenvector_derivatives(out_dir, figures=True, sizes=SIZES, n_params=N_PARAMS) -> dict:
    from ..modal import DENSE_LIMIT, model_modes
    from ..sensitivity import buffered_modes, finite_difference, modal, modal_static_correction, nelson
    from ..sensitivity.factor import single_thread_blas
    from ..sensitivity.subspace import subspace_details

    which = list(range(N_DIFF))
    rows = []
    with single_thread_blas():
        for N in sizes:
            for L in n_params:
                model = grouped_chain(N, L)
                mb = buffered_modes(N_DIFF, N)
                t_eig, modes = _best(lambda: model_modes(model, n_modes=mb))
                t_fd, (_, fd) = _best(lambda: finite_difference(model, which=which, n_modes=mb, rel_step=1e-6), 1)
                scale = float(np.max(np.abs(fd)))

                def err(d):
                    return float(np.max(np.abs(d[:, :N_DIFF] - fd)) / scale)

                dense = N <= DENSE_LIMIT
                routes: dict = {}
                t, (_, d) = _best(lambda: nelson(model, modes, which))
                ref = d
                routes["nelson"] = {"seconds": t, "error_vs_fd": err(d), "factorisations": N_DIFF,
                                    "factorisation": f"order {N} ({'dense' if dense else 'sparse'} LU), one per mode",
                                    "column_solves": N_DIFF * L}
                t, (_, d, terms) = _best(lambda: subspace_details(model, modes, which))
                routes["iterative"] = {"seconds": t, "error_vs_fd": err(d), "factorisations": 1,
                                       "series_terms": int(np.max(terms)),
                                       "column_solves": int(np.max(terms)) * N_DIFF * L,
                                       "difference_from_nelson": float(np.max(np.abs(d - ref)) / scale)}
                t, (_, d) = _best(lambda: modal_static_correction(model, modes, which))
                routes["truncated_modal_wang"] = {"seconds": t, "error_vs_fd": err(d), "factorisations": 1,
                                                  "column_solves": N_DIFF * L, "modes_used": mb}
                t, (_, d) = _best(lambda: modal(model, modes, which))
                routes["truncated_modal"] = {"seconds": t, "error_vs_fd": err(d), "factorisations": 0,
                                             "column_solves": 0, "modes_used": mb}
                if N <= FULL_MODAL_MAX:
                    t_all, all_modes = _best(lambda: model_modes(model, n_modes=N), 1)
                    t, (_, d) = _best(lambda: modal(model, all_modes, which))
                    routes["full_modal"] = {"seconds": t + t_all, "error_vs_fd": err(d), "factorisations": 0,
                                            "column_solves": 0, "modes_used": N, "eigensolution_seconds": t_all}
                for r in routes.values():
                    r["saving_vs_nelson"] = 1.0 - r["seconds"] / routes["nelson"]["seconds"]
                rows.append({"n_dofs": N, "n_parameters": L, "modes_computed": mb, "eigensolution_seconds": t_eig,
                             "finite_difference": {"seconds": t_fd, "eigensolutions": 2 * L, "rel_step": 1e-6},
                             "solver": "dense" if dense else "sparse", "routes": routes})
    dense_rows = [r for r in rows if r["solver"] == "dense"]
    big_dense = max(r["n_dofs"] for r in dense_rows)
    few, many = min(n_params), max(n_params)

    def at(N, L, route):
        return next(r["routes"][route]["saving_vs_nelson"] for r in rows if r["n_dofs"] == N and r["n_parameters"] == L)

    s_few, s_many = at(big_dense, few, "iterative"), at(big_dense, many, "iterative")
    w_few = at(big_dense, few, "truncated_modal_wang")
    sparse_rows = [r for r in rows if r["solver"] == "sparse"]
    sp_iter = [r["routes"]["iterative"]["saving_vs_nelson"] for r in sparse_rows]
    exact = max(max(r["routes"][k]["error_vs_fd"] for k in ("nelson", "iterative")) for r in rows)
    agree = bool(s_few >= 0.5 and s_many < s_few)
    explanation = (
        f"On the largest dense model ({big_dense} dofs) the iterative route saves {s_few:.0%} of Nelson's cost with "
        f"L = {few} parameters and {s_many:.0%} with L = {many} (paper, after Ting: of order 70 % for few parameters, "
        f"less as L grows){'' if agree else ' - not the paper' + chr(39) + 's pattern'}; Wang's truncated modal route saves "
        f"{w_few:.0%} but is approximate. The saving exists because Nelson factorises an order-N matrix once per "
        "differentiated mode and the iterative route once in all. On the sparse (banded) models, where each "
        "factorisation of the tridiagonal matrix costs O(N), Nelson is the cheaper "
        f"(iterative saving {', '.join(f'{v:.0%}' for v in sp_iter)}), because every term of the series is a solve "
        "with all m_d x L right-hand sides: 'very dependent upon the nature of the problem', as the paper "
        f"concludes. Nelson and the iterative route agree with finite differences to {exact:.0e} (the differences' "
        "own error); the truncated modal method without correction is off by "
        f"{max(r['routes']['truncated_modal']['error_vs_fd'] for r in rows):.0%}.")
    out = {
        "equations": "21 and the text after it (Fox & Kapoor, Nelson, Wang, Rudisill & Chu, Ting)",
        "description": f"grounded spring chains of N = {', '.join(map(str, sizes))} masses, springs in L = "
                       f"{' and '.join(map(str, n_params))} consecutive groups (the parameters); derivatives of the lowest "
                       f"{N_DIFF} mass-normalised modes with respect to every parameter; CPU seconds, best of {REPEATS}, "
                       "single-threaded BLAS; reference: central finite differences (2L eigensolutions, step 1e-6). "
                       "Routes: Nelson (one factorisation of order N per mode), the iterative route (deflated Neumann "
                       "series, one factorisation), Wang's truncated modal method with static correction, the "
                       f"truncated modal method alone (the {buffered_modes(N_DIFF, 10**6)} computed modes) and the full "
                       f"modal method (all N modes, up to N = {FULL_MODAL_MAX})",
        "rows": rows,
        "paper": {"iterative_saving_vs_nelson": PAPER_SAVING,
                  "statement": "for a small number of parameters ~70 % cheaper than Nelson; less efficient as the "
                               "number of parameters grows; Nelson needs the inversion of a matrix of order N - 1"},
        "saving_iterative_largest_dense": {"few_parameters": s_few, "many_parameters": s_many, "n_dofs": big_dense},
        "saving_wang_largest_dense": w_few,
        "saving_iterative_sparse": sp_iter,
        "agrees_with_paper": agree,
        "comparison": "agree" if agree else "differ-explained",
        "explanation": explanation,
        "summary": (f"iterative vs Nelson at {big_dense} dofs: saves {s_few:.0%} (L={few}) and {s_many:.0%} (L={many}) "
                    f"(paper ~70 %, less with more parameters); Wang saves {w_few:.0%}; on sparse banded chains Nelson "
                    f"wins ({', '.join(f'{v:.0%}' for v in sp_iter)}); exact routes vs FD {exact:.0e}"),
    }
    if figures:
        from ..plot.paper_figures import eigvec_cost_figure

        out["figure"] = eigvec_cost_figure(out_dir / "eigenvector_derivatives.png", rows)
    return out


SECTIONS = {"eigenvector_derivatives": eigenvector_derivatives}
