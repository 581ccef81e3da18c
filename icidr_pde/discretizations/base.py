"""The discretization contract: what a scheme of the shear-cell equations provides to py-pde.

A discretization is a py-pde ``PDEBase`` subclass of :class:`ShearCellBase` registered under
its ``name`` in :data:`~.registry.SCHEMES` (the CLI, ``run()``, presets, studies and the
contract tests read that registry, which imports no py-pde; nothing tests names). The 1-D
schemes are thin adapters over their py-pde-free cores (:mod:`.fd_core`, :mod:`.cheb_core`,
one per grid: :meth:`ShearCellBase.core`). The contract is dimension-agnostic: ``grid.shape``
may have one axis (the 1-D cell) or more.

Class attributes
    ``name``; from the registry entry: ``label``, ``default_N`` (the N of a grid when none is
    given), ``options`` (keyword -> tuple of valid values, with the first the default; e.g.
    ``advection``), ``grid_limit``; ``kinematics`` (the :mod:`icidr_pde.rheology.kinematics`
    adapter whose rates the scheme feeds to the rheology: its kernels are
    ``rheology.kernels(kinematics)``).

State layout
    ``FieldCollection`` of the scalar fields ``fields`` (phi and the velocity components,
    here ``("phi", "u", "w")``) on the grid of :meth:`make_grid`; ``state.data`` has shape
    ``(len(fields), *grid.shape)`` and data[k][index] is field k at ``nodes(grid)[index]``.
    The stiff integrator works on ``state.data.ravel()`` (C order) and asks the scheme for
    permutations in that flat index.

Methods (abstract, so that a scheme lacking one cannot be built, unless marked optional)
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
    ``make_evolution_rate(state, backend)`` -- py-pde's hook (the same compiled kernels for
    every backend: the numpy implementations are test oracles, ``tests/oracles``);
    ``make_jacobian(state)`` -- ``jac(t, y)`` of the flat right-hand side,
    sparse (scipy) or dense; ``jacobian_sparsity(state)`` -- pattern for colored finite
    differences, or None if the Jacobian is dense; ``interleaving(state)`` --
    ``(perm, lband, uband)`` of an ordering ``y[perm]`` in which the Jacobian is banded, or
    None; ``check_state(data)`` -- why the state is outside the model's range (a string)
    or None; ``validity_margins(data)`` -- numbers that are all > 0 while the state is
    valid (the integrator locates their first zero crossing).
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Callable, ClassVar

import numpy as np
from pde import CartesianGrid, FieldCollection, ScalarField
from pde.pdes.base import PDEBase

from ..rheology import SHEAR_CELL, Material, Rheology, get_rheology
from ..validation import real
from .core import PhiRange
from .grid_size import FD, GridLimit, check_N
from .registry import SCHEMES, check_options, pypde_solver

__all__ = ["ShearCellBase"]


class ShearCellBase(PhiRange, PDEBase):
    """What every discretization of the shear cell shares: the rheology, the walls (3.9),
    state construction and the validity checks (see the module docstring).

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
    check_implementation = False  # py-pde's own check compares backends: here both are the compiled kernels

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        entry = SCHEMES.get(cls.__dict__.get("name", ""))
        if entry is not None:
            for key in ("label", "default_N", "options", "grid_limit"):
                if key not in cls.__dict__:
                    setattr(cls, key, getattr(entry, key))
            limit = cls.grid_limit
            cls.max_N, cls.memory_note = limit.max_N, limit.memory_note
            cls.memory_estimate = staticmethod(limit.memory_estimate)

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, **options):
        super().__init__()
        self.rheology = get_rheology(rheology, material)
        if not np.isfinite(V0):
            raise ValueError(f"`V0` must be finite; got {V0}")
        self.V0 = float(V0)
        for key, value in check_options(self.name, options).items():
            setattr(self, key, value)

    @property
    def material(self) -> Material:
        return self.rheology.material

    def option_values(self) -> dict:
        """The scheme's options as set (recorded with every result)."""
        return {key: getattr(self, key) for key in self.options}

    # --- grid and state -------------------------------------------------------------------

    #: documented largest N, and what a run on N points needs (:mod:`.grid_size`)
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

    @abstractmethod
    def nodes(self, grid) -> np.ndarray:
        """Positions of the unknowns."""

    @abstractmethod
    def make_state(self, grid, phi, u, w) -> FieldCollection:
        """The fields sampled at :meth:`nodes` from callables of the node positions or arrays."""

    @abstractmethod
    def integral(self, values: np.ndarray, grid) -> float:
        """The scheme's quadrature of a field over the cell (it conserves the mass of phi)."""

    @abstractmethod
    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        """(positions, phi, *rates) where the stresses are evaluated, rates in ``kinematics.rates`` order."""

    @abstractmethod
    def make_rates(self, state: FieldCollection) -> Callable:
        """rhs(data, t) from compiled kernels cached on disk."""

    def evolution_rate(self, state: FieldCollection, t: float = 0) -> FieldCollection:
        """The right-hand side at `state` (the compiled kernels)."""
        result = state.copy(label="evolution rate")
        result.data[:] = self.make_rates(state)(state.data, t)
        return result

    # --- what the stiff integrator asks -------------------------------------------------------

    @abstractmethod
    def make_jacobian(self, state) -> Callable:
        """jac(t, y) of the flat right-hand side, sparse (scipy) or dense."""

    @abstractmethod
    def jacobian_sparsity(self, state):
        """The pattern of the Jacobian for colored finite differences, or None if it is dense."""

    @abstractmethod
    def interleaving(self, state):
        """(perm, lband, uband) of an ordering ``y[perm]`` in which the Jacobian is banded, or None."""

    def solve(self, state, t_range, dt=None, tracker="auto", *, solver="stiff", **kwargs):
        """py-pde's ``solve`` with the stiff solver as the default (``solver="stiff"``).

        py-pde's own default, explicit Euler, is stable here only for steps ~h^2/p (how long
        that takes: docs/engines.md, "Integrators"). Any py-pde solver can still be named; "stiff" is registered with
        py-pde here, on first use (:func:`~.registry.pypde_solver`).
        """
        return super().solve(state, t_range, dt, tracker, solver=pypde_solver(solver), **kwargs)


class ShearCell1DBase(ShearCellBase):
    """A 1-D scheme's py-pde class: a thin adapter over its py-pde-free core
    (:meth:`core`, one per grid), which holds the nodes, quadrature, walls, strain rates and
    compiled kernels."""

    def core(self, grid):
        """The py-pde-free core of this scheme on `grid` (one per grid)."""
        self.check_grid(grid)
        N, (z0, H) = int(grid.shape[0]), grid.axes_bounds[0]
        key = (N, float(H))
        cores = self.__dict__.setdefault("_cores", {})
        if key not in cores:
            cores[key] = SCHEMES[self.name].core_class()(self.rheology, N, H, V0=self.V0, **self.option_values())
        return cores[key]

    def nodes(self, grid) -> np.ndarray:
        """Positions of the unknowns."""
        return self.core(grid).z.copy()

    def make_state(self, grid: CartesianGrid, phi, u, w) -> FieldCollection:
        """FieldCollection of phi, u, w sampled at :meth:`nodes` from callables or arrays."""
        return self.state_of(grid, self.core(grid).initial_data(phi, u, w))

    def state_of(self, grid, data) -> FieldCollection:
        """The FieldCollection of (3, N) `data` on `grid`."""
        return FieldCollection([ScalarField(grid, np.array(values, dtype=float), label=label)
                                for label, values in zip(self.fields, data)])

    def integral(self, values: np.ndarray, grid) -> float:
        """The scheme's quadrature over 0 < z < H of values at the nodes."""
        return self.core(grid).integral(values)

    def quadrature_weights(self, grid) -> np.ndarray:
        """Weights c of :meth:`integral` (integral = c . values)."""
        return self.core(grid).weights.copy()

    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        """Positions where the stresses live and (phi, u_z, w_z) there."""
        return self.core(grid).strain_rates(data)

    # --- right-hand side --------------------------------------------------------------------

    def make_rates(self, state: FieldCollection) -> Callable:
        """rhs(data, t) from the compiled kernels cached on disk."""
        return self.core(state.grid).make_rates(state.data)

    def make_evolution_rate(self, state: FieldCollection, backend="numba") -> Callable:
        """rhs(state_data, t) for any py-pde backend: the compiled kernels of :meth:`make_rates`
        (py-pde's numba backend compiles this thin wrapper; the scheme has no numpy copy)."""
        core = self.core(state.grid)
        if "_pde_rhs" not in core.__dict__:  # one wrapper per grid: py-pde compiles it once
            core._pde_rhs = core.make_rates(state.data, contiguous=False)
        return core._pde_rhs
