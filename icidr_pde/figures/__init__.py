"""Every figure of the paper the project can compute, and its supplementary movies 1-6.

``icidr-pde figures [--only fig3 fig7 ...] [--out docs/figures] [--draft] [--movies]``

Figures are entries of a registry (:data:`.registry.FIGURES`): a name, a one-line caption, the
paper's caption, the runs it needs and a function drawing it from those runs. The
runs (:data:`.runs.RUNS`, public :func:`icidr_pde.run` only) are made once per invocation
and shared: figs 3 and 4(a) use the same four mu(I) runs, figs 6 and 7 the iCIDR ones,
and the movies use the same runs' snapshots at their frame interval. Each figure
returns the numbers a reader compares with the paper (t*, max|w| extrema, chi > 0
intervals); :func:`.make.make_figures` writes them to ``numbers.json`` and a gallery page
(``README.md``) beside the PNGs.

Settings: the paper's integrator was ode15s; we use BDF with rtol 1e-6, atol 1e-9
(t* of mu(I) depends on integrator and tolerance, docs/performance.md "Failure time t* against the integrator"). The paper's
captions do not give the snapshot times of figs 3, 6 and 7; we use t = 0, 0.5, 1, 2, 5,
10 (fig 6) and t = 0, 1, 2, 3, 5, 10, 20 (fig 7, as in the DEM comparison), and for
the blow-ups of fig 3(a,b) snapshots every 0.0025 up to t*.

``draft=True`` (tests, notebooks in CI) replaces N = 201 by N = 101 and keeps every
other setting: the same figures, qualitatively the same findings, a fraction of the cost.
``icidr-pde figures --draft`` writes into ``figures-draft/`` (:data:`.cli.DRAFT_OUT`), never over
the committed gallery ``docs/figures`` unless told to (``--out docs/figures --force``); its
headings and movie titles name the grids drawn (:func:`.runs.at_resolution`).

Adding a figure: define its runs in :data:`.runs.RUNS` (or compute them inside the drawing
function, cached in the :class:`.runs.RunCache`) and decorate the drawing function with
:func:`.registry.register_figure` (``dims="2d"`` for the 2-D cell); ``icidr-pde figures`` and the
gallery pick it up. The 2-D entries: ``polar2d`` (Lambda_max(theta) of both laws at steady
shear, :mod:`stability.directional`), ``bump2d`` (mu(I) just before its failure against iCIDR
at the same time, scene ``bump2d``) and ``tstar2d`` (t*(N) in 2-D against the x-independent
1-D run, iCIDR's convergence: the committed :mod:`icidr_pde.studies.sim2d` results plus a fresh
run on the small grids); the 2-D movie ``movie2d`` is drawn from ``bump2d``'s runs.

Modules: :mod:`.runs` (the shared runs), :mod:`.registry`, :mod:`.panels` (what several figures
draw or measure), the figures (:mod:`.paper` figs 2-7, :mod:`.dem` figs 1 and 8, :mod:`.project`,
:mod:`.two_d`), :mod:`.make` (drawing them and the movies), :mod:`.gallery` (README.md) and
:mod:`.cli` (``icidr-pde figures``); :mod:`.sim2d_fields` draws the field images and movie of
docs/sim2d.md, :mod:`.tstar_plot` the t*(N) plot of ``icidr-pde tstar --plot``. Importing the package registers every figure.
"""

# each module registers its figures; the order of these imports is the gallery's
from . import paper  # noqa: F401, I001
from . import dem  # noqa: F401
from . import project  # noqa: F401
from . import two_d  # noqa: F401
