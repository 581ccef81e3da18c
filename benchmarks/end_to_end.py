"""End to end: the time from pressing Enter to the answer, against a plain numpy+scipy script.

    python benchmarks/end_to_end.py [--repeats 3] [--cases shear-fd sine-fd tstar-cheb sine-cheb]
                                    [--no-cold] [--json out.json]

Four reference cases (issue 13), each run as whole processes, interleaved in one run:

* ``shear-fd``: iCIDR, scene shear (3.16), finite volumes N = 201, t = 10;
* ``sine-fd``: iCIDR, scene sine (5.7), finite volumes N = 201, t = 20;
* ``tstar-cheb``: mu(I),Phi(I), scene shear, Chebyshev N = 201, failure time t*;
* ``sine-cheb``: iCIDR, scene sine, Chebyshev N = 201, t = 15 (``sine-cheb-1e-6``: the project
  at rtol 1e-6 against the same baseline, not in the default set).

**Baseline**: the same discretization written as a plain script in this file
(:func:`baseline_main`, run as ``python benchmarks/end_to_end.py --baseline CASE``; it imports
numpy and scipy only): the stress law in closed form, a vectorised numpy right-hand side and
a chain-rule Jacobian (sparse for finite volumes, dense for Chebyshev) whose pointwise stress
derivatives are complex-step derivatives (exact to round-off, no difference quotient),
integrated by ``scipy.integrate.solve_ivp(method="BDF")``.

**Project**: ``python -m icidr_pde.cli run ...`` of this tree, its default integrator (CVODE)
at the tolerance given in :data:`CASES`, on its default engine (``--engine auto``: the native
engine, :mod:`icidr_pde.native`, for finite volumes and Chebyshev alike); for the cases the
native engine runs, the py-pde path (``--engine pde``) is timed in the same rounds too
(``--no-pde-path`` skips it). The first invocation uses a fresh, empty kernel cache
(NUMBA_CACHE_DIR in a temporary directory, removed at the end: generation and compilation as
after installation, "cold"); the repeated invocations find the cache ("warm"). With
``--no-cold`` the installed cache is used (one unreported warm-up invocation per case).

Printed per case: whole-process wall time (median and range over --repeats, interleaved
baseline/project), the in-process solve time (the baseline's solve; the project's ``wall_s``),
the ratios baseline/project, the integrators' counts (CVODE: steps, RHS calls, Jacobians and
LU decompositions from its own counters), the roofline of :func:`roofline` with
measured/limit, and beside each timing the accuracy: the largest over the snapshot
times t in {3, 5, 10, 15, 20} (those <= t_end) of |max|w|(t) - ref(t)|/ref(t), with ref the
converged reference of data/reference (finite volumes N = 3201, CVODE rtol 1e-10) taken at
the run's own nodes; for t*, |t* - t*_ref|/t*_ref against data/reference (BDF rtol 1e-10).

Every process runs with OPENBLAS_NUM_THREADS=1 (``--blas-threads``, 0 inherits): on this
2-core machine under a load of ~14, OpenBLAS's two threads made a 603 x 603 LU (Chebyshev
N = 201) take 0.62-0.72 s against 0.028-0.035 s single-threaded (measured), which turns the
Chebyshev cases into a measurement of thread contention for both sides.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from provenance import write_json

ROOT = Path(__file__).resolve().parent.parent
TIMES = (3.0, 5.0, 10.0, 15.0, 20.0)

#: case -> what runs; 'project' are the extra CLI options, 'baseline' the script's tolerances
CASES = {
    "shear-fd": dict(rheology="icidr", scene="shear", disc="fd", N=201, t_end=10.0, ref="icidr-shear",
                     project=[], baseline=dict(rtol=1e-5, atol=1e-8)),
    "sine-fd": dict(rheology="icidr", scene="sine", disc="fd", N=201, t_end=20.0, ref="icidr-sine",
                    project=[], baseline=dict(rtol=1e-5, atol=1e-8)),
    "tstar-cheb": dict(rheology="mui", scene="shear", disc="cheb", N=201, t_end=1.0, ref="mui-shear-tstar-cheb",
                       project=["--rtol", "1e-7", "--atol", "1e-10"], baseline=dict(rtol=1e-7, atol=1e-10)),
    "sine-cheb": dict(rheology="icidr", scene="sine", disc="cheb", N=201, t_end=15.0, ref="icidr-sine",
                      project=["--rtol", "1e-5", "--atol", "1e-8"], baseline=dict(rtol=1e-5, atol=1e-8)),
    # the same against the same baseline, the project at rtol 1e-6: its error below the baseline's
    # (at rtol 1e-5 the t = 15 error of either side depends on rounding through the step choices)
    "sine-cheb-1e-6": dict(rheology="icidr", scene="sine", disc="cheb", N=201, t_end=15.0, ref="icidr-sine",
                           project=["--rtol", "1e-6", "--atol", "1e-9"], baseline=dict(rtol=1e-5, atol=1e-8)),
}
# Table 1 and the scenes' defaults (the baseline writes them out, as a script would)
TABLE1 = dict(mu_s=0.248, mu_d=0.588, I0=0.145, phi_c=0.817, a=0.314)
SCENES = {"shear": dict(H=30.0, phi0=0.78, eps=0.05), "sine": dict(H=30.0, phi0=0.78, a=0.16, b=0.1)}


# --------------------------------------------------------------------------------------------
# the baseline: a plain numpy + scipy script
# --------------------------------------------------------------------------------------------

def stress(rheology, phi, uz, wz):
    """(p, tau_xz, tau_zz) of the shear cell, closed form: div u = w_z, ||S||^2 = (u_z^2 + w_z^2)/4,
    Psi = (phi_c - phi)/a, M = mu(Psi); iCIDR p = (2G/(M Psi))^2, c = 4G/Psi^2,
    G = sqrt(w_z^2 + M^2 ||S||^2) - w_z; mu(I) p = (2||S||/Psi)^2, c = 4 M ||S||/Psi^2; tau = c S."""
    import numpy as np

    m = TABLE1
    Psi = (m["phi_c"] - phi) / m["a"]
    M = m["mu_s"] + (m["mu_d"] - m["mu_s"]) * Psi / (m["I0"] + Psi)
    s2 = (uz * uz + wz * wz) / 4
    if rheology == "icidr":
        m2s2 = M * M * s2
        R = np.sqrt(wz * wz + m2s2)
        G = np.where(np.real(wz) > 0, m2s2 / (R + wz), R - wz)  # no cancellation for w_z > 0
        p = (2 * G / (M * Psi)) ** 2
        c = 4 * G / Psi**2
    else:
        s = np.sqrt(s2)
        p = (2 * s / Psi) ** 2
        c = 4 * M * s / Psi**2
    return p, c * uz / 2, c * wz / 2


def fluxes_and_partials(rheology, phi, uz, wz):
    """F_u = tau_xz, F_w = tau_zz - p and their partials by (phi, u_z, w_z) (complex step)."""
    import numpy as np

    p, txz, tzz = stress(rheology, phi, uz, wz)
    step = 1e-30
    partials = []
    for k in range(3):
        args = [phi.astype(complex), uz.astype(complex), wz.astype(complex)]
        args[k] = args[k] + 1j * step
        pc, txc, tzc = stress(rheology, *args)
        partials.append((np.imag(txc) / step, np.imag(tzc - pc) / step))
    return txz, tzz - p, [d[0] for d in partials], [d[1] for d in partials]


def fd_system(rheology, N, H, V0=1.0):
    """Finite volumes as in icidr_pde/discretizations/fd.py: fluxes on faces, upwind advection,
    ghost cells phi: zero gradient, u: 0 and V0, w: 0. Returns (rhs, jac, nodes)."""
    import numpy as np
    from scipy import sparse

    h = H / N
    z = (np.arange(N) + 0.5) * h

    def pad(y):
        phi, u, w = y[:N], y[N:2 * N], y[2 * N:]
        return (np.concatenate(([phi[0]], phi, [phi[-1]])), np.concatenate(([-u[0]], u, [2 * V0 - u[-1]])),
                np.concatenate(([-w[0]], w, [-w[-1]])))

    def faces(y):
        pg, ug, wg = pad(y)
        return pg, ug, wg, 0.5 * (pg[1:] + pg[:-1]), 0.5 * (wg[1:] + wg[:-1]), np.diff(ug) / h, np.diff(wg) / h

    def rhs(t, y):
        pg, ug, wg, phi_f, w_f, uz, wz = faces(y)
        p, txz, tzz = stress(rheology, phi_f, uz, wz)
        fw = tzz - p
        mass = np.where(w_f > 0, pg[:-1], pg[1:]) * w_f
        phi, w = pg[1:-1], wg[1:-1]
        du = np.where(w > 0, ug[1:-1] - ug[:-2], ug[2:] - ug[1:-1]) / h
        dw = np.where(w > 0, wg[1:-1] - wg[:-2], wg[2:] - wg[1:-1]) / h
        return np.concatenate((-np.diff(mass) / h, np.diff(txz) / (h * phi) - w * du,
                               np.diff(fw) / (h * phi) - w * dw))

    # linear maps: valid values -> ghost-padded (E), faces average/gradient, face -> cell divergence
    def extension(alpha_left, alpha_right):
        rows = np.concatenate(([0], np.arange(1, N + 1), [N + 1]))
        cols = np.concatenate(([0], np.arange(N), [N - 1]))
        return sparse.csr_matrix((np.concatenate(([alpha_left], np.ones(N), [alpha_right])), (rows, cols)),
                                 shape=(N + 2, N))

    E_phi, E_u = extension(1.0, 1.0), extension(-1.0, -1.0)
    avg = sparse.diags([0.5, 0.5], [0, 1], shape=(N + 1, N + 2), format="csr")
    grad = sparse.diags([-1 / h, 1 / h], [0, 1], shape=(N + 1, N + 2), format="csr")
    div = sparse.diags([-1 / h, 1 / h], [0, 1], shape=(N, N + 1), format="csr")
    A_phi, A_w, G_u = avg @ E_phi, avg @ E_u, grad @ E_u  # w has the same ghost map as u's slope
    D = sparse.diags

    def jac(t, y):
        pg, ug, wg, phi_f, w_f, uz, wz = faces(y)
        fu, fw, dfu, dfw = fluxes_and_partials(rheology, phi_f, uz, wz)
        phi, w = pg[1:-1], wg[1:-1]
        i = np.arange(N)
        shift = np.where(w > 0, 0, 1)  # upwind cell difference: columns i + shift, i + shift + 1 of padded
        conv = sparse.csr_matrix((np.concatenate((-np.ones(N), np.ones(N))) / h,
                                  (np.concatenate((i, i)), np.concatenate((i + shift, i + shift + 1)))),
                                 shape=(N, N + 2))
        du, dw = conv @ ug, conv @ wg
        inv_phi = D(1 / phi)
        rows = []
        for flux, dflux in ((fu, dfu), (fw, dfw)):
            rows.append([inv_phi @ div @ D(dflux[0]) @ A_phi - D(div @ flux / phi**2),
                         inv_phi @ div @ D(dflux[1]) @ G_u, inv_phi @ div @ D(dflux[2]) @ G_u])
        rows[0][1] = rows[0][1] - D(w) @ conv @ E_u
        rows[0][2] = rows[0][2] - D(du)
        rows[1][2] = rows[1][2] - D(w) @ conv @ E_u - D(dw)
        up = sparse.csr_matrix((np.ones(N + 1), (np.arange(N + 1), np.arange(N + 1) + (w_f <= 0))),
                               shape=(N + 1, N + 2))
        mass = [-div @ D(w_f) @ up @ E_phi, None, -div @ D(up @ pg) @ A_w]
        return sparse.bmat([mass, *rows], format="csc")

    return rhs, jac, z


def cheb_system(rheology, N, H):
    """Chebyshev-Gauss-Lobatto collocation as in icidr_pde/discretizations/cheb.py (Trefethen's
    cheb on z = H (1 - x)/2, u and w Dirichlet with zero wall rates). Returns (rhs, jac, nodes)."""
    import numpy as np

    n = N - 1
    j = np.arange(N)
    x = np.cos(np.pi * j / n)
    c = np.where((j == 0) | (j == n), 2.0, 1.0) * (-1.0) ** j
    Dx = np.outer(c, 1.0 / c) / (x[:, None] - x[None, :] + np.eye(N))
    Dx -= np.diag(Dx.sum(axis=1))
    Dm = -2.0 / H * Dx
    z = H * (1 - x) / 2
    walls = [N, 2 * N - 1, 2 * N, 3 * N - 1]

    def rhs(t, y):
        phi, u, w = y[:N], y[N:2 * N], y[2 * N:]
        uz, wz = Dm @ u, Dm @ w
        p, txz, tzz = stress(rheology, phi, uz, wz)
        out = np.concatenate((-Dm @ (phi * w), Dm @ txz / phi - w * uz, Dm @ (tzz - p) / phi - w * wz))
        out[walls] = 0.0
        return out

    def jac(t, y):
        phi, u, w = y[:N], y[N:2 * N], y[2 * N:]
        uz, wz = Dm @ u, Dm @ w
        fu, fw, dfu, dfw = fluxes_and_partials(rheology, phi, uz, wz)
        J = np.empty((3 * N, 3 * N))
        J[:N, :N] = -Dm * w[None, :]
        J[:N, N:2 * N] = 0.0
        J[:N, 2 * N:] = -Dm * phi[None, :]
        for r, (flux, d) in enumerate(((fu, dfu), (fw, dfw)), start=1):
            rows = slice(r * N, (r + 1) * N)
            J[rows, :N] = Dm * d[0][None, :] / phi[:, None] - np.diag(Dm @ flux / phi**2)
            J[rows, N:2 * N] = (Dm * d[1][None, :]) @ Dm / phi[:, None]
            J[rows, 2 * N:] = (Dm * d[2][None, :]) @ Dm / phi[:, None]
        J[N:2 * N, N:2 * N] -= w[:, None] * Dm
        J[N:2 * N, 2 * N:] -= np.diag(uz)
        J[2 * N:, 2 * N:] -= w[:, None] * Dm + np.diag(wz)
        J[walls] = 0.0
        return J

    return rhs, jac, z


def initial_state(scene, z):
    import numpy as np

    s = SCENES[scene]
    H = s["H"]
    if scene == "shear":
        zc = z - H / 2
        u, w = z / H, s["eps"] * zc * np.exp(-zc**2)
    else:
        u, w = z / H + s["a"] * np.sin(2 * np.pi * z / H), -s["b"] * np.sin(2 * np.pi * z / H)
    return np.concatenate((np.full_like(z, s["phi0"]), u, w))


def baseline_main(case: str) -> dict:
    """Solve `case` with the plain script; returns max|w| at the snapshot times, t*, solve time."""
    import numpy as np
    from scipy.integrate import solve_ivp

    spec = CASES[case]
    N, H = spec["N"], SCENES[spec["scene"]]["H"]
    rhs, jac, z = (fd_system if spec["disc"] == "fd" else cheb_system)(spec["rheology"], N, H)
    y0 = initial_state(spec["scene"], z)
    if spec["disc"] == "cheb":
        y0[[N, 2 * N - 1, 2 * N, 3 * N - 1]] = (0.0, 1.0, 0.0, 0.0)
    times = [t for t in TIMES if t <= spec["t_end"]]
    start = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, spec["t_end"]), y0, method="BDF", jac=jac, t_eval=times, **spec["baseline"])
    solve_s = time.perf_counter() - start
    return dict(case=case, solve_s=solve_s, success=bool(sol.success), t_final=float(sol.t[-1]) if sol.t.size else 0.0,
                t_star=None if sol.success else float(sol.t[-1] if sol.t.size else 0.0), message=sol.message,
                max_w={f"{t:g}": float(np.abs(sol.y[2 * N:, k]).max()) for k, t in enumerate(sol.t)},
                n_rhs=int(sol.nfev), n_jac=int(sol.njev), n_lu=int(sol.nlu))


def baseline_tstar(case: str) -> dict:
    """t* of the baseline: solve_ivp returns no failure time, so step a BDF solver by hand."""
    import numpy as np
    from scipy.integrate import BDF

    spec = CASES[case]
    N, H = spec["N"], SCENES[spec["scene"]]["H"]
    rhs, jac, z = cheb_system(spec["rheology"], N, H)
    y0 = initial_state(spec["scene"], z)
    y0[[N, 2 * N - 1, 2 * N, 3 * N - 1]] = (0.0, 1.0, 0.0, 0.0)
    start = time.perf_counter()
    solver = BDF(rhs, 0.0, y0, spec["t_end"], jac=jac, **spec["baseline"])
    t_good, message = 0.0, "reached t_end"
    while solver.status == "running":
        message = solver.step() or message
        if solver.status == "failed" or not np.all(np.isfinite(solver.y)) or solver.y[:N].max() >= TABLE1["phi_c"]:
            break
        t_good = solver.t
    return dict(case=case, solve_s=time.perf_counter() - start, t_star=t_good, message=message,
                n_rhs=int(solver.nfev), n_jac=int(solver.njev), n_lu=int(solver.nlu), max_w={})


# --------------------------------------------------------------------------------------------
# measuring
# --------------------------------------------------------------------------------------------

def accuracy(case: str, max_w: dict, t_star) -> float:
    """The case's error (see the module docstring)."""
    import numpy as np

    spec = CASES[case]
    if spec["ref"].startswith("mui-shear-tstar"):
        ref = json.loads((ROOT / "data" / "reference" / f"{spec['ref']}.json").read_text())["t_star"]
        return float("inf") if t_star is None else abs(t_star - ref) / ref
    ref = np.load(ROOT / "data" / "reference" / f"{spec['ref']}.npz")
    N, H = spec["N"], SCENES[spec["scene"]]["H"]
    z = (np.arange(N) + 0.5) * H / N if spec["disc"] == "fd" else H * (1 - np.cos(np.pi * np.arange(N) / (N - 1))) / 2
    errors = []
    for t in TIMES:
        if t > spec["t_end"]:
            continue
        key = f"{t:g}"
        if key not in max_w:
            return float("inf")
        k = int(np.argmin(np.abs(ref["series_t"] - t)))
        ref_max = np.abs(np.interp(z, ref["z_series"], ref["w_series"][k])).max()
        errors.append(abs(max_w[key] - ref_max) / ref_max)
    return float(max(errors))


def _best(call, repeats=200, budget=0.5):
    """Smallest wall time of `call` (seconds) over up to `repeats` calls within ~`budget`
    seconds; the smallest CPU time (process_time) of the same calls is kept in _BEST_CPU."""
    best, best_cpu, spent = float("inf"), float("inf"), 0.0
    for _ in range(repeats):
        start, cpu = time.perf_counter(), time.process_time()
        call()
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed), spent + elapsed
        best_cpu = min(best_cpu, time.process_time() - cpu)
        if spent > budget:
            break
    _BEST_CPU.append(best_cpu)
    return best


_BEST_CPU: list = []


def roofline(case: str, n_rhs: int, n_jac: int, n_lu: int | None = None, native: bool = False) -> dict:
    """Compiled-code limit of the project's solve: what its counted work costs in compiled code.

    Measured here, in process, each the best of repeated calls: one compiled right-hand side
    (t_rhs), one Jacobian into the engine's matrix (t_jac), one LU of that matrix (t_lu:
    LAPACK dgbtrf on the band (5, 5) for finite volumes, dgetrf dense for Chebyshev) and one
    back-substitution (t_solve). With CVODE's own counts (steps, Newton iterations = RHS
    calls in its corrector, Jacobians, LU decompositions = linear-solver set-ups):
    limit = n_rhs (t_rhs + t_solve) + n_jac t_jac + n_lu t_lu, i.e. the run's arithmetic with
    no interpreter, no wrapper and no per-step bookkeeping. Without an LU count every
    Jacobian is charged one LU (a lower bound: CVODE refactors when its step changes).
    `native`: t_rhs and t_jac are the native engine's C kernels, timed in C (Chebyshev: its
    BLAS products and dense Jacobian written column-major, as CVODE's dense matrix holds it).
    """
    import numpy as np
    from scipy.linalg import lapack

    from icidr_pde.case import build_case

    spec = CASES[case]
    c = build_case(spec["rheology"], spec["scene"], spec["disc"], spec["N"])
    pde, state = c.pde, c.state
    rhs = pde.make_rates(state)
    data = np.array(state.data)
    t_rhs = _best(lambda: rhs(data, 0.0))
    n = data.size
    if spec["disc"] == "fd":
        perm, lband, uband = pde.interleaving(state)
        J = np.zeros((n, n))
        jac_into, y = pde.make_band_jacobian(state), data.ravel()[perm]
        t_jac = _best(lambda: jac_into(y, J))
        if native:  # the native engine's own kernels, timed in C (no Python call around them)
            from icidr_pde.cells.shear1d.native import FdProblem

            problem = FdProblem(c.pde.rheology, spec["N"], float(c.grid.axes_bounds[0][1]))
            t_rhs, t_jac = problem.kernel_times(y)
            _BEST_CPU[-2:] = [t_rhs, t_jac]  # in place of the numba kernels' (C wall times: one thread)
        J[np.abs(np.subtract.outer(np.arange(n), np.arange(n))) > 5] = 0.0
        J += np.eye(n)
        ab = np.zeros((2 * lband + uband + 1, n))
        for k in range(-uband, lband + 1):  # LAPACK band storage with lband extra rows for pivoting
            ab[lband + uband + k, max(0, -k):n - max(0, k)] = np.diagonal(J, -k)
        t_lu = _best(lambda: lapack.dgbtrf(ab.copy(), lband, uband))
        lu, piv, _ = lapack.dgbtrf(ab.copy(), lband, uband)
        t_solve = _best(lambda: lapack.dgbtrs(lu, lband, uband, y, piv))
    else:
        jac = pde.make_jacobian(state)
        y = data.ravel()
        t_jac = _best(lambda: jac(0.0, y), repeats=20)
        if native:
            from icidr_pde.native_case import ChebCase

            t_rhs, t_jac = ChebCase(spec["rheology"], spec["scene"], spec["N"]).problem().kernel_times(y)
            _BEST_CPU[-2:] = [t_rhs, t_jac]
        J = np.asarray(jac(0.0, y)) + np.eye(n)
        t_lu = _best(lambda: lapack.dgetrf(J), repeats=20)
        lu, piv, _ = lapack.dgetrf(J)
        t_solve = _best(lambda: lapack.dgetrs(lu, piv, y))
    n_lu = n_jac if n_lu is None else n_lu
    limit = n_rhs * (t_rhs + t_solve) + n_jac * t_jac + n_lu * t_lu
    c_rhs, c_jac, c_lu, c_solve = _BEST_CPU[-4:]  # the same calls' CPU times, in the order timed
    limit_cpu = n_rhs * (c_rhs + c_solve) + n_jac * c_jac + n_lu * c_lu
    return dict(t_rhs=t_rhs, t_jac=t_jac, t_lu=t_lu, t_solve=t_solve, limit_s=limit, n_lu=n_lu,
                lu_share=n_lu * t_lu / limit, limit_cpu_s=limit_cpu)


def timed(args, env, allowed=(0,)):
    """Wall time and result of a process; an exit status outside `allowed` is an error."""
    start = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    if proc.returncode not in allowed:
        raise RuntimeError(f"{' '.join(map(str, args))} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall, proc


def run_baseline(case, env, workdir):
    out = workdir / f"baseline-{case}.json"
    wall, _ = timed([sys.executable, __file__, "--baseline", case, "--json", str(out)], env)
    data = json.loads(out.read_text())
    return dict(wall_s=wall, solve_s=data["solve_s"], error=accuracy(case, data["max_w"], data["t_star"]),
                n_rhs=data["n_rhs"], n_jac=data["n_jac"], n_lu=data["n_lu"])


def run_project(case, env, workdir, engine="auto"):
    """The project's CLI on `case`: `engine` 'auto' is the default fast path (the native
    engine for fd), 'pde' the py-pde run path (numba kernels, scikit-sundae)."""
    spec = CASES[case]
    out = workdir / f"project-{case}-{engine}.json"
    times = ["0"] + [f"{t:g}" for t in TIMES if t <= spec["t_end"]]
    args = [sys.executable, "-m", "icidr_pde.cli", "run", "--rheology", spec["rheology"], "--scene", spec["scene"],
            "--discretization", spec["disc"], "--N", str(spec["N"]), "--t-end", f"{spec['t_end']:g}",
            "--times", *times, *spec["project"], "--json", str(out), "--no-progress", "--engine", engine]
    # the t* case fails by design: the CLI exits 3 (run failed) after writing its JSON
    wall, proc = timed(args, env, allowed=(0, 3) if spec["ref"].startswith("mui-shear-tstar") else (0,))
    data = json.loads(out.read_text())
    return dict(wall_s=wall, solve_s=data["wall_s"], compile_s=data["compile_s"], solve_cpu_s=data.get("cpu_s"),
                error=accuracy(case, data["max_w"], data["t_star"] if data["blew_up"] else None),
                n_rhs=data["n_rhs"], n_jac=data["n_jac"], n_steps=data["n_steps"], n_lu=data.get("n_lu"),
                compiled="compiling" in proc.stderr, engine=data["settings"].get("engine", "pde"))


def summary(runs: list[dict]) -> dict:
    out = {}
    for key, value in runs[0].items():
        values = [r[key] for r in runs]
        if isinstance(value, float):
            out[key] = statistics.median(values)
            out[key + "_range"] = [min(values), max(values)]
        else:
            out[key] = value if len(set(map(str, values))) == 1 else values
    return out


def measure(cases, repeats: int, cold: bool, blas_threads: int = 1, compare_pde: bool = True) -> dict:
    """Interleaved baseline/project processes per case. `cold`: the project's first invocation
    runs on an empty kernel cache in a temporary directory (reported as "first, cold");
    otherwise the installed cache is used and nothing is compiled when it is warm (an
    unreported warm-up invocation makes sure of it). Temporary files are removed."""
    with tempfile.TemporaryDirectory(prefix="icidr_e2e_") as tmp:
        workdir = Path(tmp)
        env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
        if cold:
            env["NUMBA_CACHE_DIR"] = str(workdir / "cache")
        if blas_threads:
            env.update(OPENBLAS_NUM_THREADS=str(blas_threads), OMP_NUM_THREADS=str(blas_threads))
        results = {}
        for case in cases:
            first = run_project(case, env, workdir)  # cold: the first case of a law compiles it
            pde_path = compare_pde and first["engine"] == "native"  # the cases the native engine runs
            first = first if cold else None
            if pde_path:
                run_project(case, env, workdir, "pde")  # its kernels too (cold: compiled here, unreported)
            base_runs, proj_runs, pde_runs = [], [], []
            for _ in range(repeats):  # interleaved A/B (/C: the py-pde path where the fast path is native)
                base_runs.append(run_baseline(case, env, workdir))
                proj_runs.append(run_project(case, env, workdir))
                if pde_path:
                    pde_runs.append(run_project(case, env, workdir, "pde"))
            results[case] = dict(first=first, baseline=summary(base_runs), project=summary(proj_runs),
                                 pde_path=summary(pde_runs) if pde_runs else None)
            counts = {k: int(statistics.median(r[k] for r in proj_runs)) if proj_runs[0][k] is not None else None
                      for k in ("n_rhs", "n_jac", "n_lu")}
            results[case]["roofline"] = roofline(case, counts["n_rhs"], counts["n_jac"], counts["n_lu"],
                                                 native=proj_runs[0]["engine"] == "native")
            report_case(case, results[case], repeats)
    return results


def fmt(row, key):
    lo, hi = row[key + "_range"]
    return f"{row[key]:7.3f} s [{lo:.3f}-{hi:.3f}]"


def _counts(row):
    steps = f"{row['n_steps']} steps, " if row.get("n_steps") is not None else ""
    lu = f", {row['n_lu']} LU" if row.get("n_lu") is not None else ""
    return f"{steps}{row['n_rhs']} RHS, {row['n_jac']} Jacobians{lu}"


def report_case(case, res, repeats):
    b, p, first = res["baseline"], res["project"], res["first"]
    print(f"\n{case}: {CASES[case]['rheology']} {CASES[case]['scene']} {CASES[case]['disc']} N = {CASES[case]['N']}, "
          f"t_end = {CASES[case]['t_end']:g} (median [range] of {repeats}, interleaved)", flush=True)
    if first is not None:
        print(f"  project first invocation, cold cache: {first['wall_s']:7.3f} s  (compile {first['compile_s']:.2f} s,"
              f" solve {first['solve_s']:.3f} s; compiled: {first['compiled']}), error {first['error']:.2e}")
    print(f"  baseline whole process: {fmt(b, 'wall_s')}   solve {fmt(b, 'solve_s')}   error {b['error']:.2e}"
          f"  (BDF {CASES[case]['baseline']}; {_counts(b)})")
    print(f"  project  whole process: {fmt(p, 'wall_s')}   solve {fmt(p, 'solve_s')}   error {p['error']:.2e}"
          f"  ({p['engine']} engine; solve CPU {p['solve_cpu_s']:.3f} s; compile/load {p['compile_s']:.3f} s;"
          f" CVODE {_counts(p)})")
    print(f"  ratio baseline/project: whole process warm {b['wall_s'] / p['wall_s']:.2f}x (error {p['error']:.2e}"
          f" against {b['error']:.2e})"
          + (f", first cold {b['wall_s'] / first['wall_s']:.2f}x (error {first['error']:.2e})" if first else "")
          + f"; in process {b['solve_s'] / p['solve_s']:.1f}x (error {p['error']:.2e})", flush=True)
    q = res.get("pde_path")
    if q:
        print(f"  py-pde path (--engine pde) whole process: {fmt(q, 'wall_s')}   solve {fmt(q, 'solve_s')}"
              f"   error {q['error']:.2e}  (compile/load {q['compile_s']:.3f} s; CVODE {_counts(q)}); "
              f"ratio baseline/py-pde path: whole process {b['wall_s'] / q['wall_s']:.2f}x, in process "
              f"{b['solve_s'] / q['solve_s']:.1f}x", flush=True)
    r = res["roofline"]
    per_step = (f"{1e6 * p['solve_s'] / p['n_steps']:.0f} us per step, " if p.get("n_steps") else "")
    print(f"  roofline: RHS {r['t_rhs'] * 1e6:.1f} us, Jacobian {r['t_jac'] * 1e6:.0f} us, LU {r['t_lu'] * 1e6:.0f} us,"
          f" back-substitution {r['t_solve'] * 1e6:.1f} us -> compiled limit {r['limit_s']:.3f} s"
          f" (LU {100 * r['lu_share']:.0f} %); measured {per_step}{1e6 * p['solve_s'] / p['n_rhs']:.0f} us per RHS;"
          f" project solve / limit = {p['solve_s'] / r['limit_s']:.1f} (wall clock);"
          f" CPU: limit {r['limit_cpu_s']:.3f} s, solve {p['solve_cpu_s']:.3f} s,"
          f" solve / limit = {p['solve_cpu_s'] / r['limit_cpu_s']:.1f}", flush=True)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", choices=sorted(CASES), help="run the plain script for one case (internal)")
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES)[:4])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-cold", action="store_true",
                        help="skip the first invocation on an empty kernel cache; use the installed cache")
    parser.add_argument("--blas-threads", type=int, default=1,
                        help="OPENBLAS_NUM_THREADS of every process (0: inherit); see the module docstring")
    parser.add_argument("--no-pde-path", action="store_true",
                        help="do not also time the py-pde run path (--engine pde) where the fast path is native")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.baseline:
        data = (baseline_tstar if args.baseline.startswith("tstar") else baseline_main)(args.baseline)
        write_json(args.json, data, stamp=False, indent=None)  # to the parent, not a measurement
        return 0
    if args.blas_threads:  # this process measures the roofline: same BLAS threads as the runs
        os.environ.update(OPENBLAS_NUM_THREADS=str(args.blas_threads), OMP_NUM_THREADS=str(args.blas_threads))
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}")
    results = measure(args.cases, args.repeats, not args.no_cold, args.blas_threads, not args.no_pde_path)
    if args.json:
        write_json(args.json, dict(load=os.getloadavg(), cases=results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
