"""The movies the project makes: the paper's supplementary movies 1-6 (:data:`MOVIES`), which show
the full time evolution behind figs 3, 6 and 7, and the 2-D movie (:data:`MOVIES_2D`, not in the
paper: mu(I),Phi(I) on scene bump2d up to its failure beside iCIDR at the same times).
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["MovieSpec", "MOVIES", "MOVIES_2D", "PAPER_SETTINGS"]


@dataclass(frozen=True)
class MovieSpec:
    """One supplementary movie: the run (keyword arguments of :func:`icidr_pde.run`) and
    the interval of simulated time between frames."""

    name: str
    caption: str
    run: dict = field(default_factory=dict)
    frame_dt: float = 0.05


# The paper's supplementary movies 1-6 (movies 7-8 are DEM renderings, not computed here).
#: ode15s-like settings as in the paper: BDF, rtol 1e-6, atol 1e-9 (also those of the figures' runs)
PAPER_SETTINGS = dict(method="BDF", rtol=1e-6, atol=1e-9)


def _paper_movie(name, caption, rheology, scene, N, discretization, frame_dt, t_end=10.0) -> MovieSpec:
    return MovieSpec(name, caption, dict(rheology=rheology, scene=scene, N=N, t_end=t_end,
                                         discretization=discretization, **PAPER_SETTINGS), frame_dt=frame_dt)


# The paper's supplementary movies 1-6 (movies 7-8 are DEM renderings, not computed here).
MOVIES = {spec.name: spec for spec in (
    _paper_movie("movie1", "mu(I),Phi(I), IC (3.16), finite volumes N = 201: blow-up (fig 3a)",
                 "mui", "shear", 201, "fd", frame_dt=2.5e-4),
    _paper_movie("movie2", "mu(I),Phi(I), IC (3.16), Chebyshev N = 201: blow-up (fig 3b)",
                 "mui", "shear", 201, "cheb", frame_dt=2.5e-4),
    _paper_movie("movie3", "mu(I),Phi(I), IC (3.16), finite volumes N = 47: decays (fig 3c)",
                 "mui", "shear", 47, "fd", frame_dt=0.1),
    _paper_movie("movie4", "iCIDR, IC (3.16), finite volumes N = 201 (fig 6)", "icidr", "shear", 201, "fd", frame_dt=0.1),
    _paper_movie("movie5", "iCIDR, IC (3.16), Chebyshev N = 201 (fig 6)", "icidr", "shear", 201, "cheb", frame_dt=0.1),
    _paper_movie("movie6", "iCIDR, IC (5.7), finite volumes N = 201 (fig 7)", "icidr", "sine", 201, "fd",
                 frame_dt=0.2, t_end=20.0),
)}


# The 2-D movie (not in the paper): bump2d, mu(I),Phi(I) up to its failure against iCIDR at the same times,
# drawn from the runs of the bump2d gallery figure (icidr_pde.figures.two_d.bump2d_pair: CVODE rtol 1e-7, atol 1e-10).
MOVIES_2D = {
    "movie2d": MovieSpec("movie2d", "2-D cell, scene bump2d: mu(I),Phi(I) up to its failure (an oblique band) "
                         "against iCIDR at the same times, w and phi - phi0 side by side",
                         dict(rheology=("mui", "icidr"), scene="bump2d", discretization="fv2d",
                              method="CVODE", rtol=1e-7, atol=1e-10), frame_dt=0.0),
}
