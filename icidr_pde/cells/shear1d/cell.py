"""The descriptor of the 1-D shear cell (:class:`Shear1D`)."""

from __future__ import annotations

from ..base import Cell, Template

__all__ = ["Shear1D"]


class Shear1D(Cell):
    """The 1-D shear cell 0 < z < H between walls (3.9): finite volumes (``fd``, its band Jacobian
    in the interleaved ordering) and Chebyshev collocation (``cheb``, dense), scenes (3.16), (5.7)
    and bump2d's perturbation made x-independent."""

    name = "shear1d"
    dim = 1
    kinematics = "shear_cell"
    schemes = ("fd", "cheb")
    scenes = ("shear", "sine", "bump1d")
    scenes_module = "icidr_pde.cells.shear1d.scenes"
    grid_axes = ("N",)
    jacobian = {"fd": dict(banded=True, band_jac=True, sparse=True), "cheb": {}}
    native = {"fd": ("analytic", "band"), "cheb": ("analytic", "krylov", "band")}
    native_problems = {"fd": "icidr_pde.cells.shear1d.native:fd_problem",
                       "cheb": "icidr_pde.cells.shear1d.native_cheb:cheb_problem"}
    templates = (Template("templates/fd.py", "fd_", {"J": "FD_BAND_AT"}),
                 Template("templates/cheb.py", "cheb_", {"J": "COLUMN_MAJOR_AT", "B": "FD_BAND_AT"}))
    c_functions = {
        "icidr_fd_problem": "P: I D I *D *D I D D",
        "icidr_fd_jacobian": "-: P *D *D",
        "icidr_cheb_problem": "P: I *D *D I D D I D",
        "icidr_cheb_jacobian": "-: P *D *D",
        "icidr_cheb_krylov": "I: P I D L L I *D",
        "icidr_has_krylov": "I:",
        "icidr_cheb_conserve": "I: P *D",
        "icidr_cheb_low_order_jacobian": "-: P *D *D *D",
    }
