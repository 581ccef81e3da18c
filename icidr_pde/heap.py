"""Large arrays served from the heap again once freed, not from fresh pages of the kernel.

glibc's malloc gives an allocation above its mmap threshold a mapping of its own and unmaps it
at free; the threshold adjusts itself upwards to what was freed, but only to 32 MiB. Each step
of a 2-D run allocates and frees arrays of the grid's size (the right-hand side's fields, the
FFTs of the x-Fourier inverse, Krylov work arrays): above 32 MiB (a field at 2048^2 cells is
33.5 MB) every one of them is a new mapping that the kernel fills page by page with zeros, a
page fault per 4 kB, again at every call. :func:`keep_freed_arrays` raises the threshold and the
heap's trim threshold to :data:`THRESHOLD` so that a freed array is reused by the next one of its
size: the same arithmetic on the same values (no number changes), without the faults.

The setting is the process's (malloc has one); a user's own choice, by glibc's environment
variables ``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_`` or ``GLIBC_TUNABLES``, is kept.
Elsewhere than glibc (macOS, musl) nothing is done. docs/performance.md, *Page faults of large
grids*, has what it saves and the command that measures it.
"""

from __future__ import annotations

import ctypes
import os
import sys

#: arrays up to this many bytes are reused from the heap; freed memory beyond it at the heap's
#: top goes back to the system (malloc's parameter is an int: at most 2 GiB - 1)
THRESHOLD = 1 << 30
#: mallopt's parameter numbers (glibc's malloc.h)
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
#: environment variables by which a user sets glibc's malloc (then left as set)
USER_SETTINGS = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")

_applied: bool | None = None


def keep_freed_arrays() -> bool:
    """Set malloc's mmap and trim thresholds to :data:`THRESHOLD` once per process (glibc only,
    not where the user set malloc's parameters). True where they are set (now or before)."""
    global _applied
    if _applied is None:
        _applied = _set_thresholds()
    return _applied


def _set_thresholds() -> bool:
    if not sys.platform.startswith("linux") or any(name in os.environ for name in USER_SETTINGS):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    # the trim threshold first: with it below the mmap threshold a freed array would be trimmed
    return bool(mallopt(M_TRIM_THRESHOLD, THRESHOLD)) and bool(mallopt(M_MMAP_THRESHOLD, THRESHOLD))
