"""How large a grid a run accepts: each scheme's largest size, and the memory a run on it needs.

One table for every run path, importing no py-pde: the discretizations
(:meth:`icidr_pde.discretizations.base.ShearCellBase.check_N`, the 2-D scheme's
``make_grid``) and the native engine (:class:`icidr_pde.native.NativeCase`) check the grid
with :func:`check_N` / :func:`check_size` against the least a run of the scheme needs (the
estimate of its cheapest linear solver, :meth:`GridLimit.least`); the stiff solver adds what its
linear solver allocates (the solver's own ``memory``, :class:`icidr_pde.engines.linear.Memory`,
checked by :func:`check_path` before the integration starts), the native Chebyshev problem checks the estimate of its linear solver
(:meth:`GridLimit.estimate`: the dense LU's three dense 3N x 3N arrays, or the Krylov path's
D and vectors).
A run whose estimate exceeds half the memory available (:func:`~icidr_pde.validation.memory_bytes`)
is refused before any allocation.

What the estimates count: the 1-D finite volumes on the py-pde path with CVODE's band Jacobian,
one dense 3N x 3N array (scikit-sundae hands a band Jacobian over in a dense NEQ x NEQ array);
Chebyshev, the dense Jacobian and its LU, or on the Krylov path D, not a dense Jacobian; the 2-D
cell, the state, CVODE's history and 20 Krylov vectors of 3 Nx Nz each, plus what its linear
solver adds (the LU's fill-in, the AMG hierarchy, the x-Fourier factors, the line
preconditioner: :data:`icidr_pde.engines.linear.line.LINE_BYTES` and the like). The per-cell
constants were taken from measured peaks; the measurements and their commands are in
docs/scaling.md ("Memory: the measurements behind the grid-size estimates").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from ..validation import ParameterError, format_bytes, integer, memory_bytes

__all__ = ["GridLimit", "FD", "CHEB", "PLANE2D", "check_N", "check_size", "check_path", "check_memory"]


@dataclass(frozen=True)
class GridLimit:
    """The documented largest N (cells of a 2-D grid), what a run's memory holds, and its size
    in bytes for N (roughly); `paths`: (linear solver, what its run holds, its size) of linear
    solvers whose runs need another amount than `memory_estimate` (the scheme's default)."""

    max_N: int
    memory_note: str
    memory_estimate: Callable[[int], float]
    paths: tuple[tuple[str, str, Callable[[int], float]], ...] = field(default=())

    def estimate(self, N: int, linear_solver: str | None = None) -> tuple[float, str]:
        """(bytes, what they hold) of a run on N whose Newton systems `linear_solver` solves
        (None or one not in `paths`: the scheme's default, `memory_estimate`)."""
        for name, note, estimate in self.paths:
            if name == linear_solver:
                return estimate(N), note
        return self.memory_estimate(N), self.memory_note

    def check_run(self, what: str, n: int, N: int, method: str, memory) -> None:
        """Refuse a run on N (`what`: its grid, e.g. "`N` = 20000") of n unknowns whose scheme
        (:attr:`memory_estimate`) and linear solver (`method`, its `memory` for the n unknowns)
        do not fit (:func:`check_path`): the engines' py-pde adapter asks the scheme it is given."""
        check_path(what, self.memory_estimate(N), method, memory, self.memory_note)

    def least(self, N: int) -> tuple[float, str]:
        """(bytes, what they hold) of the cheapest run on N: what every run of the scheme needs."""
        return min([self.estimate(N)] + [self.estimate(N, name) for name, _, _ in self.paths])


def _fd_bytes(N: int) -> float:
    return 4000.0 * N  # ~4 kB per cell


def _cheb_bytes(N: int) -> float:
    return 8.0 * (3 * 9 * N**2 + 2 * N**2)


def _cheb_krylov_bytes(N: int) -> float:
    # D twice (the scheme's and the C problem's copy); per unknown the band J_lo (11 doubles) and
    # its LAPACK LU (16), CVODE's history and work vectors and GMRES's basis (about 35 vectors)
    return 8.0 * (2 * N**2 + 3 * N * (11 + 16 + 35))


def _plane2d_bytes(cells: int) -> float:
    # measured: GMRES alone 1.57 kB a cell above the floor at 256^2 (docs/scaling.md, the memory section)
    return 1700.0 * cells


#: finite volumes: the run time, not the memory, grows like N^2
FD = GridLimit(100_000, "banded Jacobian and work vectors", _fd_bytes)
#: Chebyshev: the dense 3N x 3N Jacobian and its LU, ~3.7 GB at N = 4001 (the dense LU of the py-pde
#: path and of the native engine's ``linear_solver="dense"``); the native engine's Newton-Krylov path
#: with the band preconditioner (:data:`icidr_pde.cells.shear1d.native_cheb.KRYLOV`, its default) stores no dense
#: 3N x 3N array: ~0.26 GB at N = 4001
CHEB = GridLimit(4001, "dense 3N x 3N Jacobian, its LU and the N x N differentiation matrix", _cheb_bytes,
                 paths=(("krylov", "the N x N differentiation matrix, the band preconditioner and its LU, "
                         "CVODE's and GMRES's vectors", _cheb_krylov_bytes),))
#: 2-D finite volumes, per cell of the Nx x Nz grid; at most 3 Nx Nz < 2^31 unknowns (the 32-bit
#: indices of the sparse Jacobian)
PLANE2D = GridLimit((2**31 - 1) // 3, "state, CVODE's history and Krylov basis: 1.7 kB a cell, measured",
                 _plane2d_bytes)


def _memory_text(need: float, note: str, have: int | None) -> str:
    shown = f"{format_bytes(have)} available" if have is not None else "an unknown amount of memory"
    return f"needs about {format_bytes(need)} of memory ({note}); this machine has {shown}"


def check_memory(subject: str, need: float, note: str, hint: str = "") -> None:
    """Refuse (ParameterError) a run needing `need` bytes beyond half the memory available;
    `subject` names the parameter and its value, e.g. "`N` = 20000 is too large ...: it"."""
    have = memory_bytes()
    if have is None or need <= 0.5 * have:
        return
    raise ParameterError(f"{subject} {_memory_text(need, note, have)} and a run may take half of it{hint}")


def check_size(subject: str, size: int, limit: GridLimit, unit: str = "") -> None:
    """Refuse a grid of `size` (N, or cells with `unit` " cells") beyond `limit.max_N` or whose least
    memory estimate does not fit into half the memory available; `subject` names the grid, e.g.
    "`N` = 20000 is too large for discretization 'fd'"."""
    need, note = limit.least(size)
    if size > limit.max_N:
        raise ParameterError(f"{subject}: the maximum is {limit.max_N}{unit}, and it "
                             f"{_memory_text(need, note, memory_bytes())}")
    check_memory(f"{subject}: it", need, note)


def check_N(scheme: str, N, limit: GridLimit) -> int:
    """N as an int in [4, limit.max_N] whose least memory estimate fits into half the memory available."""
    N = integer("N", N, 4)
    check_size(f"`N` = {N} is too large for discretization {scheme!r}", N, limit)
    return N


def check_path(what: str, scheme_bytes: float, method: str, memory, scheme_note: str = "") -> None:
    """Refuse a run (`what`: its grid, e.g. "`N` = 20000") whose scheme needs `scheme_bytes`
    (holding `scheme_note`) and whose linear solver allocates `memory` beyond it (the solver's
    :class:`~icidr_pde.engines.linear.Memory`: bytes, note, label, hint) that does not fit."""
    check_memory(f"{what} with method {method!r}, Jacobian {memory.label}", scheme_bytes + memory.bytes,
                 memory.note or scheme_note, memory.hint)
