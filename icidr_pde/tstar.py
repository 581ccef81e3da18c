"""Failure time t*(N) of a shear-cell run: the study of fig 4(b).

For the ill-posed mu(I),Phi(I)-rheology the discrete system blows up once the grid
resolves the short waves that grow fastest; the stiff integrator then cannot meet its
tolerances (step-size underflow, the paper's 'non-convergent') and the run stops at
t*. :func:`sweep` computes t* for a range of N (in parallel, with a progress bar);
``icidr-pde tstar`` is its command line, also runnable as ``python -m icidr_pde.tstar``::

    icidr-pde tstar --rheology mui --scene shear --discretization cheb --N 21:201:2 \\
        --t-end 20 --json cheb.json --plot fig4b.png

The JSON maps N (as a string) to t* (null where the run reached t-end without failing).
Several discretizations at once (``--discretization fd cheb``) give one such mapping per
discretization, keyed by its name; ``--load label=file.json`` adds saved sweeps to the plot.

t* is a property of the discrete system and of the integrator (its tolerances, its
error control, even the round-off of the linear algebra), not of the PDE: the PDE is
ill-posed and has no failure time. See docs/chebyshev.md for the measurements.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import multiprocessing
import os
import re
import sys
import time
import warnings

import numpy as np

__all__ = ["failure_time", "sweep", "parse_range", "plot_tstar", "limit_blas_threads",
           "tolerance_study", "spectral_convergence", "compare_discretizations", "threshold",
           "add_parser", "main", "PAPER_TSTAR"]

#: the paper's failure time of mu(I),Phi(I), IC (3.16), Chebyshev N_z = 201 (fig 4)
PAPER_TSTAR = {"N": 201, "t_star": 0.01052}

_BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_blas_threads(n: int = 1) -> list[str]:
    """Limit the threads of the OpenBLAS libraries already loaded in this process.

    The dense LU of the Chebyshev Jacobian (3N x 3N) is ~25 times slower with OpenBLAS's
    default threads on a busy 2-core machine than with one thread. Returns the libraries
    that were limited (an empty list if none could be).
    """
    done = []
    try:
        with open("/proc/self/maps") as fh:
            libs = sorted(set(re.findall(r"(/\S*openblas\S*\.so\S*)", fh.read())))
    except OSError:
        return done
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for symbol in ("openblas_set_num_threads", "scipy_openblas_set_num_threads64_",
                       "scipy_openblas_set_num_threads", "openblas_set_num_threads64_"):
            if hasattr(lib, symbol):
                getattr(lib, symbol)(int(n))
                done.append(os.path.basename(path))
                break
    return done


def parse_range(text: str) -> list[int]:
    """'21:201:2' -> [21, 23, ..., 201] (start:stop:step, stop included); '47' -> [47];
    '21,47,201' -> [21, 47, 201]."""
    values: list[int] = []
    try:
        for part in str(text).split(","):
            part = part.strip()
            if ":" in part:
                fields = [int(x) for x in part.split(":")]
                if len(fields) == 2:
                    fields.append(1)
                if len(fields) != 3:
                    raise ValueError
                start, stop, step = fields
                if step < 1 or stop < start:
                    raise ValueError
                values.extend(range(start, stop + 1, step))
            else:
                values.append(int(part))
    except ValueError:
        raise ValueError(f"`N` must look like start:stop:step (stop included), a number or "
                         f"a comma-separated list; got {text!r}") from None
    if not values or min(values) < 4:
        raise ValueError(f"every N must be >= 4; got {text!r}")
    return sorted(set(values))


def failure_time(
    rheology: str = "mui",
    scene: str = "shear",
    discretization: str = "cheb",
    N: int = 201,
    t_end: float = 20.0,
    *,
    method: str = "BDF",
    rtol: float = 1e-6,
    atol: float = 1e-9,
    jacobian: str | None = None,
    backend: str = "numpy",
    max_wall: float | None = None,
    return_state: bool = False,
    times=None,
    **scene_params,
) -> dict:
    """Run one case without trackers and return t* (None if it reached `t_end`).

    Uses the same PDE classes, scenes and :class:`~icidr_pde.integrator.StiffSolver`
    (and so the same failure detection) as :func:`icidr_pde.api.run`; only the
    recording is left out. `backend` is that of the right-hand side: 'numpy' needs no
    compilation and is as fast as numba here (the cost is in the implicit solves).
    `max_wall` (seconds) abandons a run that takes longer (reported as 'timeout').

    Returns a dict with N, t_star, reason, wall_s, n_steps, n_rhs, n_jac, n_lu (and,
    with `return_state`, t_final, z and the final state (3, N) or the state at t*; with
    `times`, snapshot_times and snapshots (n, 3, N) at those reached).
    """
    from .api import make_pde
    from .integrator import SimulationFailed, StiffSolver
    from .scenes import get_scene

    scene_obj = get_scene(scene, **scene_params)
    pde = make_pde(rheology, discretization)
    pde.material.check_phi(scene_obj.phi0, "phi0")
    grid = pde.make_grid(N, scene_obj.H)
    state = pde.make_state(grid, *scene_obj.initial_condition(pde.nodes(grid)))
    solver = StiffSolver(pde, method=method, rtol=rtol, atol=atol, jacobian=jacobian,
                         backend=backend)
    t_end = float(t_end)
    snap = sorted({float(t) for t in times}) if times is not None else []
    if any(not 0 <= t <= t_end for t in snap):
        raise ValueError(f"`times` must lie in [0, t_end]; got {times}")
    # the persistent integrator is advanced window by window: snapshots and the wall clock
    # are checked between windows; the windows do not affect its steps
    windows = np.unique(np.concatenate((np.geomspace(min(1e-4, t_end / 10), t_end, 200),
                                        snap, [t_end])))
    windows = windows[windows > 0]
    snapshots, snapshot_times = [], []
    if snap and snap[0] == 0:
        snapshots.append(state.data.copy())
        snapshot_times.append(0.0)
    t_star, reason, t_final = None, "reached t_end", t_end
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        stepper = solver.make_stepper(state)
        t = 0.0
        try:
            for t_next in windows:
                t = stepper(state, t, float(t_next))
                if t in snap:
                    snapshots.append(state.data.copy())
                    snapshot_times.append(t)
                if max_wall is not None and time.perf_counter() - start > max_wall:
                    reason, t_final = f"timeout after {max_wall} s wall at t = {t:.6g}", t
                    break
            final = state.data.copy()
        except SimulationFailed as failure:
            t_star, reason = float(failure.t_star), failure.reason
            t_final, final = t_star, failure.state_data
    stats = solver.stats
    out = {"N": int(N), "t_star": t_star, "reason": reason,
           "wall_s": time.perf_counter() - start, "n_steps": _int(stats.n_steps),
           "n_rhs": _int(stats.n_rhs), "n_jac": _int(stats.n_jac), "n_lu": _int(stats.n_lu)}
    if return_state:
        out.update(t_final=t_final, z=pde.nodes(grid), state=np.array(final))
    if times is not None:
        out.update(z=pde.nodes(grid), snapshot_times=snapshot_times,
                   snapshots=np.array(snapshots))
    return out


def _int(value):
    return None if value is None else int(value)


def _worker_init() -> None:
    limit_blas_threads(1)
    warnings.simplefilter("ignore")


def _run_case(kwargs: dict) -> tuple[str, dict]:
    return kwargs["discretization"], failure_time(**kwargs)


def sweep(
    Ns,
    discretizations=("cheb",),
    *,
    jobs: int = 2,
    progress: bool = True,
    **kwargs,
) -> dict[str, dict[int, dict]]:
    """t* for every N and discretization: {discretization: {N: failure_time(...) dict}}.

    Runs in `jobs` worker processes (spawned, with one BLAS thread each; jobs=1 runs
    in this process) with a tqdm progress bar. `kwargs` go to :func:`failure_time`.
    """
    Ns = [int(n) for n in Ns]
    cases = [dict(kwargs, discretization=d, N=n) for d in discretizations
             for n in sorted(Ns, reverse=True)]  # large N first: the slowest runs
    out: dict[str, dict[int, dict]] = {d: {} for d in discretizations}
    from tqdm.auto import tqdm

    bar = tqdm(total=len(cases), desc="t*(N)", disable=not progress, file=sys.stderr)
    if jobs <= 1:
        _worker_init()
        results = map(_run_case, cases)
        pool = None
    else:
        for var in _BLAS_ENV:  # inherited by the spawned workers before numpy loads
            os.environ.setdefault(var, "1")
        pool = multiprocessing.get_context("spawn").Pool(jobs, initializer=_worker_init)
        results = pool.imap_unordered(_run_case, cases)
    try:
        for disc, res in results:
            out[disc][res["N"]] = res
            t = "none" if res["t_star"] is None else f"{res['t_star']:.5g}"
            bar.set_postfix_str(f"{disc} N={res['N']} t*={t}")
            bar.update()
    finally:
        bar.close()
        if pool is not None:
            pool.close()
            pool.join()
    return {d: dict(sorted(v.items())) for d, v in out.items()}


def tstar_mapping(results: dict[int, dict]) -> dict[str, float | None]:
    """{'N': t*} with N as strings (the JSON form)."""
    return {str(n): r["t_star"] for n, r in sorted(results.items())}


def threshold(mapping: dict) -> int | None:
    """Smallest N such that every N >= it in `mapping` failed (None if the largest did not)."""
    items = sorted((int(n), t) for n, t in mapping.items())
    thr = None
    for n, t in reversed(items):
        if t is None:
            break
        thr = n
    return thr


def plot_tstar(curves: dict[str, dict], path: str, *, title: str | None = None,
               t_end: float | None = None, paper: bool = True) -> None:
    """Fig 4(b): t* against N, one curve per label; runs without failure marked at the bottom."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    styles = {"cheb": dict(color="C3", marker="o", ls="-"), "fd": dict(color="C0", marker="s", ls="--")}
    names = {"cheb": "Chebyshev", "fd": "finite differences"}
    all_t = [t for m in curves.values() for t in m.values() if t is not None]
    floor = min(all_t) / 2 if all_t else 1e-3
    for k, (label, mapping) in enumerate(curves.items()):
        items = sorted((int(n), t) for n, t in mapping.items())
        style = styles.get(label, dict(color=f"C{k + 4}", marker="^", ls="-"))
        n_f = [n for n, t in items if t is not None]
        t_f = [t for n, t in items if t is not None]
        thr = threshold(mapping)
        extra = f", all fail for N >= {thr}" if thr is not None else ""
        ax.plot(n_f, t_f, ms=3, lw=1, label=f"{names.get(label, label)}{extra}", **style)
        n_ok = [n for n, t in items if t is None]
        if n_ok:
            ax.plot(n_ok, [floor * 1.15**k] * len(n_ok), ls="none", marker="v", mfc="none",
                    color=style["color"], ms=5,
                    label=f"{names.get(label, label)}: no failure" + (f" by t = {t_end:g}" if t_end else ""))
    if paper:
        ax.plot([PAPER_TSTAR["N"]], [PAPER_TSTAR["t_star"]], marker="*", ms=13, ls="none",
                color="k", label=f"paper: t* = {PAPER_TSTAR['t_star']} (Chebyshev N = 201)")
    ax.set_yscale("log")
    ax.set_xlabel(r"$N_z$")
    ax.set_ylabel(r"$\hat t_*$")
    ax.set_title(title or r"$\mu(I),\Phi(I)$, IC (3.16): failure time (fig 4b)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


# --- studies of the discrete system --------------------------------------------------


def tolerance_study(
    N: int = 201,
    discretizations=("cheb", "fd"),
    tolerances=((1e-3, 1e-6), (1e-4, 1e-6), (1e-6, 1e-6), (1e-6, 1e-9), (1e-8, 1e-9),
                (1e-8, 1e-12), (1e-10, 1e-12)),
    methods=("BDF", "Radau", "LSODA", "CVODE"),
    method_tolerances=((1e-6, 1e-9), (1e-3, 1e-6)),
    jacobians=None,
    *,
    t_end: float = 0.2,
    jobs: int = 2,
    progress: bool = True,
    **kwargs,
) -> list[dict]:
    """t* of mu(I), IC (3.16) at one N for BDF at several (rtol, atol), and for each method
    at `method_tolerances`. Returns one row per run (failure_time's dict plus the settings).

    `jacobians` maps (discretization, method) to the Jacobian mode; by default the
    analytic one, except LSODA: dense differences for 'cheb' ('none') and banded
    differences for 'fd' ('banded-fd'), and CVODE on 'fd' ('banded-fd').
    """
    from .integrator import METHODS

    table = {("cheb", "LSODA"): "none", ("fd", "LSODA"): "banded-fd", ("fd", "CVODE"): "banded-fd"}
    table.update(jacobians or {})
    methods = [m for m in methods if m in METHODS]
    cases = []
    for disc in discretizations:
        for rtol, atol in tolerances:
            cases.append(dict(kwargs, discretization=disc, N=N, method="BDF", rtol=rtol, atol=atol))
        for method in methods:
            for rtol, atol in method_tolerances:
                if method == "BDF" and (rtol, atol) in tolerances:
                    continue
                cases.append(dict(kwargs, discretization=disc, N=N, method=method, rtol=rtol,
                                  atol=atol, jacobian=table.get((disc, method), "analytic")))
    for case in cases:
        case.setdefault("rheology", "mui")
        case.setdefault("scene", "shear")
        case.setdefault("t_end", t_end)
    return _run_cases(cases, jobs, progress)


def _run_row(case: dict) -> dict:
    res = failure_time(**case)
    defaults = {"method": "BDF", "rtol": 1e-6, "atol": 1e-9}
    return {**{k: case.get(k, defaults.get(k)) for k in ("discretization", "N", "method", "rtol",
                                                          "atol")},
            "jacobian": case.get("jacobian") or "default", "backend": case.get("backend", "numpy"),
            **{k: v for k, v in res.items() if k != "N"}}


def _run_cases(cases: list[dict], jobs: int, progress: bool) -> list[dict]:
    from tqdm.auto import tqdm

    rows = []
    with tqdm(total=len(cases), disable=not progress, file=sys.stderr) as bar:
        if jobs <= 1:
            _worker_init()
            for case in cases:
                rows.append(_run_row(case))
                bar.update()
        else:
            for var in _BLAS_ENV:
                os.environ.setdefault(var, "1")
            with multiprocessing.get_context("spawn").Pool(jobs, initializer=_worker_init) as pool:
                for row in pool.imap(_run_row, cases):
                    rows.append(row)
                    bar.update()
    return rows


def spectral_convergence(
    Ns=tuple(range(9, 62, 4)),
    N_ref: int = 161,
    *,
    rheology: str = "icidr",
    scene: str = "sine",
    t: float = 5.0,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    jobs: int = 2,
    progress: bool = True,
) -> dict:
    """Error of the Chebyshev solution at time `t` against a fine Chebyshev reference.

    The error of N is max over (phi, u, w) and over the N nodes of |f_N - I f_ref|, where
    I interpolates the reference (barycentric, spectrally accurate). Returns
    {"N": [...], "error": [...], "N_ref": N_ref, "rate": r, "fit_N": [...]} where the error
    behaves like C exp(-r N) on the points above the tolerance floor used for the fit.
    """
    from .chebyshev import interpolate

    Ns = sorted(int(n) for n in Ns)
    base = dict(rheology=rheology, scene=scene, discretization="cheb", t_end=t, rtol=rtol,
                atol=atol, return_state=True)
    cases = [dict(base, N=n) for n in [N_ref] + Ns]
    rows = _run_cases(cases, jobs, progress)
    ref = rows[0]
    if ref["t_star"] is not None:
        raise RuntimeError(f"reference run failed at t* = {ref['t_star']}")
    H = float(ref["z"][-1])
    errors = []
    for row in rows[1:]:
        if row["t_star"] is not None:
            errors.append(float("nan"))
            continue
        ref_at_nodes = interpolate(ref["state"], row["z"], H)
        errors.append(float(np.max(np.abs(row["state"] - ref_at_nodes))))
    err = np.array(errors)
    floor = 100 * rtol * np.max(np.abs(ref["state"][1:]))
    fit = np.isfinite(err) & (err > floor)
    rate = float("nan")
    if fit.sum() >= 2:
        rate = float(-np.polyfit(np.array(Ns)[fit], np.log(err[fit]), 1)[0])
    return {"N": Ns, "error": errors, "N_ref": N_ref, "t": t, "rtol": rtol, "atol": atol,
            "rate": rate, "fit_N": [int(n) for n in np.array(Ns)[fit]], "floor": floor,
            "wall_s": [r["wall_s"] for r in rows[1:]]}


def compare_discretizations(
    scene: str = "shear",
    times=None,
    cases=(("cheb", 47), ("cheb", 201), ("fd", 201)),
    *,
    rheology: str = "icidr",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    jobs: int = 2,
    progress: bool = True,
) -> dict:
    """w(z, t) of several discretizations at the times of figs 6, 7, compared on the
    reference nodes of the first Chebyshev case with the most points.

    Returns {"times": [0, ...], "max_w": [...], "diff": {label: [...]}, "failed": {...}}
    where diff is max |w - w_ref| over the nodes of each case (cell centres for 'fd'), the
    reference being interpolated there spectrally (as the figures draw the coarse runs as
    circles at their nodes over the reference line), and max_w the reference amplitude
    max_z |w_ref| (so max_w[0] is that of the initial condition).
    """
    from .chebyshev import interpolate
    from .scenes import get_scene

    scene_obj = get_scene(scene)
    if times is None:
        times = list(scene_obj.default_times)
    times = sorted({0.0} | {float(t) for t in times})
    runs = [dict(rheology=rheology, scene=scene, discretization=d, N=n, t_end=times[-1],
                 rtol=rtol, atol=atol, times=times) for d, n in cases]
    rows = _run_cases(runs, jobs, progress)
    labels = [f"{d}{n}" for d, n in cases]
    by = dict(zip(labels, rows))
    ref_label = max((lab for lab, (d, n) in zip(labels, cases) if d == "cheb"),
                    key=lambda lab: int(lab[4:]))
    H = scene_obj.H
    out = {"times": times, "reference": ref_label, "max_w": [], "diff": {},
           "failed": {lab: by[lab]["t_star"] for lab in labels if by[lab]["t_star"] is not None}}
    ref = by[ref_label]
    n_ref = len(ref["snapshots"])
    for k in range(len(times)):
        out["max_w"].append(float(np.max(np.abs(ref["snapshots"][k][2]))) if k < n_ref
                            else float("nan"))
    for label in labels:
        if label == ref_label:
            continue
        row, diffs = by[label], []
        for k in range(len(times)):
            if k >= len(row["snapshots"]) or k >= n_ref:
                diffs.append(float("nan"))
                continue
            w_ref = interpolate(ref["snapshots"][k][2], row["z"], H)
            diffs.append(float(np.max(np.abs(row["snapshots"][k][2] - w_ref))))
        out["diff"][label] = diffs
    return out


# --- command line -------------------------------------------------------------------


def _load_spec(text: str) -> tuple[str, str]:
    if "=" in text:
        label, path = text.split("=", 1)
    else:
        path = text
        label = os.path.splitext(os.path.basename(path))[0]
    return label, path


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``tstar`` subcommand to an argparse subparsers object."""
    from .integrator import JACOBIAN_MODES, METHODS
    from .rheology import RHEOLOGIES

    p = subparsers.add_parser(
        "tstar", help="failure time t*(N) sweep (fig 4b)",
        description="Sweep N and record the failure time t* (null: no failure by --t-end).")
    p.add_argument("--rheology", choices=sorted(RHEOLOGIES), default="mui")
    p.add_argument("--scene", choices=["shear", "sine"], default="shear")
    p.add_argument("--discretization", nargs="+", choices=["fd", "cheb"], default=["fd"],
                   help="one or both of fd (default) and cheb")
    p.add_argument("--N", default=None,
                   help="start:stop:step with stop included, e.g. 21:201:2 (default), "
                        "or a comma-separated list")
    p.add_argument("--t-end", type=float, default=20.0)
    p.add_argument("--method", choices=sorted(METHODS), default="BDF")
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--atol", type=float, default=1e-9)
    p.add_argument("--jacobian", choices=JACOBIAN_MODES, default=None,
                   help="default: the method's own (analytic for BDF and Radau)")
    p.add_argument("--backend", choices=["numpy", "numba"], default="numpy",
                   help="right-hand side backend (numpy: no compile time, default)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--json", default=None, help="write {N: t*} here")
    p.add_argument("--plot", default=None, help="write the t*(N) plot (fig 4b) here")
    p.add_argument("--load", action="append", default=[], metavar="LABEL=FILE",
                   help="add a saved {N: t*} JSON to the plot (repeatable); "
                        "without --N nothing is run")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_tstar)
    return p


def cmd_tstar(args) -> int:
    if args.jobs < 1:
        raise ValueError(f"`--jobs` must be >= 1; got {args.jobs}")
    curves: dict[str, dict] = {}
    for spec in args.load:
        label, path = _load_spec(spec)
        with open(path) as fh:
            curves[label] = json.load(fh)
    if args.N is None and args.load:
        results = {}
    else:
        Ns = parse_range(args.N or "21:201:2")
        from .integrator import check_tolerances

        check_tolerances(args.rtol, args.atol)
        if not (np.isfinite(args.t_end) and args.t_end > 0):
            raise ValueError(f"`--t-end` must be > 0; got {args.t_end}")
        results = sweep(Ns, tuple(dict.fromkeys(args.discretization)), jobs=args.jobs,
                        progress=not args.no_progress, rheology=args.rheology,
                        scene=args.scene, t_end=args.t_end, method=args.method,
                        rtol=args.rtol, atol=args.atol, jacobian=args.jacobian,
                        backend=args.backend)
    mappings = {d: tstar_mapping(r) for d, r in results.items()}
    for disc, mapping in mappings.items():
        curves[disc] = mapping
        failed = [(int(n), t) for n, t in mapping.items() if t is not None]
        thr = threshold(mapping)
        print(f"{disc}: {len(failed)}/{len(mapping)} runs failed; "
              f"every N >= {thr} fails" if thr is not None else
              f"{disc}: {len(failed)}/{len(mapping)} runs failed; the largest N did not fail")
        for n, t in sorted((int(n), t) for n, t in mapping.items()):
            print(f"  N={n:4d}  t*={'null' if t is None else f'{t:.6g}'}")
    if args.json and mappings:
        payload = next(iter(mappings.values())) if len(mappings) == 1 else mappings
        with open(args.json, "w") as fh:
            json.dump(payload, fh, indent=1)
        print(f"t*(N) written to {args.json}")
    if args.plot:
        if not curves:
            raise ValueError("nothing to plot: give --N or --load")
        plot_tstar(curves, args.plot, t_end=args.t_end,
                   paper=args.rheology == "mui" and args.scene == "shear")
        print(f"plot written to {args.plot}")
    return 0


def main(argv=None) -> int:
    """`python -m icidr_pde.tstar ...`: the same as `icidr-pde tstar ...`."""
    from .cli import main as cli_main

    argv = list(sys.argv[1:] if argv is None else argv)
    return cli_main(argv if argv[:1] == ["tstar"] else ["tstar"] + argv)


if __name__ == "__main__":
    sys.exit(main())
