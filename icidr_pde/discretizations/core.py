"""What the py-pde-free core of every 1-D scheme shares: the law, the grid size, the walls'
velocity, the options, the validity of a state and the state's layouts.

A core (:class:`~.fd_core.FiniteVolumes`, :class:`~.cheb_core.Collocation`) is a scheme on
one grid of N points on 0 < z < H: its nodes ``z``, quadrature ``weights``, the initial
data from the scene's callables, the strain rates where the stresses live, the compiled
kernels (rates and Jacobian, from the scheme's template, :mod:`icidr_pde.rheology.codegen`)
and the structure of the Jacobian. It imports neither py-pde nor scipy nor numba (the
kernels are compiled or loaded on first use). The py-pde classes (:mod:`.fd`, :mod:`.cheb`)
and the native engine's cases are built on it.

Data are (3, N) arrays of (phi, u, w) at the nodes; the state vector y of an engine is
``pack(data)``: the fields in blocks (``data.ravel()``) unless the scheme orders them
otherwise (:attr:`Scheme1D.interleaved`).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..rheology import SHEAR_CELL, Material, Rheology, get_rheology
from ..validation import real
from .grid_size import check_N
from .registry import SCHEMES, check_options

__all__ = ["Scheme1D", "PhiRange", "ghost_coefficients"]


def ghost_coefficients(V0: float = 1.0) -> np.ndarray:
    """(3, 2, 2) ghost-cell maps of the walls (3.9): the ghost value of field k at side s
    (0: z = 0, 1: z = H) is ``c[k, s, 0] * edge + c[k, s, 1]``. phi zero gradient (ghost =
    edge), u = 0 and V0 and w = 0 as Dirichlet values on the wall (ghost = 2 value - edge)."""
    return np.array([[[1.0, 0.0], [1.0, 0.0]],
                     [[-1.0, 0.0], [-1.0, 2.0 * V0]],
                     [[-1.0, 0.0], [-1.0, 0.0]]])


class PhiRange:
    """The validity of a state (for any scheme with a ``material``): phi inside the law's
    inertial range at every node."""

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


class Scheme1D(PhiRange):
    """A 1-D scheme of the shear cell on N points of 0 < z < H with walls u(0) = 0,
    u(H) = V0, w = 0 (3.9), closed by `rheology` (a name or a Rheology, with `material`).

    Class attributes from the registry entry of ``name`` (:mod:`.registry`): ``label``,
    ``default_N``, ``options``, ``grid_limit``.
    """

    name: ClassVar[str] = ""
    fields: ClassVar[tuple[str, ...]] = ("phi", "u", "w")
    kinematics = SHEAR_CELL
    #: the engines' state vector holds the fields cell by cell (y[3 i + k]) rather than in blocks
    interleaved: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        entry = SCHEMES[cls.name]
        cls.label, cls.default_N, cls.options, cls.grid_limit = (entry.label, entry.default_N, entry.options,
                                                                 entry.grid_limit)

    def __init__(self, rheology: str | Rheology = "icidr", N: int | None = None, H: float = 30.0, *,
                 material: Material | None = None, V0: float = 1.0, **options):
        self.rheology = get_rheology(rheology, material)
        self.N = check_N(self.name, self.default_N if N is None else N, self.grid_limit)
        self.H = real("H", H, 0)
        if not np.isfinite(V0):
            raise ValueError(f"`V0` must be finite; got {V0}")
        self.V0 = float(V0)
        self.option_values = check_options(self.name, options)
        for key, value in self.option_values.items():
            setattr(self, key, value)

    @property
    def material(self) -> Material:
        return self.rheology.material

    # --- nodes, data and quadrature -----------------------------------------------------

    z: np.ndarray       #: positions of the unknowns
    weights: np.ndarray  #: quadrature weights: integral over the cell = weights . values

    def nodes(self) -> np.ndarray:
        """Positions of the unknowns (a copy of ``z``)."""
        return self.z.copy()

    def sample(self, phi, u, w) -> np.ndarray:
        """(3, N) data of the fields at the nodes from callables of z or arrays (or numbers)."""
        return np.array([np.broadcast_to(np.asarray(f(self.z) if callable(f) else f, float), (self.N,))
                         for f in (phi, u, w)], dtype=float)

    def initial_data(self, phi, u, w) -> np.ndarray:
        """The data of a state with these fields (:meth:`sample`; a scheme whose walls are
        unknowns sets them)."""
        return self.sample(phi, u, w)

    def integral(self, values) -> float:
        """The scheme's quadrature of a field over 0 < z < H (it conserves the mass of phi)."""
        return float(np.dot(self.weights, values))

    def mass(self, data) -> float:
        """The integral of phi (data[0])."""
        return self.integral(data[0])

    # --- state vector -------------------------------------------------------------------------

    def pack(self, data) -> np.ndarray:
        """The engines' state vector of (3, N) data."""
        data = np.asarray(data, dtype=float)
        return np.ascontiguousarray(data.T if self.interleaved else data).ravel()

    def unpack(self, y) -> np.ndarray:
        """(3, N) data of a state vector."""
        y = np.asarray(y)
        return np.ascontiguousarray(y.reshape(self.N, 3).T) if self.interleaved else y.reshape(3, self.N)

    def phi_of(self, y) -> np.ndarray:
        """phi of a state vector (a view)."""
        y = np.asarray(y)
        return y[0::3] if self.interleaved else y[:self.N]

    # --- kernels ----------------------------------------------------------------------------

    def loops(self):
        """The scheme's compiled kernels for its law (compiled or loaded from the disk cache)."""
        from ..rheology.codegen import compose

        return compose(self.template(), self.rheology.kernels(self.kinematics), name=self.name)

    @classmethod
    def template(cls) -> str:
        """The source of the scheme's kernels, ``templates/<name>.py``."""
        import importlib.resources

        cell = cls.__module__.rpartition(".")[0]  # the package of the core: its cell's folder
        return importlib.resources.files(cell).joinpath("templates", f"{cls.name}.py").read_text()
