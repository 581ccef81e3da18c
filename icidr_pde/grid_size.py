"""How many points a 1-D shear-cell scheme accepts: its largest N and the memory a run on N needs.

One table for both run paths, importing no py-pde: the discretizations
(:meth:`icidr_pde.discretizations.base.ShearCellBase.check_N`) and the native engine
(:class:`icidr_pde.native.NativeCase`) check N with :func:`check_N`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .validation import ParameterError, format_bytes, integer, memory_bytes

__all__ = ["GridLimit", "FD", "CHEB", "check_N"]


@dataclass(frozen=True)
class GridLimit:
    """The documented largest N, what a run's memory holds, and its size in bytes for N (roughly)."""

    max_N: int
    memory_note: str
    memory_estimate: Callable[[int], float]


def _fd_bytes(N: int) -> float:
    return 4000.0 * N  # ~4 kB per cell


def _cheb_bytes(N: int) -> float:
    return 8.0 * (3 * 9 * N**2 + 2 * N**2)


#: finite volumes: the run time, not the memory, grows like N^2
FD = GridLimit(100_000, "banded Jacobian and work vectors", _fd_bytes)
#: Chebyshev: the dense 3N x 3N Jacobian and its LU, ~2.5 GB at N = 4001
CHEB = GridLimit(4001, "dense 3N x 3N Jacobian, its LU and the N x N differentiation matrix", _cheb_bytes)


def check_N(scheme: str, N, limit: GridLimit) -> int:
    """N as an int in [4, limit.max_N] whose memory estimate fits into half this machine's memory."""
    N = integer("N", N, 4)
    need, have = limit.memory_estimate(N), memory_bytes()
    if N > limit.max_N or (have is not None and need > 0.5 * have):
        raise ParameterError(
            f"`N` = {N} is too large for discretization {scheme!r}: the maximum is {limit.max_N}, "
            f"and N = {N} needs about {format_bytes(need)} of memory ({limit.memory_note}); "
            f"this machine has {format_bytes(have) if have is not None else 'an unknown amount'}")
    return N
