"""Studies of the discrete system (fig 4b and the discretization comparisons).

* :mod:`.failure_time` -- t* of one case and sweeps over N (fig 4b), on the run path of ``run()``;
* :mod:`.discrete` -- t* against integrator and tolerance, Chebyshev convergence, figs 6-7 agreement;
* :mod:`.plots` -- the t*(N) figure; :mod:`.parallel` -- worker processes; :mod:`.cli` -- ``icidr-pde tstar``.
"""

from .discrete import compare_discretizations, spectral_convergence, tolerance_study
from .failure_time import PAPER_TSTAR, failure_time, parse_range, sweep, threshold, tstar_mapping
from .parallel import limit_blas_threads
from .plots import plot_tstar

__all__ = ["failure_time", "sweep", "parse_range", "tstar_mapping", "threshold", "PAPER_TSTAR", "plot_tstar",
           "tolerance_study", "spectral_convergence", "compare_discretizations", "limit_blas_threads"]
