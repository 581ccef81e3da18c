"""Every study: what the runs of :func:`icidr_pde.run` say about the equations and their discretizations.

* :mod:`.failure_time` -- t* of one case and sweeps over N (fig 4b), on the run path of ``run()``;
* :mod:`.discrete` -- t* against integrator and tolerance, Chebyshev convergence, figs 6-7 agreement;
* :mod:`.grid_convergence` -- errors of coarse runs against a fine one and the observed order;
* :mod:`.references` -- converged reference solutions of the speed-accuracy study (data/reference);
* :mod:`.sim2d` -- the 2-D shear cell: grid convergence, t*(N), growth of oblique modes (data/sim2d);
* :mod:`.parallel` -- worker processes; :mod:`.distributed` -- the runs as dask tasks;
* :mod:`.case_cache` -- finished cases kept in a folder, so that an interrupted study resumes.

The command ``icidr-pde tstar`` is :mod:`icidr_pde.cli.tstar`, its figure :mod:`icidr_pde.figures.tstar_plot`.
"""

import importlib

from .failure_time import PAPER_TSTAR, failure_time, parse_range, sweep, threshold, tstar_mapping
from .parallel import limit_blas_threads

#: names of :mod:`.discrete`, imported when first asked for: a worker process of a sweep (which
#: unpickles a function of :mod:`.failure_time`) then does not import py-pde and scipy with it
_DISCRETE = ("compare_discretizations", "spectral_convergence", "tolerance_study")

__all__ = ["failure_time", "sweep", "parse_range", "tstar_mapping", "threshold", "PAPER_TSTAR",
           "tolerance_study", "spectral_convergence", "compare_discretizations", "limit_blas_threads"]


def __getattr__(name):
    if name in _DISCRETE:
        return getattr(importlib.import_module(".discrete", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
