"""The descriptor of the 2-D x-periodic cell (:class:`Plane2D`)."""

from __future__ import annotations

from ..base import Cell, Template

__all__ = ["Plane2D"]


class Plane2D(Cell):
    """The x-periodic 2-D cell 0 <= x < L, 0 < z < H between walls (3.9): finite volumes
    (``fv2d``) on Nx x Nz cells, a sparse Jacobian (every cell coupled to its 3 x 3
    neighbourhood), waves advected along x; its Result adds the grid along x and per-snapshot
    measures."""

    name = "plane2d"
    dim = 2
    kinematics = "plane_flow"
    schemes = ("fv2d",)
    scenes = ("bump2d", "mode2d")
    scenes_module = "icidr_pde.cells.plane2d.scenes"
    result_fields = ("Nx", "L", "measures")
    grid_axes = ("Nx", "Nz")
    jacobian = {"fv2d": dict(sparse=True, line=True, amg=True, advected=True)}
    native = {"fv2d": ("krylov", "gmres")}
    native_problems = {"fv2d": "icidr_pde.cells.plane2d.native:plane2d_problem"}
    native_cores = {"fv2d": "icidr_pde.cells.plane2d.core:PlaneCells"}
    templates = (Template("templates/plane2d.py", "plane2d_", names=("walls", "halo_into", "patch_rates")),)
    c_defines = ("#define LAW_INLINE inline __attribute__((always_inline))\n#define KERNEL_SCRATCH\n"
                 "#define LAW_POWI law_powi")
    c_functions = {"icidr_plane2d_problem": "P: I I D D I *D *D I D D I D"}
    profiles = False
    #: the largest grid (cells) on which 'auto' takes the native engine (unpreconditioned GMRES in C,
    #: no py-pde or numba to import) rather than the py-pde path's default, GMRES with the x-Fourier
    #: preconditioner: where the native engine measured faster whole-process (docs/engines.md);
    #: 'native' takes it on any grid
    native_auto_cells = 64 * 64

    def make_grid(self, pde, core):
        return pde.make_grid((core.Nx, core.Nz), core.H, L=core.L)

    def make_state(self, pde, grid, data):
        return pde.make_state(grid, *data)

    def points_along_z(self, core) -> int:
        return int(core.Nz)

    def owns_grid(self, N) -> bool:
        return isinstance(N, (tuple, list))

    def choice_grid(self, scene, N, scene_params=None) -> dict:
        """Its cells (Nx Nz) and whether it is a thin cell (hx > THIN_CELL hz)."""
        from ...scenes import Scene, get_scene
        from .core import grid_shape, thin_cell

        try:
            scene_obj = scene if isinstance(scene, Scene) else get_scene(scene, **(scene_params or {}))
            Nx, Nz, L = grid_shape(N, scene_obj.H, L=getattr(scene_obj, "L", None))
        except (ValueError, TypeError):
            return {}
        return dict(cells=Nx * Nz, thin_cell=thin_cell(Nx, Nz, L, scene_obj.H))

    def native_refusal(self, thin_cell: bool = False, cells: int | None = None) -> str:
        if thin_cell:
            return "a thin 2-D cell (hx > THIN_CELL hz: the py-pde path preconditions GMRES)"
        if cells is not None and cells > self.native_auto_cells:
            return (f"a 2-D grid of {cells} cells (> {self.native_auto_cells}: the py-pde path measured faster; "
                    "--engine native takes it)")
        return ""

    def result_extras(self, case, data) -> dict:
        """Nx, L and the measures (:func:`.core.measures`) of each snapshot; `case` is the run
        path's, on the py-pde-free core (``scheme``) or on the py-pde class and its grid."""
        from .core import measures

        core = getattr(case, "scheme", None)
        if core is not None:
            return dict(Nx=core.Nx, L=core.L, measures=[measures(core, None, case.scene, d) for d in data])
        grid = case.grid
        return dict(Nx=int(grid.shape[0]), L=float(grid.axes_bounds[0][1]),
                    measures=[measures(case.pde, grid, case.scene, d) for d in data])

    def result_summary(self, result) -> dict:
        out = dict(Nx=result.Nx, Nz=result.N, L=result.L)
        for key in ("max_phi_dev", "l2_velocity"):
            out[key] = {label: m[key] for label, m in zip(result.time_labels, result.measures)}
        return out
