"""mu(I),Phi(I) bump2d failure time t* against the linear solver, Krylov tolerance,
preconditioner and time integrator (issue 23, the 128^2 question).

Each case is one ``icidr_pde.api.run`` of mu(I) on bump2d (N^2 cells, t_end 0.4, the studies'
rtol 1e-7, atol 1e-10 unless the case says otherwise). eps_lin is CVODE's Krylov tolerance
factor (``CVodeSetEpsLin``; GMRES stops at ||r|| < eps_lin * (Newton tolerance)), set by the
integrator to :data:`icidr_pde.engines.sundae.KRYLOV_EPS_LIN` (5e-5 since this study; the case
'gmres' is SUNDIALS' default 0.05). ``CVodeSetNonlinConvCoef`` (the Newton convergence test,
default 0.1) is set through SUNDIALS' own C setter on the run's CVODE memory
(:mod:`icidr_pde.engines.cvode_counters` finds it). ``krylov_dim`` is
scikit-sundae's option (the integrator's 20). 'line' forces the z-line preconditioner of
thin cells (:meth:`ShearCell2DPDE.line_pattern`) on the square cell; 'gmres-amg-epslin-5e-5' is GMRES
preconditioned by algebraic multigrid (``jacobian='amg'``, :mod:`icidr_pde.engines.linear.amg_hierarchy`).

    nice -n 5 python benchmarks/tstar2d_solvers.py --sizes 64 128 [--advection central] [--cases ...]

Appends one JSON line per case to data/benchmarks/tstar2d_solvers.jsonl.
"""

import argparse
import ctypes
import json
import pathlib
import sys
import time

import icidr_pde.engines.cvode_counters as cvode_counters
import icidr_pde.cells.plane2d.core as plane2d_core
import icidr_pde.engines.sundae as integrator
import sksundae.cvode

from provenance import append_jsonl

#: name: (run keywords, CVODE extras)
CASES = {
    "gmres": (dict(method="CVODE", jacobian="krylov"), {}),
    "gmres-epslin-5e-3": (dict(method="CVODE", jacobian="krylov"), {"eps_lin": 5e-3}),
    "gmres-epslin-5e-4": (dict(method="CVODE", jacobian="krylov"), {"eps_lin": 5e-4}),
    "gmres-epslin-5e-5": (dict(method="CVODE", jacobian="krylov"), {"eps_lin": 5e-5}),
    "gmres-epslin-5e-6": (dict(method="CVODE", jacobian="krylov"), {"eps_lin": 5e-6}),
    "gmres-dim5": (dict(method="CVODE", jacobian="krylov"), {"krylov_dim": 5}),
    "gmres-dim50": (dict(method="CVODE", jacobian="krylov"), {"krylov_dim": 50}),
    "gmres-newton-1e-3": (dict(method="CVODE", jacobian="krylov"), {"nonlin_conv": 1e-3}),
    "gmres-line": (dict(method="CVODE", jacobian="krylov"), {"line": True}),
    "gmres-line-epslin-5e-4": (dict(method="CVODE", jacobian="krylov"), {"line": True, "eps_lin": 5e-4}),
    "gmres-rtol-1e-9": (dict(method="CVODE", jacobian="krylov", rtol=1e-9, atol=1e-12), {}),
    "gmres-epslin-5e-5-rtol-1e-9": (dict(method="CVODE", jacobian="krylov", rtol=1e-9, atol=1e-12), {"eps_lin": 5e-5}),
    "gmres-epslin-5e-5-rtol-1e-8": (dict(method="CVODE", jacobian="krylov", rtol=1e-8, atol=1e-11), {"eps_lin": 5e-5}),
    "gmres-amg-epslin-5e-5": (dict(method="CVODE", jacobian="amg"), {"eps_lin": 5e-5}),
    "gmres-amg-epslin-5e-5-rtol-1e-8": (dict(method="CVODE", jacobian="amg", rtol=1e-8, atol=1e-11), {"eps_lin": 5e-5}),
    "gmres-fourier-epslin-5e-5": (dict(method="CVODE", jacobian="fourier"), {"eps_lin": 5e-5}),
    "gmres-fourier-epslin-5e-7": (dict(method="CVODE", jacobian="fourier"), {"eps_lin": 5e-7}),
    "gmres-fourier-epslin-0.05": (dict(method="CVODE", jacobian="fourier"), {"eps_lin": 0.05}),
    "gmres-fourier-epslin-5e-5-rtol-1e-8": (dict(method="CVODE", jacobian="fourier", rtol=1e-8, atol=1e-11), {"eps_lin": 5e-5}),
    "gmres-fourier-epslin-5e-5-rtol-1e-9": (dict(method="CVODE", jacobian="fourier", rtol=1e-9, atol=1e-12), {"eps_lin": 5e-5}),
    "gmres-fourier-epslin-5e-5-rtol-1e-10": (dict(method="CVODE", jacobian="fourier", rtol=1e-10, atol=1e-13), {"eps_lin": 5e-5}),
    "sparse-lu": (dict(method="CVODE", jacobian="sparse"), {}),
    "scipy-bdf-analytic": (dict(method="BDF", jacobian="analytic"), {}),
    "scipy-bdf-analytic-rtol-1e-9": (dict(method="BDF", jacobian="analytic", rtol=1e-9, atol=1e-12), {}),
}

_EXTRA = {}


def _attach(solver, nfev, _original=cvode_counters.attach):
    counters = _original(solver, nfev)
    for key, setter in (("nonlin_conv", "CVodeSetNonlinConvCoef"),):
        if key in _EXTRA:
            if counters is None:
                raise RuntimeError(f"{setter}: no CVODE memory found")
            function = getattr(counters.lib, setter)
            function.argtypes = [ctypes.c_void_p, ctypes.c_double]
            if function(counters.mem, ctypes.c_double(_EXTRA[key])) != 0:
                raise RuntimeError(f"{setter}({_EXTRA[key]}) refused")
    return counters


def _cvode(rhsfn, _original=sksundae.cvode.CVODE, **kwargs):
    if "krylov_dim" in _EXTRA and kwargs.get("linsolver") == "gmres":
        kwargs["krylov_dim"] = _EXTRA["krylov_dim"]
    return _original(rhsfn, **kwargs)


cvode_counters.attach = _attach
sksundae.cvode.CVODE = _cvode


def one(name: str, n: int, advection: str, t_end: float) -> dict:
    from icidr_pde.api import run

    kwargs, extra = CASES[name]
    _EXTRA.clear()
    _EXTRA.update(extra)
    plane2d_core.THIN_CELL = 0.0 if extra.get("line") else 10.0
    integrator.KRYLOV_EPS_LIN = extra.get("eps_lin", 0.05)  # 'gmres': SUNDIALS' default
    settings = {"rtol": 1e-7, "atol": 1e-10, **kwargs}
    start = time.perf_counter()
    r = run("mui", "bump2d", (n, n), t_end, ["0", f"{t_end:g}"], series_times=[], advection=advection,
            engine="pde", **settings)  # the py-pde engine these cases patch
    d = r.to_dict()
    return {"case": name, "N": n, "advection": advection, "t_end": t_end, "settings": settings, "extra": extra,
            "t_star": r.t_star, "reason": r.reason, "wall_s": time.perf_counter() - start,
            "n_steps": d.get("n_steps"), "n_rhs": d.get("n_rhs")}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--advection", default="central")
    parser.add_argument("--t-end", type=float, default=0.4)
    parser.add_argument("--out", default="data/benchmarks/tstar2d_solvers.jsonl")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    for n in args.sizes:
        for name in args.cases:
            try:
                row = one(name, n, args.advection, args.t_end)
            except Exception as exc:  # a case the solver cannot run is a row too
                row = {"case": name, "N": n, "advection": args.advection, "error": f"{type(exc).__name__}: {exc}"}
            row["command"] = "python benchmarks/tstar2d_solvers.py " + " ".join(sys.argv[1:])
            print(json.dumps(row), flush=True)
            append_jsonl(out, row)


if __name__ == "__main__":
    main()
