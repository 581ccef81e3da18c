"""Work-precision study: error against a converged reference versus wall time.

    python benchmarks/work_precision.py            # full study (about 15 min on 2 cores)
    python benchmarks/work_precision.py --quick    # subset (a few minutes)

Every knob a user turns: integrator (scipy BDF/Radau/LSODA, SUNDIALS CVODE, py-pde's
adaptive explicit Runge-Kutta), Jacobian mode, rtol, grid N, discretization. Baselines in
the same run: (a) solve_ivp(method="BDF") with no Jacobian and no sparsity, (b) py-pde's
stock `scipy` solver with a tracker every 0.1, (c) our persistent scipy BDF with its best
(analytic) Jacobian. Errors: max|w|(t) series error relative to max|w| (`series`) and the
largest relative L2 error of (phi, u, w) profiles (`profiles`); see icidr_pde/studies/references.py.
Timings are medians of `--repeats` runs, numba compile time is reported separately.
Writes data/benchmarks/work_precision[_quick].json, docs/wp_<case>.png and a markdown table.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import statistics
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from icidr_pde import build_case, run  # noqa: E402
from icidr_pde.studies.references import (  # noqa: E402
    CASES, case_run, profile_error, reference, series_error, series_times)

from provenance import write_json  # noqa: E402


class _Outcome:
    """The parts of a Result the error measures read, for runs made outside run()."""

    def __init__(self, z, times, fields, scene_params):
        self.z, self.times = z, np.asarray(times)
        self.phi, self.u, self.w = (np.array([f[k] for f in fields]) for k in range(3))
        self.scene_params = scene_params


def _state(case, N):
    spec = CASES[case]
    built = build_case(spec["rheology"], spec["scene"], "fd", N)
    return built.pde, built.scene, built.grid, built.state


def run_pypde(case, N, rtol, solver_name, tracker_every=None):
    """py-pde's own solvers: explicit adaptive RK (numba) or the stock scipy solver."""
    from pde import MemoryStorage
    from pde.trackers.trackers import CallbackTracker

    spec = CASES[case]
    pde, scene, grid, state = _state(case, N)
    storage = MemoryStorage()
    trackers = [storage.tracker(interrupts=list(series_times(spec["t_end"])))]
    if tracker_every:
        trackers.append(CallbackTracker(lambda s, t: None, interrupts=tracker_every))
    if solver_name == "explicit-rk":
        kwargs = dict(solver="explicit", scheme="runge-kutta", adaptive=True, tolerance=rtol,
                      backend="numba")
    else:
        kwargs = dict(solver="scipy", backend="numba", method="BDF", rtol=rtol, atol=rtol * 1e-3,
                      jac_sparsity=pde.jacobian_sparsity(state))
    pde.make_pde_rhs(state, backend="numba")
    start = time.perf_counter()
    pde.solve(state, t_range=spec["t_end"], tracker=trackers, **kwargs)
    wall = time.perf_counter() - start
    return wall, _Outcome(pde.nodes(grid), storage.times, storage.data, scene.parameters())


def run_solve_ivp(case, N, rtol):
    """Baseline (a): what a user writes first: solve_ivp BDF, no Jacobian, no sparsity."""
    from scipy.integrate import solve_ivp

    spec = CASES[case]
    pde, scene, grid, state = _state(case, N)
    rhs = pde.make_pde_rhs(state, backend="numba")
    shape = state.data.shape
    start = time.perf_counter()
    sol = solve_ivp(lambda t, y: rhs(y.reshape(shape), t).ravel(), (0, spec["t_end"]),
                    state.data.ravel(), method="BDF", t_eval=series_times(spec["t_end"]),
                    rtol=rtol, atol=rtol * 1e-3)
    wall = time.perf_counter() - start
    return wall, _Outcome(pde.nodes(grid), sol.t, list(sol.y.T.reshape(-1, *shape)), scene.parameters())


def run_ours(case, N, rtol, method, jacobian, discretization="fd"):
    res = case_run(case, N, rtol, rtol * 1e-3, method, discretization, jacobian)
    if res.blew_up:
        raise RuntimeError(res.reason)
    return res.wall_s, res, res.compile_s


def measure(label, family, fn, ref, repeats, **knobs):
    walls, compile_s, outcome = [], None, None
    for i in range(repeats):
        if i and walls[0] > 5.0:  # a slow configuration: one timing is enough to rank it
            break
        try:
            out = fn()
        except Exception as err:  # a configuration that cannot run is reported, not hidden
            return dict(label=label, family=family, **knobs, error=str(err)[:200])
        walls.append(out[0])
        outcome = out[1]
        if len(out) > 2 and compile_s is None:
            compile_s = out[2]
    return dict(label=label, family=family, **knobs, wall_s=statistics.median(walls),
                wall_all=walls, compile_s=compile_s, series=series_error(outcome, ref),
                profiles=profile_error(outcome, ref))


def configurations(quick: bool):
    rtols = [1e-3, 1e-5, 1e-7] if quick else [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]
    Ns = [51, 201, 801] if quick else [25, 51, 101, 201, 401, 801]
    configs = []
    for method, jac in [("BDF", "analytic"), ("BDF", "sparse-fd"), ("Radau", "analytic"),
                        ("LSODA", "banded-fd"), ("CVODE", "banded-fd")]:
        for rtol in rtols:
            family = "(c) BDF analytic J [baseline c]" if (method, jac) == ("BDF", "analytic") else f"{method} {jac}"
            configs.append((family, dict(N=201, rtol=rtol, method=method, jacobian=jac),
                            lambda c, N=201, r=rtol, m=method, j=jac: run_ours(c, N, r, m, j)))
    for rtol in rtols[:-1] if quick else rtols[:5]:
        configs.append(("py-pde explicit RK (numba)", dict(N=201, rtol=rtol, method="explicit-rk"),
                        lambda c, r=rtol: run_pypde(c, 201, r, "explicit-rk")))
    for rtol in ([1e-3, 1e-5] if quick else [1e-3, 1e-4, 1e-5, 1e-6]):
        configs.append(("(a) solve_ivp BDF, no Jacobian", dict(N=201, rtol=rtol, method="solve_ivp-BDF"),
                        lambda c, r=rtol: run_solve_ivp(c, 201, r)))
        configs.append(("(b) py-pde scipy solver, tracker 0.1", dict(N=201, rtol=rtol, method="pypde-scipy"),
                        lambda c, r=rtol: run_pypde(c, 201, r, "scipy", tracker_every=0.1)))
    for N in Ns:
        configs.append(("fd grid, CVODE rtol 1e-8", dict(N=N, rtol=1e-8, method="CVODE", jacobian="banded-fd"),
                        lambda c, N=N: run_ours(c, N, 1e-8, "CVODE", "banded-fd")))
    from icidr_pde.api import DISCRETIZATIONS

    if "cheb" in DISCRETIZATIONS:
        for N in ([17, 33, 65] if quick else [17, 25, 33, 49, 65, 97]):
            configs.append(("cheb grid, BDF analytic rtol 1e-8",
                            dict(N=N, rtol=1e-8, method="BDF", jacobian="analytic", discretization="cheb"),
                            lambda c, N=N: run_ours(c, N, 1e-8, "BDF", "analytic", "cheb")))
    return configs


def tstar_study(discretization: str, quick: bool, repeats: int) -> dict:
    """Case (iii): error of the failure time t* (mu(I), shear, N = 201) against the
    tight-tolerance reference, and its cost, for each integrator and rtol."""
    from icidr_pde.studies.references import reference_tstar

    ref = reference_tstar(discretization)
    rtols = [1e-3, 1e-6] if quick else [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
    methods = [("BDF", "analytic"), ("Radau", "analytic"), ("CVODE", None)]
    if discretization == "fd":
        methods.append(("LSODA", "banded-fd"))
    rows = []
    for method, jacobian in methods:
        for rtol in rtols:
            walls, res = [], None
            for _ in range(repeats):
                res = run("mui", "shear", 201, 1.0, [0.0], discretization=discretization, method=method,
                          jacobian=jacobian, rtol=rtol, atol=rtol * 1e-3)
                walls.append(res.wall_s)
            err = abs(res.t_star - ref["t_star"]) / ref["t_star"] if res.blew_up else float("inf")
            rows.append(dict(family=f"{method} {res.jacobian}", method=method, rtol=rtol,
                             t_star=res.t_star, reason=res.reason, tstar_error=err,
                             wall_s=statistics.median(walls), compile_s=res.compile_s))
    return {"reference": ref, "rows": rows}


def best_at(rows, family_filter, target):
    ok = [r for r in rows if family_filter(r) and "error" not in r and r["series"] <= target]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


def plot(case, rows, path):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5), sharey=True)
    families = sorted({r["family"] for r in rows if "error" not in r})
    for ax, key in zip(axes, ("series", "profiles")):
        for family in families:
            pts = sorted((r[key], r["wall_s"]) for r in rows if r["family"] == family and "error" not in r)
            if pts:
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=family, ms=4)
        ax.set_xlabel(f"error ({'max|w|(t) series' if key == 'series' else 'profiles, rel. L2'})")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("wall time [s] (median)")
    axes[1].legend(fontsize=7)
    fig.suptitle(f"work-precision, case {case}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--cases", nargs="*", default=list(CASES),
                        help="iCIDR cases (i), (ii); none: only the t* case (iii)")
    parser.add_argument("--target", type=float, default=1e-3, help="max|w| error for the speed-up ratio")
    parser.add_argument("--tstar", nargs="*", default=["fd", "cheb"],
                        help="discretizations for case (iii), the t* of mu(I) at N = 201")
    args = parser.parse_args(argv)
    repeats = args.repeats or (1 if args.quick else 3)
    from tqdm import tqdm

    out = {"quick": args.quick, "repeats": repeats, "cases": {}}
    for case in args.cases:
        ref = reference(case)
        rows = []
        configs = configurations(args.quick)
        for family, knobs, fn in tqdm(configs, desc=case):
            rows.append(measure(f"{family} {knobs}", family, lambda: fn(case), ref, repeats, **knobs))
        base_c = best_at(rows, lambda r: r["family"].startswith("(c)"), args.target)
        fast = best_at(rows, lambda r: r.get("N") == 201 and not r["family"].startswith("("), args.target)
        summary = {"target": args.target, "baseline_c": base_c, "fastest": fast,
                   "speedup_vs_c": (base_c["wall_s"] / fast["wall_s"]) if base_c and fast else None}
        out["cases"][case] = {"rows": rows, "summary": summary, "reference": ref["meta"]}
        plot(case, rows, ROOT / "docs" / f"wp_{case}{'_quick' if args.quick else ''}.png")
        print(f"\n{case}: fastest at max|w| error <= {args.target:g}: "
              f"{fast and fast['label']} {fast and round(fast['wall_s'], 4)} s; baseline (c): "
              f"{base_c and base_c['label']} {base_c and round(base_c['wall_s'], 4)} s; "
              f"ratio {summary['speedup_vs_c'] and round(summary['speedup_vs_c'], 1)}")
    out["tstar"] = {}
    for discretization in args.tstar:
        try:
            out["tstar"][discretization] = tstar_study(discretization, args.quick, repeats)
        except ValueError as err:  # e.g. the Chebyshev discretization is not installed
            out["tstar"][discretization] = {"error": str(err)}
    suffix = ("_quick" if args.quick else "") + ("" if args.cases else "_tstar")
    path = ROOT / "data" / "benchmarks" / f"work_precision{suffix}.json"
    if path.exists() and args.cases and set(args.cases) != set(CASES):  # partial rerun: merge
        previous = json.loads(path.read_text())
        out["cases"] = {**previous.get("cases", {}), **out["cases"]}
        out["tstar"] = out["tstar"] or previous.get("tstar", {})
    write_json(path, out, default=float)
    table = markdown_table(out)
    print(table)
    doc = ROOT / "docs" / f"work_precision_tables{suffix}.md"
    doc.write_text("# Work-precision tables\n\nGenerated by `python benchmarks/work_precision.py"
                   f"{' --quick' if args.quick else ''}` (repeats: {repeats}; wall time excludes "
                   "numba compilation, reported apart).\n" + summary_lines(out) + table + "\n")
    print(f"written {path}")


def summary_lines(out) -> str:
    lines = []
    for case, data in out["cases"].items():
        s = data["summary"]
        if s["fastest"] and s["baseline_c"]:
            lines.append(f"\n* **{case}**, max|w| error <= {s['target']:g} at N = 201: fastest "
                         f"{s['fastest']['family']} rtol {s['fastest']['rtol']:g} "
                         f"({s['fastest']['wall_s']:.3f} s, error {s['fastest']['series']:.1e}); "
                         f"baseline (c) {s['baseline_c']['family']} rtol {s['baseline_c']['rtol']:g} "
                         f"({s['baseline_c']['wall_s']:.3f} s, error {s['baseline_c']['series']:.1e}): "
                         f"**{s['speedup_vs_c']:.1f}x**")
        else:
            lines.append(f"\n* **{case}**: no configuration at N = 201 reached max|w| error {s['target']:g}")
    return "\n".join(lines) + "\n"


def markdown_table(out) -> str:
    lines = []
    for disc, data in out.get("tstar", {}).items():
        if "rows" not in data:
            continue
        lines += [f"\n#### mu(I) shear t* at N = 201, {disc} (reference t* = {data['reference']['t_star']:.6g})\n",
                  "| integrator | rtol | t* | rel. error of t* | wall [s] |", "| --- | --- | --- | --- | --- |"]
        for r in data["rows"]:
            lines.append(f"| {r['family']} | {r['rtol']:g} | {r['t_star']:.6g} | {r['tstar_error']:.1e} | {r['wall_s']:.3f} |")
    for case, data in out["cases"].items():
        lines += [f"\n#### {case}\n", "| configuration | N | rtol | wall [s] | compile [s] | max\\|w\\| error | profile error |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]
        for r in data["rows"]:
            if "error" in r:
                lines.append(f"| {r['family']} | {r.get('N')} | {r.get('rtol')} | failed: {r['error'][:60]} | | | |")
                continue
            comp = f"{r['compile_s']:.1f}" if r.get("compile_s") else "-"
            lines.append(f"| {r['family']} | {r['N']} | {r['rtol']:g} | {r['wall_s']:.3f} | {comp} | "
                         f"{r['series']:.1e} | {r['profiles']:.1e} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
