"""The 2-D figures: the plane-wave symbol at steady shear (polar2d), the bump2d cell (bump2d) and
t*(N) in 2-D against the x-independent 1-D run with iCIDR's convergence (tstar2d)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from .panels import line_colors, pyplot, snapshot_at
from .registry import register_figure
from .runs import DATA

__all__ = ["BUMP2D_FRAMES", "BUMP2D_LAST", "BUMP2D_N", "CONVERGENCE2D_FRESH", "STEADY_SHEAR_2D", "TSTAR2D_FRESH",
           "LARGE_2D", "bump2d", "bump2d_pair", "closed_form_ill_posed_interval", "polar2d", "settings_label",
           "spectrum_fraction", "tstar2d"]


STEADY_SHEAR_2D = dict(phi0=0.78, velocity_gradient=(0.0, 1.0 / 30.0, 0.0, 0.0))  # u = z/H, H = 30: grad u = [[0, 1/H], [0, 0]]
BUMP2D_N = (64, 32)  # bump2d grid Nx = Nz (gallery, draft)


def closed_form_ill_posed_interval(phi0, velocity_gradient, material=None) -> list[float]:
    """mu(I),Phi(I)'s ill-posed angles |theta - beta| < arccos(M)/2 (degrees, docs/plane_waves.md), with
    beta = atan2(u_z + w_x, u_x - w_z)/2 the principal stretching direction and M = mu(Psi(phi0)).

    Written from the closed form, not from :mod:`stability.directional`: the figure marks it as a check.
    """
    from ..rheology import Material

    ux, uz, wx, wz = velocity_gradient
    beta = 0.5 * np.degrees(np.arctan2(uz + wx, ux - wz))
    half = 0.5 * np.degrees(np.arccos(float((material or Material()).M(phi0))))
    return [float(beta - half), float(beta + half)]


def _closed_form_lambda_max(rheology, theta_deg, phi0, velocity_gradient, material=None):
    """Lambda_max(theta) of the closed forms of docs/plane_waves.md (d = rho_* = 1):
    mu(I): (4 s/(phi Psi^2)) max(cos 2(theta - beta) - M, -M/2); iCIDR: -2 (R - div u)/(phi Psi^2), R = sqrt(div u^2 + M^2 s^2)."""
    from ..rheology import Material

    m = material or Material()
    ux, uz, wx, wz = velocity_gradient
    s, div = 0.5 * np.hypot(ux - wz, uz + wx), ux + wz
    M, Psi = float(m.M(phi0)), float(m.Psi(phi0))
    if rheology == "mui":
        beta = 0.5 * np.arctan2(uz + wx, ux - wz)
        return 4 * s / (phi0 * Psi**2) * np.maximum(np.cos(2 * (np.radians(theta_deg) - beta)) - M, -M / 2)
    return np.full(np.shape(theta_deg), -2 * (np.hypot(div, M * s) - div) / (phi0 * Psi**2))


@register_figure("polar2d", "2-D plane waves at steady shear: Lambda_max(theta) of mu(I),Phi(I) (ill-posed "
                 "interval shaded) and iCIDR, the closed-form interval |theta - beta| < arccos(M)/2 marked",
                 "not in the paper (its appendix A is 1-D; section 1 cites the 2-D ill-posedness, Heyman et al. "
                 "2017): stability.directional at phi0 = 0.78, u = z/30", dims="2d", source="stability.directional")
def polar2d(runs):
    from stability.directional import directional_stability, plot_polar

    plt = pyplot()
    phi0, L = STEADY_SHEAR_2D["phi0"], STEADY_SHEAR_2D["velocity_gradient"]
    angles = np.arange(0.0, 180.0, 0.5)
    results = {name: directional_stability(name, phi0, L, angles_deg=angles) for name in ("mui", "icidr")}
    mui, icidr = results["mui"], results["icidr"]
    lo, hi = closed_form_ill_posed_interval(phi0, L)
    fig = plt.figure(figsize=(12, 5.4))
    ax = fig.add_subplot(1, 2, 1, projection="polar")
    plot_polar([mui, icidr], ax)
    rmin, rmax = ax.get_ylim()
    for edge in (lo, hi, lo + 180.0, hi + 180.0):
        ax.plot(np.radians([edge, edge]), [rmin, rmax], "k:", lw=1.2)
    ax.set_title("(a) $\\Lambda_{max}(\\theta)$ (radius; dashed circle: 0); dotted: closed form", fontsize=9)
    ax = fig.add_subplot(1, 2, 2)
    for name, res in results.items():
        color = "tab:red" if name == "mui" else "tab:blue"
        label = r"$\mu(I),\Phi(I)$" if name == "mui" else "iCIDR"
        ax.plot(res.angles_deg, res.lambda_max, color=color, lw=1.8, label=f"{label} (stability.directional)")
        ax.plot(res.angles_deg[::15], _closed_form_lambda_max(name, res.angles_deg[::15], phi0, L), "o",
                color=color, mfc="none", ms=6, label=f"{label}, closed form")
        for a, b in res.ill_posed_intervals_deg:
            ax.axvspan(a, b, color=color, alpha=0.12, lw=0)
    for edge in (lo, hi):
        ax.axvline(edge, color="k", ls=":", lw=1.2)
    ax.axhline(0, color="gray", lw=0.6)
    ax.axvline(90, color="gray", lw=0.8, ls="--")
    ax.text(91, ax.get_ylim()[1] * 0.9, "1-D cell\n(θ = 90°)", fontsize=8, va="top")
    ax.text(0.5 * (lo + hi), ax.get_ylim()[1] * 0.97, f"closed form ({lo:.4f}°, {hi:.4f}°)", fontsize=8,
            ha="center", va="top")
    ax.set(xlabel=r"$\theta$ (degrees; n = (cos θ, sin θ))", ylabel=r"$\Lambda_{max}(\theta)$", xlim=(0, 180),
           xticks=range(0, 181, 30), title="(b) shaded: ill-posed angles found by stability.directional")
    ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(f"steady shear $\\phi_0$ = {phi0}, u = z/30: plane waves exp(iξ n·x)", fontsize=10)
    fig.tight_layout()
    [[a, b]] = mui.ill_posed_intervals_deg if len(mui.ill_posed_intervals_deg) == 1 else [[np.nan, np.nan]]
    closed = {name: float(np.max(np.abs(res.lambda_max - _closed_form_lambda_max(name, res.angles_deg, phi0, L))))
              for name, res in results.items()}
    return fig, {"mui_ill_posed_intervals_deg": mui.ill_posed_intervals_deg, "closed_form_interval_deg": [lo, hi],
                 "interval_endpoint_difference_deg": float(max(abs(a - lo), abs(b - hi))),
                 "mui_worst_angle_deg": mui.worst_angle_deg, "mui_max_lambda": mui.max_lambda,
                 "mui_lambda_at_90_deg": float(mui.at_90_deg["lambda_plus"].real),
                 "icidr_well_posed": icidr.well_posed, "icidr_max_lambda": icidr.max_lambda,
                 "max_abs_lambda_minus_closed_form": closed}


BUMP2D_FRAMES = (60, 30)  # snapshots of the bump2d pair between t = 0 and 0.98 t* (gallery, draft): figure and movie
BUMP2D_LAST = 0.98  # the last snapshot before t*: the state at t* itself is grid-scale noise (max|w| ~ 1e8)


def bump2d_pair(runs, n: int | None = None) -> dict:
    """mu(I),Phi(I) and iCIDR on bump2d (n x n cells) at the same times, made once per :class:`RunCache`.

    mu(I) is run twice through :func:`icidr_pde.run`: once for its failure time t*, then with
    snapshots at k/(frames - 1) * 0.98 t*; iCIDR is run with those snapshot times and t*. Returns
    {"mui", "icidr", "t_star_probe", "n"}; `n` defaults to BUMP2D_N (gallery or draft).
    """
    from ..api import run
    from ..studies.sim2d import SETTINGS as SIM2D_SETTINGS

    n = n or BUMP2D_N[1 if runs.draft else 0]
    key = f"bump2d-pair-{n}"
    if key not in runs._results:
        start = time.perf_counter()
        if runs.verbose:
            print(f"  run bump2d mu(I) and iCIDR ({n}x{n}) ...", flush=True)
        probe = run("mui", "bump2d", (n, n), 10.0, [0.0], series_times=[], **SIM2D_SETTINGS)
        if not probe.blew_up:
            raise RuntimeError(f"mu(I),Phi(I) on bump2d {n}x{n} reached t = 10 without failing: {probe}")
        frames = BUMP2D_FRAMES[1 if runs.draft else 0]
        times = sorted({float(f"{t:.6g}") for t in np.linspace(0.0, BUMP2D_LAST * probe.t_star, frames)})
        mui = run("mui", "bump2d", (n, n), 10.0, times, **SIM2D_SETTINGS)
        t_icidr = sorted(set(float(t) for t in mui.times) | {float(f"{mui.t_final:.6g}")})
        icidr = run("icidr", "bump2d", (n, n), t_icidr[-1], t_icidr, **SIM2D_SETTINGS)
        runs._results[key] = {"mui": mui, "icidr": icidr, "t_star_probe": probe.t_star, "n": n}
        runs.seconds[key] = time.perf_counter() - start
    return runs._results[key]


def _shear_deviation(result, k):
    """phi - phi0, w and |u - u_shear| = sqrt((u - z/H)^2 + w^2) of snapshot k of a bump2d run."""
    H, phi0 = result.scene_params["H"], result.scene_params["phi0"]
    z = result.z[..., 1]
    return {"phi - phi0": result.phi[k] - phi0, "w": result.w[k],
            "|u - u_shear|": np.hypot(result.u[k] - z / H, result.w[k])}


def _field_panel(ax, field, extent, title, signed=True):
    vmax = float(np.max(np.abs(field))) or 1.0
    im = ax.imshow(field.T, origin="lower", extent=extent, cmap="RdBu_r" if signed else "magma",
                   vmin=-vmax if signed else 0.0, vmax=vmax, interpolation="nearest")
    ax.set_title(title, fontsize=8)
    ax.set(xlabel="x", ylabel="z")
    return im


def _wave_angles(shape, L, H):
    """FFT wave vectors (k_x, k_z) of an (Nx, Nz) field on [0, L] x [0, H] and their angles mod 180 (degrees)."""
    kx = np.fft.fftfreq(shape[0], L / shape[0])[:, None]
    kz = np.fft.fftfreq(shape[1], H / shape[1])[None, :]
    return kx, kz, np.degrees(np.arctan2(kz, kx)) % 180.0


def spectrum_fraction(field, L, H, lo, hi) -> float:
    """Share of the energy |FFT|^2 of `field` (mean removed) in wave vectors at angles lo < theta < hi (mod 180).

    The field vanishes near the walls here (a localised bump), so the z transform needs no window."""
    energy = np.abs(np.fft.fft2(field - np.mean(field))) ** 2
    _, _, angle = _wave_angles(field.shape, L, H)
    return float(energy[(angle > lo % 180.0) & (angle < hi % 180.0)].sum() / energy.sum())


def _spectrum_panel(ax, field, L, H, lo, hi):
    energy = np.fft.fftshift(np.abs(np.fft.fft2(field - np.mean(field))) ** 2)
    kx, kz, _ = _wave_angles(field.shape, L, H)
    kx, kz = np.fft.fftshift(kx.ravel()), np.fft.fftshift(kz.ravel())
    top = float(energy.max()) or 1.0
    ax.pcolormesh(2 * np.pi * kx, 2 * np.pi * kz, np.log10(np.maximum(energy.T / top, 1e-8)), cmap="viridis",
                  shading="nearest", vmin=-8, vmax=0)
    r = 2 * np.pi * max(kx.max(), kz.max())
    for edge in (lo, hi):
        t = np.radians(edge)
        ax.plot([-r * np.cos(t), r * np.cos(t)], [-r * np.sin(t), r * np.sin(t)], "w--", lw=1)
    ax.set(xlabel="$k_x$", ylabel="$k_z$", aspect="equal")


@register_figure("bump2d", "2-D cell, scene bump2d: mu(I),Phi(I) just before it fails (a thin oblique band) "
                 "against iCIDR at the same time on the same grid (smooth)",
                 "not in the paper: the 2-D analogue of figs 3 and 6 (fv2d finite volumes, CVODE rtol 1e-7, "
                 "atol 1e-10), fields phi - phi0, w, |u - u_shear| and max|w|(t)", dims="2d",
                 source="computed (icidr_pde.run, scene bump2d)")
def bump2d(runs):
    plt = pyplot()
    pair = bump2d_pair(runs)
    mui, icidr = pair["mui"], pair["icidr"]
    k_mui = len(mui.times) - 1
    t_shown = float(mui.times[k_mui])
    k_icidr = snapshot_at(icidr, t_shown)
    L, H = mui.scene_params["L"], mui.scene_params["H"]
    extent = (0.0, L, 0.0, H)
    fig, axes = plt.subplots(2, 4, figsize=(16, 7.2), constrained_layout=True)
    numbers = {"N": f"{mui.Nx}x{mui.N}", "t_star_mui": mui.t_star, "reason_mui": mui.reason.split(" (")[0],
               "t_shown": t_shown, "t_shown_over_t_star": t_shown / mui.t_star}
    for row, (res, k, label) in enumerate(((mui, k_mui, r"$\mu(I),\Phi(I)$"), (icidr, k_icidr, "iCIDR"))):
        fields = _shear_deviation(res, k)
        for col, (name, field) in enumerate(fields.items()):
            im = _field_panel(axes[row, col], field, extent,
                              f"{label}: {name}, t = {res.times[k]:.4g}  (max {np.max(np.abs(field)):.2g})",
                              signed=name != "|u - u_shear|")
            fig.colorbar(im, ax=axes[row, col], shrink=0.85)
            numbers[f"max_abs_{name.replace(' ', '').replace('|', '')}_{res.rheology}"] = float(np.max(np.abs(field)))
        numbers[f"mass_drift_{res.rheology}"] = float(res.mass_drift)
    ax = axes[0, 3]
    for res, color, label in ((mui, "tab:red", r"$\mu(I),\Phi(I)$"), (icidr, "tab:blue", "iCIDR")):
        ax.semilogy(res.max_w_t, res.max_w_series, color=color, label=label)
    ax.axvline(t_shown, color="k", lw=0.6, ls=":")
    ax.set(xlabel="t", ylabel="max|w|", xlim=(0, mui.t_star), ylim=(1e-3, 2.0))
    ax.set_title(f"max|w|(t); dotted: t = {t_shown:.4g}; t* = {mui.t_star:.4g}", fontsize=8)
    ax.legend(fontsize=7)
    lo, hi = closed_form_ill_posed_interval(mui.scene_params["phi0"], (0.0, 1.0 / H, 0.0, 0.0))
    phi_dev = mui.phi[k_mui] - mui.scene_params["phi0"]
    numbers["mui_phi_spectrum_fraction_in_ill_posed_cone"] = spectrum_fraction(phi_dev, L, H, lo, hi)
    numbers["cone_share_of_angles"] = (hi - lo) / 180.0
    _spectrum_panel(axes[1, 3], phi_dev, L, H, lo, hi)
    axes[1, 3].set_title(f"$\\mu(I)$: log |FFT of φ − φ0|², t = {t_shown:.4g}\ndashed: closed-form ill-posed cone, "
                         f"{numbers['mui_phi_spectrum_fraction_in_ill_posed_cone']:.0%} of the energy\n"
                         f"({numbers['cone_share_of_angles']:.0%} of the angles)", fontsize=8)
    fig.suptitle(f"bump2d, {mui.Nx}x{mui.N} cells (L = H = {H:g}): top mu(I),Phi(I) at {t_shown / mui.t_star:.0%} "
                 f"of its t* = {mui.t_star:.4g} (the state at t* is grid-scale noise, max|w| = "
                 f"{np.max(np.abs(mui.final[2])):.0e}); bottom iCIDR at the same time", fontsize=10)
    return fig, numbers


TSTAR2D_FRESH = ((16, 24, 32), (16, 24))  # grids of the fresh mu(I) t* check (gallery, draft)
CONVERGENCE2D_FRESH = ((16, 32, 64), (16, 32))  # grids of the fresh iCIDR check (gallery, draft)


def _fresh_studies(runs) -> dict:
    """sim2d.tstar_study and convergence_study on the small grids, once per RunCache (JSON in a temporary
    folder: the committed data/sim2d is never overwritten)."""
    import tempfile

    from ..studies import sim2d

    key = "sim2d-fresh"
    if key not in runs._results:
        start = time.perf_counter()
        k = 1 if runs.draft else 0
        if runs.verbose:
            print(f"  sim2d tstar {TSTAR2D_FRESH[k]}, convergence {CONVERGENCE2D_FRESH[k]} ...", flush=True)
        with tempfile.TemporaryDirectory() as folder:
            tstar = sim2d.tstar_study(TSTAR2D_FRESH[k], path=Path(folder) / "tstar.json")
            conv = sim2d.convergence_study(CONVERGENCE2D_FRESH[k], path=Path(folder) / "convergence.json")
        runs._results[key] = {"tstar": tstar, "convergence": conv}
        runs.seconds[key] = time.perf_counter() - start
    return runs._results[key]


def _plain_ticks(ax, values, fmt="{:g}"):
    """Ticks at `values` with plain labels on a log axis (no minor labels)."""
    ax.set_xticks(list(values), [fmt.format(v) for v in values])
    ax.xaxis.set_minor_locator(pyplot().NullLocator())


#: the 2-D studies beyond 128^2 (docs/sim2d.md, "Grids beyond 128²"), drawn where committed: these grids
#: take minutes to hours each, so the gallery reads them and never runs them
LARGE_2D = {"tstar": Path("sim2d") / "tstar_large.json", "convergence": Path("sim2d") / "convergence_large.json"}
#: the linear solvers of the 2-D CVODE runs, as a legend names them (keys: engines.choose.CHOICES_2D["CVODE"])
_SOLVER_LABELS = {"fourier": "GMRES + x-Fourier", "krylov": "GMRES alone", "amg": "GMRES + AMG", "sparse": "sparse LU"}


def _large_studies() -> dict:
    """The committed studies beyond 128^2 that exist (``{"tstar": payload, "convergence": payload}``,
    either missing where its file is)."""
    return {part: json.loads((DATA / name).read_text()) for part, name in LARGE_2D.items() if (DATA / name).is_file()}


def settings_label(settings: dict) -> str:
    """A study's integrator settings in a few words: "CVODE rtol 1e-05, atol 1e-08, GMRES + x-Fourier"."""
    solver = settings.get("jacobian", "krylov") if settings.get("engine") != "petsc" else "PETSc"
    return (f"{settings['method']} rtol {settings['rtol']:g}, atol {settings['atol']:g}, "
            f"{_SOLVER_LABELS.get(solver, solver)}")


def _measure(study: dict, n: int, q: str, t: str) -> float:
    """Measure `q` at time `t` of a convergence study's grid `n`; NaN where that run did not reach `t`."""
    value = study["runs"][str(n)][q].get(t)
    return np.nan if value is None else value


def _grids_text(sizes) -> str:
    sizes = sorted(sizes)
    return "none" if not sizes else f"{sizes[0]}²" if len(sizes) == 1 else f"{sizes[0]}²-{sizes[-1]}²"


@register_figure("tstar2d", "2-D cell: mu(I),Phi(I) t*(N) on bump2d falls under refinement while the x-independent "
                 "1-D run decays up to N = 64; iCIDR's max|w| converges (committed study + a fresh run on small grids; "
                 "beyond 128²: {large_grids})",
                 "not in the paper: the 2-D analogue of fig 4(b) and of figs 6-7's grid agreement. Grids up to 128^2 "
                 "are expensive, so the lines are the committed `icidr-pde study sim2d tstar` and "
                 "`... convergence` (data/sim2d/*.json, CVODE rtol 1e-7, GMRES alone); the stars are recomputed by "
                 "the same study code here. The grids beyond 128² (diamonds, dashed: data/sim2d/tstar_large.json and "
                 "convergence_large.json, drawn where committed, never run here) are the same studies on the stable "
                 "2-D default, CVODE rtol 1e-5, atol 1e-8, GMRES + x-Fourier, whose time error is about 2-4e-4 "
                 "relative (docs/scaling.md) against the far smaller one of rtol 1e-7: so panel (c) takes "
                 "differences within one settings family only (the two families are two series, no difference "
                 "across them)",
                 dims="2d", source="data/sim2d/tstar.json, data/sim2d/convergence.json, data/sim2d/tstar_large.json "
                                   "and convergence_large.json where committed + computed")
def tstar2d(runs):
    plt = pyplot()
    tstar = json.loads((DATA / "sim2d" / "tstar.json").read_text())
    conv = json.loads((DATA / "sim2d" / "convergence.json").read_text())
    large = _large_studies()
    fresh = _fresh_studies(runs)
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    ax = axes[0]
    rows = tstar["rows"]
    N = np.array([r["N"] for r in rows])
    t2 = np.array([np.nan if r["t_star_2d"] is None else r["t_star_2d"] for r in rows])
    t1 = np.array([np.nan if r["t_star_1d"] is None else r["t_star_1d"] for r in rows])
    t_end = tstar["t_end"]
    ax.loglog(N, t2, "o-", color="tab:red", label="2-D bump2d, $N^2$ cells (data/sim2d)")
    ax.loglog(N, t1, "s-", color="tab:purple", label="1-D, x-independent bump, N cells")
    decays = np.isnan(t1)
    ax.loglog(N[decays], np.full(decays.sum(), t_end), "v", color="tab:purple", mfc="none", ms=8,
              label=f"1-D: no failure by t = {t_end:g} (decays)")
    fr = fresh["tstar"]["rows"]
    ax.loglog([r["N"] for r in fr], [r["t_star_2d"] for r in fr], "*", color="k", ms=12, label="2-D recomputed here")
    ax.legend(fontsize=7, loc="lower left")
    ax.add_artist(ax.get_legend())  # the large grids' own legend, above the lines, keeps this one
    large_rows = large["tstar"]["rows"] if "tstar" in large else []
    large_t2 = {r["N"]: r["t_star_2d"] for r in large_rows if r["t_star_2d"] is not None}
    large_t1 = {r["N"]: r["t_star_1d"] for r in large_rows if r["t_star_1d"] is not None}
    if large_t2:
        ax.loglog(list(large_t2), list(large_t2.values()), "D--", color="tab:red", mfc="none", ms=6,
                  label=f"2-D, {_grids_text(large_t2)}: {settings_label(large['tstar']['settings'])}")
    if large_t1:
        ax.loglog(list(large_t1), list(large_t1.values()), "D--", color="tab:purple", mfc="none", ms=5,
                  label="1-D at those N, same settings")
    shown = [v for v in (*t2, *t1, *large_t2.values(), *large_t1.values()) if np.isfinite(v)]
    ax.set(xlabel="N", ylabel="t*", title="(a) mu(I),Phi(I): t* of bump2d against N",
           ylim=(min(0.05, 0.5 * min(shown)), (8 if large_rows else 2) * t_end))
    _plain_ticks(ax, sorted({*N.tolist(), *(r["N"] for r in large_rows)}))
    ax.tick_params(axis="x", labelsize=7)
    if large_rows:
        ax.legend(handles=ax.get_lines()[4:], fontsize=7, loc="upper right")
    committed = {r["N"]: r for r in rows}
    rel = [abs(r["t_star_2d"] - committed[r["N"]]["t_star_2d"]) / committed[r["N"]]["t_star_2d"]
           for r in fr if r["N"] in committed and r["t_star_2d"] is not None]
    one_d_fresh_decays = all(r["t_star_1d"] is None for r in fr)
    # iCIDR: max|w| at each time against N, and the successive differences (grids doubling)
    sizes = conv["sizes"]
    big = large.get("convergence")
    big_sizes = big["sizes"] if big else []
    ax = axes[1]
    for t, c in zip(conv["times"], line_colors(len(conv["times"]))):
        ax.semilogx(sizes, [conv["runs"][str(n)]["max_w"][t] for n in sizes], "o-", color=c, label=f"t = {t}")
        fs = fresh["convergence"]["sizes"]
        ax.semilogx(fs, [fresh["convergence"]["runs"][str(n)]["max_w"][t] for n in fs], "*", color="k", ms=9)
        if big and t in big["times"]:
            ax.semilogx(big_sizes, [_measure(big, n, "max_w", t) for n in big_sizes], "D--", color=c, mfc="none",
                        ms=5)
    if big:
        ax.plot([], [], "D--", color="gray", mfc="none", label=f"{_grids_text(big_sizes)}: {settings_label(big['settings'])}")
    top = max(r["max_w"][t] for r in conv["runs"].values() for t in conv["times"])
    ax.set(xlabel="N ($N^2$ cells)", ylabel="max|w|", title="(b) iCIDR on bump2d: max|w|(t) against N; *: recomputed",
           ylim=(0, 1.45 * top))
    ax.set_yticks([y for y in ax.get_yticks() if 0 <= y <= 1.1 * top])  # none under the legend
    _plain_ticks(ax, [*sizes, *big_sizes])
    ax.tick_params(axis="x", labelsize=7)
    ax.legend(fontsize=7, ncol=3, loc="upper center")
    ax = axes[2]

    def differences(study, q, t):
        """|q(N) - q(2N)| of one study's grids against h = H/N of the coarser (one settings family)."""
        ns = study["sizes"]
        return (np.array([30.0 / n for n in ns[:-1]]),
                [abs(_measure(study, a, q, t) - _measure(study, b, q, t)) for a, b in zip(ns, ns[1:])])

    h = np.array([30.0 / n for n in sizes[:-1]])
    series = [(q, marker, t, ls) for q, marker in (("max_w", "o"), ("max_phi_dev", "s"), ("l2_velocity", "^"))
              for t, ls in (("1", "-"), ("10", "--"))]
    large_differences = {}
    for (q, marker, t, ls), c in zip(series, plt.rcParams["axes.prop_cycle"].by_key()["color"]):
        ax.loglog(h, differences(conv, q, t)[1], marker + ls, color=c, ms=4, label=f"{q}, t = {t}")
        if big and len(big_sizes) > 1 and t in big["times"]:
            big_h, diff = differences(big, q, t)
            ax.loglog(big_h, diff, marker + ls, color=c, mfc="none", ms=4)
            large_differences.setdefault(q, {})[t] = {n: d for n, d in zip(big_sizes, diff) if np.isfinite(d)}
    all_h = np.array([*h, *(30.0 / n for n in big_sizes[:-1])])
    ax.loglog(all_h, 0.5 * conv["runs"][str(sizes[0])]["max_w"]["1"] * all_h / h[0], "k:", label="order 1")
    ax.loglog(all_h, 0.5 * conv["runs"][str(sizes[0])]["max_w"]["1"] * (all_h / h[0]) ** 2, "k-.", label="order 2")
    if large_differences:  # the two settings families, named
        ax.plot([], [], "o", color="gray", label=f"filled: {_grids_text(sizes)}, {settings_label(conv['settings'])}")
        ax.plot([], [], "o", color="gray", mfc="none",
                label=f"hollow: {_grids_text(big_sizes)}, {settings_label(big['settings'])}")
    coarse = ", ".join(str(n) for n in [*sizes[:-1], *big_sizes[:-1]])
    drawn = [y for line in ax.get_lines() for y in line.get_ydata() if y > 0]
    low, high = min(drawn), max(drawn)
    ax.set(xlabel=f"h = H/N (N = {coarse} against 2N)", ylabel="|q(N) - q(2N)|",
           title="(c) iCIDR: successive differences shrink with h",
           ylim=(0.5 * low, high * (high / low) ** 0.8))  # room above the lines for the legend
    ax.set_yticks([y for y in ax.get_yticks() if 0.5 * low <= y <= 2 * high])
    _plain_ticks(ax, sorted(all_h, reverse=True), "{:.3g}")
    ax.tick_params(axis="x", labelsize=7)
    ax.invert_xaxis()
    ax.legend(fontsize=6, ncol=2, loc="upper right")
    fig.tight_layout()
    finest = conv["observed_orders"]
    large_orders = big["observed_orders"] if big else {}
    return fig, {"t_star_2d": dict(zip(N.tolist(), t2.tolist())), "t_star_1d_fails_from_N": int(N[~decays].min())
                 if (~decays).any() else None, "t_star_2d_falls": bool(np.all(np.diff(t2) < 0)),
                 "fresh_t_star_2d": {r["N"]: r["t_star_2d"] for r in fr},
                 "fresh_vs_committed_rel_max": float(max(rel)) if rel else None,
                 "fresh_1d_decays": one_d_fresh_decays,
                 "icidr_observed_orders_finest": {q: finest[q][t][-1] for q in finest for t in ("10",)},
                 "icidr_fresh_max_w": {n: fresh["convergence"]["runs"][str(n)]["max_w"] for n in
                                       fresh["convergence"]["sizes"]},
                 "large_grids": ("; ".join(f"{label} {_grids_text(s)} ({settings_label(large[part]['settings'])})"
                                           for part, label, s in (("tstar", "t*", [r["N"] for r in large_rows]),
                                                                  ("convergence", "convergence", big_sizes)) if s)
                                 or "no data/sim2d/*_large.json committed"),
                 "large_t_star_2d": large_t2, "large_t_star_1d": large_t1,
                 "large_t_star_2d_falls": bool(np.all(np.diff(list(large_t2.values())) < 0)) if large_t2 else None,
                 "large_max_w": {n: big["runs"][str(n)]["max_w"] for n in big_sizes},
                 "large_successive_differences": large_differences,
                 "large_observed_orders_finest": {q: large_orders[q]["10"][-1] for q in large_orders
                                                  if large_orders[q]["10"]}}
