"""Every figure of the paper the project can compute, and its supplementary movies 1-6.

``icidr-pde figures [--only fig3 fig7 ...] [--out docs/figures] [--draft] [--movies]``

Figures are entries of a registry (:data:`FIGURES`): a name, a one-line caption, the
paper's caption, the runs it needs and a function drawing it from those runs. The
runs (:data:`RUNS`, public :func:`icidr_pde.run` only) are made once per invocation
and shared: figs 3 and 4(a) use the same four mu(I) runs, figs 6 and 7 the iCIDR ones,
and the movies use the same runs' snapshots at their frame interval. Each figure
returns the numbers a reader compares with the paper (t*, max|w| extrema, chi > 0
intervals); :func:`make_figures` writes them to ``numbers.json`` and a gallery page
(``README.md``) beside the PNGs.

Settings: the paper's integrator was ode15s; we use BDF with rtol 1e-6, atol 1e-9
(t* of mu(I) depends on integrator and tolerance, docs/performance.md "Failure time t* against the integrator"). The paper's
captions do not give the snapshot times of figs 3, 6 and 7; we use t = 0, 0.5, 1, 2, 5,
10 (fig 6) and t = 0, 1, 2, 3, 5, 10, 20 (fig 7, as in the DEM comparison), and for
the blow-ups of fig 3(a,b) snapshots every 0.0025 up to t*.

``draft=True`` (tests, notebooks in CI) replaces N = 201 by N = 101 and keeps every
other setting: the same figures, qualitatively the same findings, a fraction of the cost.
``icidr-pde figures --draft`` writes into ``figures-draft/`` (:data:`DRAFT_OUT`), never over
the committed gallery ``docs/figures`` unless told to (``--out docs/figures --force``); its
headings and movie titles name the grids drawn (:func:`at_resolution`).

Adding a figure: define its runs in :data:`RUNS` (or compute them inside the drawing
function, cached in the :class:`RunCache`) and decorate the drawing function with
:func:`register_figure` (``dims="2d"`` for the 2-D cell); ``icidr-pde figures`` and the
gallery pick it up. The 2-D entries: ``polar2d`` (Lambda_max(theta) of both laws at steady
shear, :mod:`stability.directional`), ``bump2d`` (mu(I) just before its failure against iCIDR
at the same time, scene ``bump2d``) and ``tstar2d`` (t*(N) in 2-D against the x-independent
1-D run, iCIDR's convergence: the committed :mod:`icidr_pde.studies.sim2d` results plus a fresh
run on the small grids); the 2-D movie ``movie2d`` is drawn from ``bump2d``'s runs.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .datafiles import data_dir
from .outputs import save_figure, writable_folder, write_atomically

__all__ = ["FIGURES", "RUNS", "FigureSpec", "RunCache", "register_figure", "make_figures", "make_movies",
           "positive_intervals", "sign_changes", "chi_infinite_z", "at_resolution", "add_parser", "DATA"]

DATA = data_dir()  # the committed results (repository data/, or icidr_pde/data in a wheel)
PAPER_TSTAR_CHEB = 0.01052  # fig 4(a) caption
PAPER_SETTINGS = dict(method="BDF", rtol=1e-6, atol=1e-9)  # ode15s-like
FIG6_TIMES = (0.0, 0.5, 1.0, 2.0, 5.0, 10.0)
FIG7_TIMES = (0.0, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0)
GALLERY = "docs/figures"  # the committed gallery (paper resolution)
DRAFT_OUT = "figures-draft"  # where `icidr-pde figures --draft` writes unless told otherwise
BLOWUP_DT = 2.5e-4  # snapshot interval of the mu(I) fine runs (figure lines every 0.0025, movie frames)


# --- runs --------------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RunSpec:
    """Keyword arguments of :func:`icidr_pde.run` for one run, N given as (paper, draft)."""

    rheology: str
    scene: str
    discretization: str
    N: tuple[int, int]
    t_end: float
    times: tuple = ()
    movie: str | None = None

    def kwargs(self, draft: bool) -> dict:
        from .movies.registry import MOVIES
        from .movies.schedule import frame_times

        times = set(self.times)
        if self.movie:
            spec = MOVIES[self.movie]
            t_movie = self.t_end if spec.frame_dt >= 0.01 else 0.1  # blow-ups: frames up to t = 0.1 at most
            times |= set(np.round(frame_times(t_movie, spec.frame_dt), 12))
        return dict(rheology=self.rheology, scene=self.scene, discretization=self.discretization,
                    N=self.N[1] if draft else self.N[0], t_end=self.t_end, times=sorted(times), **PAPER_SETTINGS)


_FINE_BLOWUP = tuple(np.round(np.arange(0, 0.1 + 1e-12, BLOWUP_DT), 12))
RUNS = {
    "mui-fd-fine": RunSpec("mui", "shear", "fd", (201, 101), 10.0, _FINE_BLOWUP, "movie1"),
    "mui-cheb-fine": RunSpec("mui", "shear", "cheb", (201, 101), 10.0, _FINE_BLOWUP, "movie2"),
    "mui-fd-coarse": RunSpec("mui", "shear", "fd", (47, 47), 10.0, FIG6_TIMES, "movie3"),
    "mui-cheb-coarse": RunSpec("mui", "shear", "cheb", (47, 47), 10.0, FIG6_TIMES),
    "icidr-shear-fd-coarse": RunSpec("icidr", "shear", "fd", (47, 47), 10.0, FIG6_TIMES),
    "icidr-shear-fd-fine": RunSpec("icidr", "shear", "fd", (201, 101), 10.0, FIG6_TIMES, "movie4"),
    "icidr-shear-cheb-fine": RunSpec("icidr", "shear", "cheb", (201, 101), 10.0, FIG6_TIMES, "movie5"),
    "icidr-sine-fd-coarse": RunSpec("icidr", "sine", "fd", (47, 47), 20.0, FIG7_TIMES),
    "icidr-sine-fd-fine": RunSpec("icidr", "sine", "fd", (201, 101), 20.0, FIG7_TIMES, "movie6"),
}


class RunCache:
    """Runs of :data:`RUNS`, made on first use and kept for the invocation."""

    def __init__(self, draft: bool = False, verbose: bool = False):
        self.draft, self.verbose = draft, verbose
        self._results: dict = {}
        self.seconds: dict[str, float] = {}

    def __getitem__(self, key: str):
        if key not in self._results:
            from .api import run

            kwargs = RUNS[key].kwargs(self.draft)
            start = time.perf_counter()
            if self.verbose:
                print(f"  run {key} (N = {kwargs['N']}) ...", flush=True)
            self._results[key] = run(**kwargs)
            self.seconds[key] = time.perf_counter() - start
        return self._results[key]


def at_resolution(text: str, draft: bool) -> str:
    """`text`, which names the paper's grids (N = 201), with each N read as the one a draft
    run uses (:data:`RUNS`: N = 201 -> 101; N = 47 stays)."""
    if not draft:
        return text
    for paper, drafted in {spec.N for spec in RUNS.values() if spec.N[0] != spec.N[1]}:
        text = re.sub(rf"\b{paper}\b", str(drafted), text)
    return text


# --- registry ----------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FigureSpec:
    """A figure: `draw(runs) -> (matplotlib Figure, numbers)`; `runs` is a :class:`RunCache`."""

    name: str
    caption: str
    paper: str
    draw: Callable
    dims: str = "1d"
    source: str = "computed"  # or a committed data file
    command: str = field(default="")

    def heading(self, numbers: dict, draft: bool = False) -> str:
        """The one-line caption, its ``{fields}`` filled from the figure's `numbers` (counts
        that come from the data), at the resolution drawn (:func:`at_resolution`)."""
        return at_resolution(self.caption.format_map(_Unknown(numbers)), draft)


class _Unknown(dict):
    """Numbers for a caption; a field a figure's (older) numbers lack reads "?"."""

    def __missing__(self, key):
        return "?"


FIGURES: dict[str, FigureSpec] = {}


def register_figure(name: str, caption: str, paper: str, *, dims: str = "1d", source: str = "computed"):
    """Decorator adding a drawing function to :data:`FIGURES` under `name`."""

    def decorator(draw):
        FIGURES[name] = FigureSpec(name, caption, paper, draw, dims, source,
                                   command=f"icidr-pde figures --only {name}")
        return draw

    return decorator


# --- helpers -----------------------------------------------------------------------------------------------------------

def _plt():
    import matplotlib.pyplot as plt

    return plt


def positive_intervals(z, values) -> list[list[float]]:
    """The z-intervals where `values` > 0 (each [first z, last z] of a run of positive values)."""
    positive = np.asarray(values) > 0
    intervals, start = [], None
    for k, flag in enumerate(positive):
        if flag and start is None:
            start = k
        if start is not None and (not flag or k == len(positive) - 1):
            stop = k if flag else k - 1
            intervals.append([float(z[start]), float(z[stop])])
            start = None
    return intervals


def sign_changes(x, y) -> list[float]:
    """The zeros of the piecewise-linear interpolant of y(x): each x where y is 0 at a node, and
    x0 - y0 (x1 - x0) / (y1 - y0) between neighbours x0, x1 where y changes sign."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    k = np.nonzero(y[:-1] * y[1:] < 0)[0]
    between = x[k] - y[k] * (x[k + 1] - x[k]) / (y[k + 1] - y[k])
    return sorted(float(r) for r in np.concatenate([x[y == 0], between]))


def chi_infinite_z(result, k=0) -> list[float]:
    """Where chi (A18) of snapshot `k` is infinite: its denominator |u_z| vanishes where u_z, the
    face gradient of u (finite volumes: (u_i+1 - u_i) / (z_i+1 - z_i) at the face between), changes
    sign; located between faces by linear interpolation. On no node is chi exactly infinite."""
    z, u = np.asarray(result.z), np.asarray(result.u[k])
    return sign_changes(0.5 * (z[1:] + z[:-1]), np.diff(u) / np.diff(z))


def _snapshot(result, t):
    """Index of the snapshot at time t (exact match of a requested time)."""
    k = int(np.argmin(np.abs(result.times - t)))
    if abs(result.times[k] - t) > 1e-9:
        raise KeyError(f"no snapshot at t = {t} in {result.rheology} N = {result.N}")
    return k


def _colors(n):
    return _plt().cm.viridis(np.linspace(0, 0.85, max(n, 1)))


def _scheme(result) -> str:
    """The discretization's name in labels ("finite volumes", "Chebyshev")."""
    from .discretizations import DISCRETIZATIONS

    return DISCRETIZATIONS[result.discretization].label


def _tstar_label(result):
    return f"t* = {result.t_star:.5g}" if result.blew_up else "no failure"


def _max_w_extrema(result, t_min=0.0):
    """Global maximum of max|w|(t) and the interior local maxima after t_min."""
    t, m = result.max_w_t, result.max_w
    keep = t >= t_min
    t, m = t[keep], m[keep]
    inner = [k for k in range(1, len(m) - 1) if m[k] >= m[k - 1] and m[k] > m[k + 1]]
    return {"max": float(m.max()), "t_of_max": float(t[np.argmax(m)]),
            "local_maxima": [[float(t[k]), float(m[k])] for k in inner],
            "final": float(m[-1]), "t_final": float(t[-1])}


def _grid_difference(coarse, fine, times):
    """Largest |w_coarse - w_fine| (fine interpolated to the coarse nodes) over the snapshot `times`
    after t = 0 (at t = 0 both are the same formula; the difference would be interpolation error)."""
    return max(float(np.max(np.abs(np.interp(coarse.z, fine.z, fine.w[_snapshot(fine, t)])
                                   - coarse.w[_snapshot(coarse, t)]))) for t in times if t > 0)


# --- figure 2 ----------------------------------------------------------------------------------------------------------

@register_figure("fig2", "Initial condition (3.16) and chi (A18) of mu(I),Phi(I): ill-posed (chi > 0) in the centre",
                 "Fig 2: u(z,0), w(z,0), phi(z,0) for IC (3.16), phi0 = 0.78, eps = 0.05, H = 30; (d) chi(z)")
def fig2(runs):
    plt = _plt()
    res = runs["mui-fd-fine"]
    fig, axes = plt.subplots(1, 4, figsize=(13, 3.3))
    for ax, name, label, letter in zip(axes[:3], ("u", "w", "phi"), ("u", "w", r"$\phi$"), "abc"):
        ax.plot(res.z, getattr(res, name)[0], "k")
        ax.set(xlabel="z", ylabel=label, title=f"({letter})", xlim=(0, 30))
    axes[2].set_ylim(0.77, 0.79)
    z_chi, chi = res.chi_z, res.chi[0]
    ax = axes[3]
    ax.plot(z_chi, chi, "k")
    ax.axhline(0, color="gray", lw=0.6)
    intervals = positive_intervals(z_chi, chi)
    for a, b in intervals:
        ax.axvspan(a, b, color="tab:red", alpha=0.15)
    ax.set(xlabel="z", ylabel=r"$\chi$", title="(d)  shaded: $\\chi > 0$ (ill-posed)", xlim=(0, 30))
    fig.tight_layout()
    return fig, {"chi_positive_z": intervals, "chi_max": float(np.max(chi)), "chi_min": float(np.min(chi)),
                 "max_w0": float(np.max(np.abs(res.w[0])))}


# --- figure 3 ----------------------------------------------------------------------------------------------------------

def _blowup_times(res, fractions=(0.25, 0.5, 0.7, 0.85, 0.95)):
    """Snapshot times (multiples of BLOWUP_DT) at about these fractions of t*, and the last one before t*."""
    reached = res.times[res.times > 0]
    if not res.blew_up or len(reached) == 0:
        return []
    picked = {float(reached[np.argmin(np.abs(reached - f * res.t_star))]) for f in fractions}
    picked.add(float(reached[-1]))
    return sorted(picked)


def _blowup_panel(ax, res, letter, title):
    """w at a few times up to the last snapshot before t*, the IC dashed. The state at t* itself is
    not drawn: the integrator's last accepted state is grid-scale noise of size ~1e6-1e10 everywhere,
    which hides where the growth started (the centre); its size is printed instead."""
    times = _blowup_times(res)
    for t, c in zip(times, _colors(len(times))):
        ax.plot(res.z, res.w[_snapshot(res, t)], color=c, lw=1, label=f"t = {t:.4g}")
    ax.plot(res.z, res.w[0], "k--", lw=1.2, label="t = 0 (3.16)")
    if res.blew_up:
        ax.text(0.02, 0.03, f"fails at t* = {res.t_star:.4g}: max|w| = {np.max(np.abs(res.final[2])):.2g}",
                transform=ax.transAxes, fontsize=8, color="tab:red")
    ax.set(xlabel="z", ylabel="w", xlim=(0, 30), title=f"({letter}) {title}")
    ax.legend(fontsize=7, loc="upper left")


@register_figure("fig3", "mu(I),Phi(I) w snapshots: N = 201 fails (fd, Chebyshev), N = 47 decays",
                 "Fig 3: w snapshots, (a) finite differences N = 201, (b) Chebyshev N = 201, (c) finite "
                 "differences N = 47; IC dashed black")
def fig3(runs):
    plt = _plt()
    fd, cheb, coarse = runs["mui-fd-fine"], runs["mui-cheb-fine"], runs["mui-fd-coarse"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    _blowup_panel(axes[0], fd, "a", f"{_scheme(fd)}, N = {fd.N}: {_tstar_label(fd)}")
    _blowup_panel(axes[1], cheb, "b", f"{_scheme(cheb)}, N = {cheb.N}: {_tstar_label(cheb)}")
    ax = axes[2]
    shown = [t for t in FIG6_TIMES if t > 0]
    for t, c in zip(shown, _colors(len(shown))):
        ax.plot(coarse.z, coarse.w[_snapshot(coarse, t)], color=c, label=f"t = {t:g}")
    ax.plot(coarse.z, coarse.w[0], "k--", lw=1.2, label="t = 0 (3.16)")
    ax.set(xlabel="z", ylabel="w", xlim=(0, 30),
           title=f"(c) {_scheme(coarse)}, N = {coarse.N}: {_tstar_label(coarse)}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig, {"t_star_fd_fine": fd.t_star, "t_star_cheb_fine": cheb.t_star, "N_fine": fd.N,
                 "coarse_blew_up": coarse.blew_up, "coarse_max_w_t10": float(np.max(np.abs(coarse.w[-1]))),
                 "max_w0": float(np.max(np.abs(coarse.w[0]))),
                 "argmax_z_before_tstar_fd": float(fd.z[np.argmax(np.abs(fd.w[len(fd.times) - 1]))])}


# --- figure 4 ----------------------------------------------------------------------------------------------------------

def _load_tstar(name):
    path = DATA / "tstar" / name
    data = json.loads(path.read_text())
    N = np.array(sorted(int(k) for k in data))
    t = np.array([np.nan if data[str(n)] is None else data[str(n)] for n in N], dtype=float)
    return N, t


@register_figure("fig4", "max|w|(t) of the four mu(I) runs with t* marked; t*(N) of the Chebyshev scheme",
                 "Fig 4: (a) max|w|(t), finite differences dashed, Chebyshev solid, N = 201 red, N = 47 blue, "
                 "t* = 0.01052 indicated; (b) t* against N (Chebyshev)", source="computed + data/tstar/")
def fig4(runs):
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    ax = axes[0]
    numbers = {}
    for key, color, ls in (("mui-fd-fine", "tab:red", "--"), ("mui-cheb-fine", "tab:red", "-"),
                           ("mui-fd-coarse", "tab:blue", "--"), ("mui-cheb-coarse", "tab:blue", "-")):
        res = runs[key]
        keep = res.max_w_t > 0
        ax.loglog(res.max_w_t[keep], res.max_w[keep], ls=ls, color=color, label=f"{_scheme(res)}, N = {res.N}")
        if res.blew_up:  # the value at t* (1e6-1e10) is off the axis: the cross sits at its top
            ax.plot([res.t_star], [min(res.max_w[-1], 5.0)], "x", color=color, ms=8, clip_on=False)
        numbers[f"t_star_{key}"] = res.t_star
        numbers[f"max_w_final_{key}"] = float(res.max_w[-1])
    cheb = runs["mui-cheb-fine"]
    if cheb.blew_up:
        ax.axvline(cheb.t_star, color="k", lw=0.7)
        ax.annotate(f"Chebyshev t* = {cheb.t_star:.4g}\n(paper, N = 201: {PAPER_TSTAR_CHEB})", (cheb.t_star, 0.5),
                    xycoords=("data", "axes fraction"), xytext=(4, 0), textcoords="offset points", fontsize=8)
    ax.plot([], [], "x", color="k", ms=8, label="failure at t* (max|w| off the axis)")
    ax.set(xlabel="t", ylabel="max|w|", title="(a) max|w|(t) of the four runs", xlim=(1e-4, 10), ylim=(1e-4, 5))
    ax.legend(fontsize=8, loc="lower left")
    ax = axes[1]
    N, t = _load_tstar("mui_shear_cheb_BDF_rtol1e-6_atol1e-9.json")
    ax.plot(N, t, "o", color="k", ms=3, mfc="none", label="Chebyshev (data/tstar, icidr-pde tstar)")
    ax.plot([cheb.N], [cheb.t_star], "*", color="tab:red", ms=12, label=f"this run, N = {cheb.N}")
    ax.set_yscale("log")
    ax.set(xlabel="$N_z$", ylabel="$t_*$", title="(b)  no failure by t = 20 below the threshold")
    threshold = int(N[np.isfinite(t)].min())
    ax.axvline(threshold - 1, color="gray", lw=0.6, ls=":")
    ax.text(threshold + 3, 0.5 * np.nanmax(t), f"fails for $N_z \\geq$ {threshold}", fontsize=8, va="top")
    ax.legend(fontsize=8)
    fig.tight_layout()
    numbers.update(paper_t_star=PAPER_TSTAR_CHEB, cheb_threshold_N=threshold,
                   cheb_t_star_N201_data=float(t[N == 201][0]))
    return fig, numbers


# --- figure 5 ----------------------------------------------------------------------------------------------------------

FIG5_PHI = (0.72, 0.74, 0.76, 0.78, 0.80)


def yield_ratio(I, phi, material=None):
    """Y/p of iCIDR (4.7): mu(Psi(phi)) I / Psi(phi)."""
    from .rheology import Material

    m = Material() if material is None else material
    psi = m.Psi(phi)
    return m.mu(psi) * np.asarray(I, dtype=float) / psi


@register_figure("fig5", "iCIDR yield ratio Y/p against I for several phi, with mu(I) and mu_d",
                 "Fig 5: Y/p against I for several phi (black), mu(I) (blue), steady isochoric points "
                 "I = Psi(phi) (dots), mu_d (dashed red)", source="(4.7), Table 1")
def fig5(runs):
    from .rheology import Material

    plt = _plt()
    m = Material()
    I = np.linspace(0, 0.6, 301)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    dots = []
    for phi in FIG5_PHI:
        ax.plot(I, yield_ratio(I, phi, m), "k", lw=1)
        psi = float(m.Psi(phi))
        dots.append([phi, psi, float(m.mu(psi))])
        ax.plot([psi], [m.mu(psi)], "ko", ms=5)
        ax.annotate(f"$\\phi$ = {phi:g}", (I[-1], yield_ratio(I[-1], phi, m)), fontsize=7,
                    xytext=(-40, 4), textcoords="offset points")
    ax.plot(I, m.mu(I), color="tab:blue", lw=2, label=r"$\mu(I)$ (2.10)")
    ax.axhline(m.mu_d, color="tab:red", ls="--", label=r"$\mu_d$")
    ax.set(xlabel="I", ylabel="Y/p", xlim=(0, 0.6), ylim=(0, 1.0))
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig, {"isochoric_points_phi_I_mu": dots, "mu_d": m.mu_d}


# --- figure 6 ----------------------------------------------------------------------------------------------------------

@register_figure("fig6", "iCIDR with IC (3.16): w snapshots and max|w|(t) at N = 47 and 201 on top of one another",
                 "Fig 6: (a) w at a sequence of times, N = 47 (open circles) and N = 201 (lines); (b) max|w|(t), "
                 "N = 47 blue circles, N = 201 red line")
def fig6(runs):
    plt = _plt()
    coarse, fine = runs["icidr-shear-fd-coarse"], runs["icidr-shear-fd-fine"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    ax = axes[0]
    for t, c in zip(FIG6_TIMES, _colors(len(FIG6_TIMES))):
        ax.plot(fine.z, fine.w[_snapshot(fine, t)], color=c, label=f"t = {t:g}")
        ax.plot(coarse.z, coarse.w[_snapshot(coarse, t)], "o", color=c, mfc="none", ms=4)
    ax.set(xlabel="z", ylabel="w", xlim=(0, 30), title=f"(a) lines N = {fine.N}, circles N = {coarse.N}")
    ax.legend(fontsize=7)
    ax = axes[1]
    ax.plot(coarse.max_w_t, coarse.max_w, "o", color="tab:blue", mfc="none", ms=4, markevery=6,
            label=f"N = {coarse.N}")
    ax.plot(fine.max_w_t, fine.max_w, color="tab:red", label=f"N = {fine.N}")
    ax.set(xlabel="t", ylabel="max|w|", yscale="log", xlim=(0, 10), title="(b)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    w0 = np.max(np.abs(fine.w[0]))
    diff = _grid_difference(coarse, fine, FIG6_TIMES)
    return fig, {"blew_up": bool(coarse.blew_up or fine.blew_up), "max_w0": float(w0),
                 "max_w_t10_fine": float(np.max(np.abs(fine.w[-1]))),
                 "grid_difference_rel_max_w0": diff / w0, "N": [coarse.N, fine.N]}


# --- figure 7 ----------------------------------------------------------------------------------------------------------

@register_figure("fig7", "iCIDR with IC (5.7): phi, u, w at N = 47 and 201, chi at t = 0, max|w|(t) with its "
                 "local maximum near t = 3",
                 "Fig 7: (a-c) phi, u, w, N = 201 lines, N = 47 open circles; (d) chi (A18) at t = 0; (e) max|w|(t), "
                 "N = 47 open circles, N = 201 red line")
def fig7(runs):
    plt = _plt()
    coarse, fine = runs["icidr-sine-fd-coarse"], runs["icidr-sine-fd-fine"]
    fig, axes = plt.subplots(1, 5, figsize=(17, 3.8))
    for ax, name, label, letter in zip(axes[:3], ("phi", "u", "w"), (r"$\phi$", "u", "w"), "abc"):
        for t, c in zip(FIG7_TIMES, _colors(len(FIG7_TIMES))):
            ax.plot(fine.z, getattr(fine, name)[_snapshot(fine, t)], color=c, label=f"t = {t:g}")
            ax.plot(coarse.z, getattr(coarse, name)[_snapshot(coarse, t)], "o", color=c, mfc="none", ms=3)
        ax.set(xlabel="z", ylabel=label, xlim=(0, 30), title=f"({letter})")
    axes[0].legend(fontsize=6)
    ax = axes[3]
    z_chi, chi = fine.chi_z, fine.chi[0]
    intervals = positive_intervals(z_chi, chi)
    ax.plot(z_chi, np.where(np.isfinite(chi), chi, np.nan), "k")
    inf_z = chi_infinite_z(fine)
    for a, b in intervals:
        ax.axvspan(a, b, color="tab:red", alpha=0.15)
    for zi in inf_z:
        ax.axvline(zi, color="tab:red", lw=0.8, ls=":")
    ax.axhline(0, color="gray", lw=0.6)
    ax.set(xlabel="z", ylabel=r"$\chi$ at t = 0", xlim=(0, 30), ylim=(-10, 10),
           title="(d) shaded $\\chi>0$; dotted $\\chi=\\infty$")
    ax = axes[4]
    ax.plot(coarse.max_w_t, coarse.max_w, "o", color="tab:blue", mfc="none", ms=3, markevery=6,
            label=f"N = {coarse.N}")
    ax.plot(fine.max_w_t, fine.max_w, color="tab:red", label=f"N = {fine.N}")
    extrema = _max_w_extrema(fine, t_min=1.0)
    for t, v in extrema["local_maxima"]:
        ax.plot([t], [v], "kv", ms=6)
        ax.annotate(f"local max t = {t:.2f}", (t, v), xytext=(6, 6), textcoords="offset points", fontsize=7)
    ax.set(xlabel="t", ylabel="max|w|", yscale="log", xlim=(0, 20), title="(e)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    w0 = np.max(np.abs(fine.w[0]))
    diff = _grid_difference(coarse, fine, FIG7_TIMES)
    return fig, {"chi_positive_z": intervals, "chi_infinite_z": [float(z) for z in inf_z],
                 "max_w_local_maxima_after_t1": extrema["local_maxima"], "blew_up": bool(coarse.blew_up or fine.blew_up),
                 "grid_difference_rel_max_w0": diff / w0, "max_w_t20_fine": float(np.max(np.abs(fine.w[-1])))}


# --- figures 1 and 8: DEM, from committed data -------------------------------------------------------------------------

@register_figure("fig1", "Steady DEM mu(I) and phi(I) (LAMMPS, committed data) pooled over k_n, H and N, "
                         "with (2.10), (2.11) and Table 1",
                 "Fig 1: (a) mu and (b) phi against I; blue lines (2.10), (2.11) with Table 1; symbols DEM "
                 "(one marker per k_n, H, N configuration); dashed: fit to the pool",
                 source="data/dem/steady.json, data/dem/steady_pool.json")
def fig1(runs):
    from .rheology import Material

    plt = _plt()
    summary = json.loads((DATA / "dem" / "steady.json").read_text())
    pool_path = DATA / "dem" / "steady_pool.json"
    pool = json.loads(pool_path.read_text()) if pool_path.exists() else None
    pts = summary["points"]
    I, dI = np.array([p["I"] for p in pts]), np.array([p["I_std"] for p in pts])
    mu, dmu = np.array([p["mu"] for p in pts]), np.array([p["mu_std"] for p in pts])
    phi = np.array([p["phi"] for p in pts])
    m = Material()
    Ig = np.linspace(0, 0.3, 301)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    axes[0].errorbar(I, mu, xerr=dI, yerr=dmu, fmt="o", color="k", mfc="none", ms=5, capsize=2,
                     label=f"DEM ({summary['repeats']} repeats, {summary['n_particles']} disks; std)")
    axes[1].errorbar(I, phi, xerr=dI, fmt="o", color="k", mfc="none", ms=5, capsize=2, label="DEM reference")
    numbers = {}
    if pool is not None:
        configs = [c for c in dict.fromkeys(p["config"] for p in pool["points"]) if c != "reference"]
        for j, cfg in enumerate(configs):
            cp = [p for p in pool["points"] if p["config"] == cfg]
            x = np.array([p["I"] for p in cp])
            kw = dict(fmt="s^vD<>p"[j % 7], ms=4, mfc="none", capsize=1.5, color=f"C{j + 1}")
            axes[0].errorbar(x, [p["mu"] for p in cp], xerr=[p["se_I"] for p in cp],
                             yerr=[p["se_mu"] for p in cp], label=f"{cfg} (s.e.)", **kw)
            axes[1].errorbar(x, [p["phi"] for p in cp], xerr=[p["se_I"] for p in cp], label=cfg, **kw)
        f = pool["pooled_fit"]["fit"]
        axes[0].plot(Ig, f["mu_s"] + (f["mu_d"] - f["mu_s"]) / (f["I0"] / np.maximum(Ig, 1e-12) + 1), "k--",
                     lw=1, label="(2.10), pooled fit")
        axes[1].plot(Ig, f["phi_c"] - f["a"] * Ig, "k--", lw=1, label="(2.11), pooled fit")
        numbers = {"pooled_fit": f, "pooled_fit_std": pool["pooled_fit"]["std"],
                   "pooled_points": len(pool["points"]), "configs": configs}
    axes[0].plot(Ig, m.mu(Ig), color="tab:blue", label="(2.10), Table 1")
    axes[1].plot(Ig, m.Phi(Ig), color="tab:blue", label="(2.11), Table 1")
    axes[0].set(xlabel="I", ylabel=r"$\mu$", title="(a)", xlim=(0, 0.3))
    axes[1].set(xlabel="I", ylabel=r"$\phi$", title="(b)", xlim=(0, 0.3))
    for ax in axes:
        ax.legend(fontsize=6)
    fig.tight_layout()
    residual_mu = float(np.max(np.abs(mu - m.mu(I))))
    residual_phi = float(np.max(np.abs(phi - m.Phi(I))))
    return fig, {"I_range": [float(I.min()), float(I.max())], "max_abs_mu_minus_table1": residual_mu,
                 "max_abs_phi_minus_table1": residual_phi, "fit": summary.get("fit"), **numbers}


@register_figure("fig8", "iCIDR (Table 1) against the mean of {dem_runs} DEM runs from IC (5.7): phi, u, w and "
                 "max|w|(t)",
                 "Fig 8: (a-c) phi, u, w profiles, DEM mean (circles) +- std (bars) against iCIDR; (d) max|w|(t)",
                 source="data/dem/transient_ensemble.npz")
def fig8(runs):
    plt = _plt()
    ens = np.load(DATA / "dem" / "transient_ensemble.npz")
    tt, z = ens["times"], ens["z"]
    fig, axes = plt.subplots(1, 4, figsize=(16, 4))
    for j, t in enumerate(FIG7_TIMES):
        k = int(np.argmin(np.abs(tt - t)))
        color = _colors(len(FIG7_TIMES))[j]
        for ax, f in zip(axes[:3], ("phi", "u", "w")):
            ax.errorbar(z, ens[f"{f}_mean"][k], yerr=ens[f"{f}_std"][k], fmt="o", ms=3, mfc="none", color=color,
                        capsize=1.5, label=f"t = {t:g}" if f == "phi" else None)
            ax.plot(z, ens[f"icidr_table1_{f}"][k], "-", color=color)
    for ax, label, letter in zip(axes[:3], (r"$\phi$", "u", "w"), "abc"):
        ax.set(xlabel="z", ylabel=label, title=f"({letter})")
    axes[0].legend(fontsize=6)
    ax = axes[3]
    icidr_max = np.max(np.abs(ens["icidr_table1_w"]), axis=1)
    repeats = int(ens["repeats"])
    ax.plot(tt, ens["max_w"], "ko", mfc="none", ms=3, label=f"DEM mean of {repeats} runs")
    ax.plot(tt, icidr_max, color="tab:red", label="iCIDR (Table 1), same bins")
    ax.set(xlabel="t", ylabel="max|w| (2d bins)", yscale="log", title="(d)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    summary = json.loads((DATA / "dem" / "transient.json").read_text())
    return fig, {"dem_runs": repeats, "rel_error_table1_max": summary["rel_error_table1_summary"]["max"],
                 "secondary_max_w_peak": summary.get("secondary_max_w_peak")}


# --- the project's own -------------------------------------------------------------------------------------------------

@register_figure("work_precision", "Work-precision of every integrator and Jacobian mode (committed benchmark data)",
                 "not in the paper: python benchmarks/work_precision.py", source="data/benchmarks/work_precision.json")
def work_precision(runs):
    plt = _plt()
    data = json.loads((DATA / "benchmarks" / "work_precision.json").read_text())
    cases = list(data["cases"])
    fig, axes = plt.subplots(1, len(cases), figsize=(6 * len(cases), 4.5), squeeze=False)
    numbers = {}
    for ax, case in zip(axes[0], cases):
        rows = [r for r in data["cases"][case]["rows"] if "error" not in r]
        for family in sorted({r["family"] for r in rows}):
            pts = sorted((r["series"], r["wall_s"]) for r in rows if r["family"] == family)
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", ms=3, label=family)
        ax.axvline(data["cases"][case]["summary"]["target"], color="gray", lw=0.6, ls=":")
        ax.set(xlabel="max|w|(t) error (relative)", ylabel="wall time [s]", title=case)
        ax.grid(True, which="both", alpha=0.3)
        numbers[case] = data["cases"][case]["summary"].get("speedup_vs_c")
    axes[0][-1].legend(fontsize=6)
    fig.tight_layout()
    return fig, {"speedup_vs_c": numbers}


@register_figure("growth", "Largest growth rate of the linearised finite-volume operator against h (symbolic toolkit)",
                 "not in the paper: mu(I) grows like 4 Lambda_+/h^2, iCIDR stays bounded", source="stability")
def growth(runs):
    from stability.growth import fd_growth_table

    plt = _plt()
    rows = fd_growth_table(Ns=(32, 64, 128, 256) if runs.draft else (32, 64, 128, 256, 512, 1024))
    h = np.array([r["h"] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.loglog(h, [r["mui"] for r in rows], "o-", color="tab:red", label=r"$\mu(I),\Phi(I)$")
    ax.loglog(h, [max(r["icidr"], 1e-12) for r in rows], "s-", color="tab:blue", label="iCIDR (floored at 1e-12)")
    ax.invert_xaxis()
    ax.set(xlabel="grid spacing h", ylabel="max Re(eigenvalue), linearised fd operator")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig, {"rows": [{k: float(v) for k, v in r.items()} for r in rows]}


# --- 2-D: the plane-wave symbol, the bump2d cell, t*(N) -----------------------------------------------------------------

STEADY_SHEAR_2D = dict(phi0=0.78, velocity_gradient=(0.0, 1.0 / 30.0, 0.0, 0.0))  # u = z/H, H = 30: grad u = [[0, 1/H], [0, 0]]
BUMP2D_N = (64, 32)  # bump2d grid Nx = Nz (gallery, draft)


def closed_form_ill_posed_interval(phi0, velocity_gradient, material=None) -> list[float]:
    """mu(I),Phi(I)'s ill-posed angles |theta - beta| < arccos(M)/2 (degrees, docs/plane_waves.md), with
    beta = atan2(u_z + w_x, u_x - w_z)/2 the principal stretching direction and M = mu(Psi(phi0)).

    Written from the closed form, not from :mod:`stability.directional`: the figure marks it as a check.
    """
    from .rheology import Material

    ux, uz, wx, wz = velocity_gradient
    beta = 0.5 * np.degrees(np.arctan2(uz + wx, ux - wz))
    half = 0.5 * np.degrees(np.arccos(float((material or Material()).M(phi0))))
    return [float(beta - half), float(beta + half)]


def _closed_form_lambda_max(rheology, theta_deg, phi0, velocity_gradient, material=None):
    """Lambda_max(theta) of the closed forms of docs/plane_waves.md (d = rho_* = 1):
    mu(I): (4 s/(phi Psi^2)) max(cos 2(theta - beta) - M, -M/2); iCIDR: -2 (R - div u)/(phi Psi^2), R = sqrt(div u^2 + M^2 s^2)."""
    from .rheology import Material

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

    plt = _plt()
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
    from .api import run
    from .studies.sim2d import SETTINGS as SIM2D_SETTINGS

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
    plt = _plt()
    pair = bump2d_pair(runs)
    mui, icidr = pair["mui"], pair["icidr"]
    k_mui = len(mui.times) - 1
    t_shown = float(mui.times[k_mui])
    k_icidr = _snapshot(icidr, t_shown)
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
        ax.semilogy(res.max_w_t, res.max_w, color=color, label=label)
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

    from .studies import sim2d

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
    ax.xaxis.set_minor_locator(_plt().NullLocator())


@register_figure("tstar2d", "2-D cell: mu(I),Phi(I) t*(N) on bump2d falls under refinement while the x-independent "
                 "1-D run decays up to N = 64; iCIDR's max|w| converges (committed study + a fresh run on small grids)",
                 "not in the paper: the 2-D analogue of fig 4(b) and of figs 6-7's grid agreement. Grids up to 128^2 "
                 "are expensive, so the lines are the committed `python -m icidr_pde.studies.sim2d tstar` and "
                 "`... convergence` (data/sim2d/*.json); the stars are recomputed by the same study code here",
                 dims="2d", source="data/sim2d/tstar.json, data/sim2d/convergence.json + computed")
def tstar2d(runs):
    plt = _plt()
    tstar = json.loads((DATA / "sim2d" / "tstar.json").read_text())
    conv = json.loads((DATA / "sim2d" / "convergence.json").read_text())
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
    ax.set(xlabel="N", ylabel="t*", title="(a) mu(I),Phi(I): t* of bump2d against N", ylim=(0.05, 2 * t_end))
    _plain_ticks(ax, N)
    ax.legend(fontsize=7, loc="lower left")
    committed = {r["N"]: r for r in rows}
    rel = [abs(r["t_star_2d"] - committed[r["N"]]["t_star_2d"]) / committed[r["N"]]["t_star_2d"]
           for r in fr if r["N"] in committed and r["t_star_2d"] is not None]
    one_d_fresh_decays = all(r["t_star_1d"] is None for r in fr)
    # iCIDR: max|w| at each time against N, and the successive differences (grids doubling)
    sizes = conv["sizes"]
    ax = axes[1]
    for t, c in zip(conv["times"], _colors(len(conv["times"]))):
        ax.semilogx(sizes, [conv["runs"][str(n)]["max_w"][t] for n in sizes], "o-", color=c, label=f"t = {t}")
        fs = fresh["convergence"]["sizes"]
        ax.semilogx(fs, [fresh["convergence"]["runs"][str(n)]["max_w"][t] for n in fs], "*", color="k", ms=9)
    ax.set(xlabel="N ($N^2$ cells)", ylabel="max|w|", title="(b) iCIDR on bump2d: max|w|(t) against N; *: recomputed")
    _plain_ticks(ax, sizes)
    ax.legend(fontsize=7, ncol=2)
    ax = axes[2]
    h = np.array([30.0 / n for n in sizes[:-1]])
    for q, marker in (("max_w", "o"), ("max_phi_dev", "s"), ("l2_velocity", "^")):
        for t, ls in (("1", "-"), ("10", "--")):
            diff = [abs(conv["runs"][str(a)][q][t] - conv["runs"][str(b)][q][t]) for a, b in zip(sizes, sizes[1:])]
            ax.loglog(h, diff, marker + ls, ms=4, label=f"{q}, t = {t}")
    ax.loglog(h, 0.5 * conv["runs"][str(sizes[0])]["max_w"]["1"] * h / h[0], "k:", label="order 1 (upwinding)")
    ax.set(xlabel="h = H/N (N = 16, 32, 64 against 2N)", ylabel="|q(N) - q(2N)|",
           title="(c) iCIDR: successive differences shrink with h")
    _plain_ticks(ax, h, "{:.3g}")
    ax.invert_xaxis()
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    finest = conv["observed_orders"]
    return fig, {"t_star_2d": dict(zip(N.tolist(), t2.tolist())), "t_star_1d_fails_from_N": int(N[~decays].min())
                 if (~decays).any() else None, "t_star_2d_falls": bool(np.all(np.diff(t2) < 0)),
                 "fresh_t_star_2d": {r["N"]: r["t_star_2d"] for r in fr},
                 "fresh_vs_committed_rel_max": float(max(rel)) if rel else None,
                 "fresh_1d_decays": one_d_fresh_decays,
                 "icidr_observed_orders_finest": {q: finest[q][t][-1] for q in finest for t in ("10",)},
                 "icidr_fresh_max_w": {n: fresh["convergence"]["runs"][str(n)]["max_w"] for n in
                                       fresh["convergence"]["sizes"]}}


# --- driver ------------------------------------------------------------------------------------------------------------

def make_figures(only=None, out="docs/figures", *, draft=False, verbose=True, runs: RunCache | None = None,
                 dpi=110) -> dict:
    """Draw the figures named in `only` (default: all) into `out`; return {name: numbers}."""
    plt = _plt()
    names = list(FIGURES) if not only else list(only)
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"`only` must name figures of {sorted(FIGURES)}; got {unknown}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runs = runs or RunCache(draft=draft, verbose=verbose)
    numbers = {}
    for name in names:
        start = time.perf_counter()
        if verbose:
            print(f"{name} ...", flush=True)
        fig, nums = FIGURES[name].draw(runs)
        path = out / f"{name}.png"
        save_figure(fig, path, dpi=dpi)
        plt.close(fig)
        nums = {"png": path.name, "seconds": round(time.perf_counter() - start, 2), "draft": draft, **nums}
        numbers[name] = nums
        if verbose:
            print(f"  {FIGURES[name].heading(nums, draft)} -> {path} ({nums['seconds']} s)")
    return numbers


def movie2d(runs, path, *, verbose=True, dpi=90, stride=1) -> dict:
    """The 2-D movie: bump2d, mu(I),Phi(I) up to its failure against iCIDR at the same times
    (the runs of the ``bump2d`` figure, :func:`bump2d_pair`; every `stride`-th snapshot).
    Returns what the gallery lists."""
    from .movies.render import movie_from_results_2d

    pair = bump2d_pair(runs)
    mui, icidr = pair["mui"], pair["icidr"]
    start = time.perf_counter()
    title = f"bump2d {mui.Nx}x{mui.N}: mu(I),Phi(I) (left) | iCIDR (right)" + (" [draft]" if runs.draft else "")
    path = movie_from_results_2d({"mu(I),Phi(I)": mui, "iCIDR": icidr}, path, title=title, progress=verbose,
                                 dpi=dpi, stride=stride)
    kept = len(set(range(0, len(mui.times), stride)) | {len(mui.times) - 1})
    info = {"file": path.name, "frame_dt": float(np.mean(np.diff(mui.times))) * stride, "frames": kept + mui.blew_up,
            "seconds": round(time.perf_counter() - start, 1), "t_star": mui.t_star, "grid": f"{mui.Nx}x{mui.N}"}
    if verbose:
        print(f"movie2d: {path} ({info['seconds']} s)")
    return info


def make_movies(only=None, out="docs/figures", *, draft=False, runs: RunCache | None = None, verbose=True,
                suffix=".mp4") -> dict:
    """Write the movies (default: supplementary movies 1-6 and movie2d) from the shared runs."""
    from .movies.registry import MOVIES, MOVIES_2D
    from .movies.render import movie_from_result

    names = list(MOVIES) + list(MOVIES_2D) if not only else list(only)
    runs = runs or RunCache(draft=draft, verbose=verbose)
    key_of = {spec.movie: key for key, spec in RUNS.items() if spec.movie}
    written = {}
    for name in names:
        if name in MOVIES_2D:
            written[name] = movie2d(runs, Path(out) / f"{name}{suffix}", verbose=verbose)
            continue
        spec = MOVIES[name]
        res = runs[key_of[name]]
        start = time.perf_counter()
        path = movie_from_result(res, Path(out) / f"{name}{suffix}", frame_dt=spec.frame_dt,
                                 title=f"movie {name[5:]}: {at_resolution(spec.caption, draft)}"
                                       + (" [draft]" if draft else ""))
        written[name] = {"file": path.name, "frame_dt": spec.frame_dt, "seconds": round(time.perf_counter() - start, 1),
                         "t_star": res.t_star, "draft": draft}
        if verbose:
            print(f"{name}: {path} ({written[name]['seconds']} s)")
    return written


# --- gallery -----------------------------------------------------------------------------------------------------------

def _fmt(value):
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_fmt(v)}" for k, v in value.items()) + "}"
    return str(value)


_HIDDEN = {"png", "seconds", "draft", "rows", "fit"}


def write_gallery(numbers: dict, out="docs/figures", movies: dict | None = None, meta: dict | None = None) -> Path:
    """Write `out`/README.md: each figure with its caption, the paper's caption, its command and numbers."""
    out = Path(out)
    lines = ["# Figures of Schaeffer et al. (2019), recomputed", "",
             "Generated by `icidr-pde figures` (this page too: do not edit by hand). Each figure names the command "
             "that redraws it and the numbers a reader compares with the paper. Settings: BDF, rtol 1e-6, "
             "atol 1e-9 (ode15s-like), finite volumes unless stated; the paper's captions give no snapshot "
             "times, so we use those listed in `icidr_pde/figures.py`.", ""]
    if meta:
        lines += [f"Last full run: {meta.get('date', '?')}, {meta.get('total_s', 0):.0f} s wall on 2 shared cores "
                  f"({'draft' if meta.get('draft') else 'paper'} resolution, movies "
                  f"{'included' if meta.get('movies') else 'not included'}).", ""]
    for name, spec in FIGURES.items():
        if name not in numbers:
            continue
        nums = numbers[name]
        lines += [f"## {name}: {spec.heading(nums, nums.get('draft', False))}", "", f"![{name}]({nums['png']})", "",
                  f"*Paper:* {spec.paper}.  ", f"*Command:* `{spec.command}`  (source: {spec.source}; "
                  f"{nums['seconds']} s{', draft' if nums.get('draft') else ''})", ""]
        shown = {k: v for k, v in nums.items() if k not in _HIDDEN}
        if shown:
            lines += ["| measured | value |", "| --- | --- |"]
            lines += [f"| {k} | {_fmt(v)} |" for k, v in shown.items()]
            lines.append("")
    two_d = [name for name, spec in FIGURES.items() if spec.dims == "2d"]
    lines += ["## 2-D figures", "",
              f"The 2-D entries ({', '.join(two_d)}) use the x-periodic 2-D cell (`fv2d`, docs/sim2d.md) and the "
              "plane-wave analysis (docs/plane_waves.md); a further one is one "
              "`@register_figure(..., dims=\"2d\")` function in `icidr_pde/figures.py`.", ""]
    if movies:
        from .movies.registry import MOVIES, MOVIES_2D

        lines += ["## Supplementary movies 1-6 and the 2-D movie", "", "`icidr-pde figures --movies` (frames at a fixed "
                  "interval of simulated time; a failed run ends on its state at t*). Movies 7-8 of the paper are DEM "
                  "renderings and are not reproduced; `2d` (not in the paper) is drawn from the runs of `bump2d`, "
                  "frames every 1/59 of 98 % of mu(I)'s t* (1/29 in a draft) plus the state at t*.", "",
                  "| movie | content | frame interval | file |", "| --- | --- | --- | --- |"]
        for name, info in movies.items():
            spec = {**MOVIES, **MOVIES_2D}[name]
            caption = at_resolution(spec.caption, info.get("draft", False))
            lines.append(f"| {name[5:]} | {caption} | {info['frame_dt']:.4g} | [{info['file']}]({info['file']}) |")
        lines.append("")
    path = out / "README.md"
    text = "\n".join(lines)
    write_atomically(path, lambda fh: fh.write(text))
    return path


# --- command line ------------------------------------------------------------------------------------------------------

def add_parser(subparsers):
    p = subparsers.add_parser("figures", help="redraw the paper's figures (and movies 1-6) into docs/figures")
    p.description = ("Redraw the paper's figures (and movies) with numbers.json and a gallery page README.md. "
                     f"A --draft run writes into {DRAFT_OUT}/ unless --out names another folder, and never "
                     "into a folder holding a full-resolution gallery (docs/figures) without --force.")
    p.add_argument("--only", nargs="+", default=None, metavar="NAME",
                   help=f"figures to draw (default: all): {' '.join(FIGURES)}")
    p.add_argument("--out", default=None,
                   help=f"output folder (PNGs, numbers.json, README.md) "
                        f"(default: {GALLERY}, with --draft {DRAFT_OUT})")
    p.add_argument("--draft", action="store_true", help="N = 101 instead of 201 (same findings, a fraction of the cost)")
    p.add_argument("--force", action="store_true",
                   help="with --draft: write into --out even where it holds a full-resolution gallery")
    p.add_argument("--movies", nargs="*", default=None, metavar="MOVIE",
                   help="also write the movies (all, or those named: movie1 ... movie6, movie2d)")
    p.add_argument("--gif", action="store_true", help="movies as GIF instead of MP4")
    p.set_defaults(func=cmd_figures)
    return p


def _full_resolution(out: Path) -> bool:
    """True where `out` holds a gallery (numbers.json) with a figure drawn at the paper's resolution."""
    store = out / "numbers.json"
    try:
        figures = json.loads(store.read_text()).get("figures", {})
    except (OSError, ValueError):
        return False
    return any(not nums.get("draft", False) for nums in figures.values())


def cmd_figures(args) -> int:
    import datetime

    start = time.perf_counter()
    out = writable_folder("--out", args.out if args.out is not None else DRAFT_OUT if args.draft else GALLERY)
    if args.draft and not args.force and _full_resolution(out):
        raise ValueError(f"`out` {out} holds a full-resolution gallery that a draft would overwrite: "
                         f"omit --out (a draft goes to {DRAFT_OUT}), name another folder, or add --force")
    runs = RunCache(draft=args.draft, verbose=True)
    numbers = make_figures(args.only, out, draft=args.draft, runs=runs)
    movies = None
    if args.movies is not None:
        movies = make_movies(args.movies or None, out, draft=args.draft, runs=runs,
                             suffix=".gif" if args.gif else ".mp4")
    total = time.perf_counter() - start
    store = out / "numbers.json"
    previous = json.loads(store.read_text()) if store.exists() else {}
    figures = {**previous.get("figures", {}), **numbers}
    movies_all = {**previous.get("movies", {}), **(movies or {})}
    meta = previous.get("meta", {})
    if not args.only:  # a complete run: its time is the one to quote
        meta = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                "total_s": total, "draft": args.draft, "movies": movies is not None,
                "run_seconds": {k: round(v, 1) for k, v in runs.seconds.items()}}
    text = json.dumps({"meta": meta, "figures": figures, "movies": movies_all}, indent=1)
    write_atomically(store, lambda fh: fh.write(text))
    write_gallery(figures, out, movies_all or None, meta)
    print(f"{len(numbers)} figure(s){' and %d movie(s)' % len(movies) if movies else ''} in {out} ({total:.0f} s)")
    return 0
