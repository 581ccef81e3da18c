"""The discretization contract: what a scheme of the shear-cell equations provides.

A discretization is a py-pde ``PDEBase`` subclass of :class:`ShearCellBase` that
registers itself under its ``name`` in :data:`DISCRETIZATIONS` (the CLI, ``run()``,
presets, studies and the contract tests read that registry; nothing tests names). The
contract is dimension-agnostic: ``grid.shape`` may have one axis (the 1-D cell) or more.

Class attributes
    ``name``, ``label``; ``default_N`` (the N of a grid when none is given); ``options``
    (keyword -> tuple of valid values, with the first the default; e.g. ``advection``);
    ``kinematics`` (the :mod:`icidr_pde.rheology.kinematics` adapter whose rates the
    scheme feeds to the rheology: its kernels are ``rheology.kernels(kinematics)``).

State layout
    ``FieldCollection`` of the scalar fields ``fields`` (phi and the velocity components,
    here ``("phi", "u", "w")``) on the grid of :meth:`make_grid`; ``state.data`` has shape
    ``(len(fields), *grid.shape)`` and data[k][index] is field k at ``nodes(grid)[index]``.
    The stiff integrator works on ``state.data.ravel()`` (C order) and asks the scheme for
    permutations in that flat index.

Methods (all must be implemented unless marked optional)
    ``make_grid(N, H)`` / ``check_grid(grid)``; ``nodes(grid)`` -- positions of the
    unknowns, shape ``grid.shape`` (1-D) or ``(*grid.shape, dim)``; ``make_state(grid,
    phi, u, w)`` -- fields sampled at the nodes from callables of the node positions or
    arrays; ``integral(values, grid)`` -- the scheme's quadrature of a field over the cell
    (it conserves the mass integral of phi); ``quadrature_weights(grid)`` (optional) -- its
    weights c, integral = c . values (the integrator keeps c . phi conserved by its Newton
    updates with them); ``strain_rates(data, grid)`` -- ``(positions,
    phi, *rates)`` where the stresses are evaluated, rates in ``kinematics.rates`` order;
    ``make_rates(state)`` -- ``rhs(data, t) -> rates`` evaluated by compiled kernels cached
    on disk (no per-process compilation, see :mod:`icidr_pde.rheology.codegen`);
    ``make_evolution_rate(state, backend)`` -- py-pde's hook ('numpy' evaluates an
    independent numpy implementation, which the contract tests compare with
    ``make_rates``); ``make_jacobian(state)`` -- ``jac(t, y)`` of the flat right-hand side,
    sparse (scipy) or dense; ``jacobian_sparsity(state)`` -- pattern for colored finite
    differences, or None if the Jacobian is dense; ``interleaving(state)`` --
    ``(perm, lband, uband)`` of an ordering ``y[perm]`` in which the Jacobian is banded, or
    None; ``check_state(data)`` -- why the state is outside the model's range (a string)
    or None; ``validity_margins(data)`` -- numbers that are all > 0 while the state is
    valid (the integrator locates their first zero crossing).
"""

from __future__ import annotations

from typing import Callable, ClassVar

import numpy as np
from pde import CartesianGrid, FieldCollection, ScalarField
from pde.pdes.base import PDEBase

from ..engines import stiff  # noqa: F401  -- registers py-pde's "stiff" solver, the default of solve()
from ..rheology import SHEAR_CELL, Material, Rheology, get_rheology
from ..grid_size import FD, GridLimit, check_N
from ..validation import real

__all__ = ["ShearCellBase", "DISCRETIZATIONS", "get_discretization"]

#: name -> discretization class; filled by the subclasses themselves
DISCRETIZATIONS: dict[str, type] = {}


class ShearCellBase(PDEBase):
    """What every discretization of the shear cell shares: the rheology, the walls (3.9),
    state construction, the numpy rate and the validity checks (see the module docstring).

    Args:
        rheology: a registered rheology name ('mui': (3.6), (3.8); 'icidr': (4.12), (4.14))
            or a :class:`~icidr_pde.rheology.Rheology` instance
        material: laws and parameters of the material (default: Table 1)
        V0: velocity of the top wall (1 in the scalings (3.12))
        **options: the scheme's ``options`` (each must be one of its valid values)
    """

    name: ClassVar[str] = ""
    label: ClassVar[str] = ""
    default_N: ClassVar[int] = 0
    options: ClassVar[dict[str, tuple]] = {}
    fields: ClassVar[tuple[str, ...]] = ("phi", "u", "w")
    kinematics = SHEAR_CELL
    check_implementation = False  # make_rates is compared with the numpy path by the contract tests

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name"):
            DISCRETIZATIONS[cls.name] = cls

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, **options):
        super().__init__()
        self.rheology = get_rheology(rheology, material)
        if not np.isfinite(V0):
            raise ValueError(f"`V0` must be finite; got {V0}")
        self.V0 = float(V0)
        unknown = set(options) - set(self.options)
        if unknown:
            raise ValueError(f"unknown option(s) {sorted(unknown)} for discretization {self.name!r}; "
                             f"valid: {sorted(self.options)}")
        for key, valid in self.options.items():
            value = options.get(key, valid[0])
            if value not in valid:
                raise ValueError(f"`{key}` must be one of {valid}; got {value!r}")
            setattr(self, key, value)

    @property
    def material(self) -> Material:
        return self.rheology.material

    def option_values(self) -> dict:
        """The scheme's options as set (recorded with every result)."""
        return {key: getattr(self, key) for key in self.options}

    # --- grid and state -------------------------------------------------------------------

    #: documented largest N, and what a run on N points needs (:mod:`icidr_pde.grid_size`)
    grid_limit: ClassVar[GridLimit] = FD
    max_N: ClassVar[int] = FD.max_N
    memory_note: ClassVar[str] = FD.memory_note
    memory_estimate = staticmethod(FD.memory_estimate)

    @classmethod
    def check_N(cls, N) -> int:
        """N as an int in [4, max_N] whose memory estimate fits into half this machine's memory."""
        return check_N(cls.name, N, cls.grid_limit)

    @classmethod
    def make_grid(cls, N: int, H: float = 30.0) -> CartesianGrid:
        """The grid CartesianGrid([[0, H]], N) holding N values per field."""
        N = cls.check_N(N)
        return CartesianGrid([[0.0, real("H", H, 0)]], N)

    def check_grid(self, grid) -> None:
        if not isinstance(grid, CartesianGrid) or grid.num_axes != 1 or grid.periodic[0]:
            raise ValueError("`grid` must be a non-periodic 1-D CartesianGrid([[0, H]], N) "
                             f"(use {type(self).__name__}.make_grid)")

    def nodes(self, grid) -> np.ndarray:
        """Positions of the unknowns."""
        raise NotImplementedError

    def make_state(self, grid: CartesianGrid, phi, u, w) -> FieldCollection:
        """FieldCollection of phi, u, w sampled at :meth:`nodes` from callables or arrays."""
        self.check_grid(grid)
        z = self.nodes(grid)
        fields = []
        for label, f in zip(self.fields, (phi, u, w)):
            data = f(z) if callable(f) else np.broadcast_to(np.asarray(f, float), grid.shape)
            fields.append(ScalarField(grid, np.array(data, dtype=float), label=label))
        return FieldCollection(fields)

    def integral(self, values: np.ndarray, grid) -> float:
        raise NotImplementedError

    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        raise NotImplementedError

    # --- right-hand side --------------------------------------------------------------------

    def make_rates(self, state: FieldCollection) -> Callable:
        """rhs(data, t) from compiled kernels cached on disk."""
        raise NotImplementedError

    def evolution_rate(self, state: FieldCollection, t: float = 0) -> FieldCollection:
        """Numpy evaluation of the right-hand side."""
        rhs = self.make_evolution_rate(state, "numpy")
        result = state.copy(label="evolution rate")
        result.data[:] = rhs(state.data, t)
        return result

    # --- what the stiff integrator asks -------------------------------------------------------

    def make_jacobian(self, state) -> Callable:
        raise NotImplementedError

    def jacobian_sparsity(self, state):
        raise NotImplementedError

    def interleaving(self, state):
        raise NotImplementedError

    def solve(self, state, t_range, dt=None, tracker="auto", *, solver="stiff", **kwargs):
        """py-pde's ``solve`` with the stiff solver as the default (``solver="stiff"``).

        py-pde's own default, explicit Euler, is stable here only for steps ~h^2/p: 158 s
        for t = 1 at N = 101. Any py-pde solver can still be named.
        """
        return super().solve(state, t_range, dt, tracker, solver=solver, **kwargs)

    def check_state(self, data: np.ndarray) -> str | None:
        """Reason why `data` is outside the inertial regime, or None if it is valid."""
        phi = data[0]
        lo, hi = self.validity_bounds()
        if np.all(phi > lo) and np.all(phi < hi):
            return None
        lo_name, hi_name = self.material.dilatancy.range_names()
        return (f"phi left ({lo_name}, {hi_name}) = ({lo:g}, {hi}): "
                f"min {phi.min():.6g}, max {phi.max():.6g}")

    def validity_margins(self, data: np.ndarray) -> np.ndarray:
        """Distances of phi from the ends of its inertial range; all positive while valid."""
        phi = data[0]
        lo, hi = self.validity_bounds()
        return np.array([phi.min() - lo, hi - phi.max()])

    def validity_bounds(self) -> tuple[float, float]:
        """(lo, hi) of :meth:`validity_margins` and :meth:`check_state`: the state is valid
        while lo < phi < hi at every node (the stiff integrator evaluates this on its own
        vector, at every step, without reordering it). A subclass that redefines validity
        redefines this too, or sets it to None."""
        return self.material.phi_range


def get_discretization(name) -> type:
    """The discretization class registered as `name`."""
    if isinstance(name, type) and issubclass(name, ShearCellBase):
        return name
    try:
        return DISCRETIZATIONS[name]
    except (KeyError, TypeError):
        raise ValueError(f"`discretization` must be one of {sorted(DISCRETIZATIONS)}; "
                         f"got {name!r}") from None
