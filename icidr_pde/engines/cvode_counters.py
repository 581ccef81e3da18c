"""CVODE's own counters, linear-solver set-up controls and the state of its last step, which
scikit-sundae does not expose.

scikit-sundae (1.2) reports only the right-hand side and Jacobian counts of a run and sets
none of CVODE's Newton-matrix reuse controls. SUNDIALS has both as plain C functions
(``CVodeGetNumSteps``, ``CVodeGetNumLinSolvSetups``, ``CVodeSetDeltaGammaMaxLSetup``,
``CVodeSetLSetupFrequency``..., ``CVodeGetCurrentTime`` and ``CVodeGetDky`` for the state of
the last accepted step); they are called here through ctypes on the shared library
scikit-sundae ships (scikit_sundae.libs/libsundials_cvode-*.so, already loaded by it) with
the integrator memory of its ``CVODE`` object.

That memory pointer is a private field of scikit-sundae's Cython class (after the object
header and its method table: ``mem``, then the SUNDIALS context ``ctx``). It is accepted only
where it proves itself: the first member of CVODE's memory block is its SUNDIALS context,
so ``*mem == ctx`` must hold, and CVODE's right-hand-side count must equal the one
scikit-sundae reports. Otherwise :func:`attach` returns None and the run goes on without
the counters (n_steps and n_lu None, as before).
"""

from __future__ import annotations

import ctypes
import glob
import os

import numpy as np

__all__ = ["CvodeCounters", "attach"]

_LIB = []
_COUNTERS = {"steps": "CVodeGetNumSteps", "rhs": "CVodeGetNumRhsEvals", "lu": "CVodeGetNumLinSolvSetups",
             "jac": "CVodeGetNumJacEvals", "error_test_failures": "CVodeGetNumErrTestFails",
             "newton_iterations": "CVodeGetNumNonlinSolvIters",
             "newton_failures": "CVodeGetNumNonlinSolvConvFails",
             "linear_iterations": "CVodeGetNumLinIters", "preconditioner_setups": "CVodeGetNumPrecEvals",
             "preconditioner_solves": "CVodeGetNumPrecSolves", "linear_failures": "CVodeGetNumLinConvFails"}


def _library():
    """The libsundials_cvode that scikit-sundae loaded (same path: the same handle), or None."""
    if not _LIB:
        try:
            import sksundae

            libs = os.path.join(os.path.dirname(os.path.dirname(sksundae.__file__)), "scikit_sundae.libs")
            paths = sorted(glob.glob(os.path.join(libs, "libsundials_cvode-*.so*")))
            _LIB.append(ctypes.CDLL(paths[0]) if len(paths) == 1 else None)
        except (ImportError, OSError):
            _LIB.append(None)
    return _LIB[0]


class CvodeCounters:
    """Counters and set-up controls of one scikit-sundae CVODE (see the module docstring)."""

    def __init__(self, lib, mem: int, owner, ctx: int | None = None):
        self.lib, self.mem, self.ctx = lib, ctypes.c_void_p(mem), ctypes.c_void_p(ctx)
        self._owner = owner  # keeps the CVODE memory alive as long as this object

    def get(self, name: str) -> int:
        value = ctypes.c_long()
        function = getattr(self.lib, _COUNTERS[name])
        function.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_long)]
        if function(self.mem, ctypes.byref(value)) != 0:
            raise RuntimeError(f"{_COUNTERS[name]} failed")
        return int(value.value)

    def all(self) -> dict:
        """Every counter of :data:`_COUNTERS` by its short name."""
        return {name: self.get(name) for name in _COUNTERS}

    def set_lsetup_reuse(self, delta_gamma: float | None = None, frequency: int | None = None,
                         jacobian_frequency: int | None = None) -> None:
        """How long CVODE keeps its factored Newton matrix I - gamma J (modified Newton):
        refactor when gamma changed by more than `delta_gamma` (relative; SUNDIALS' default
        0.3) or after `frequency` steps (default 20); a new Jacobian after at most
        `jacobian_frequency` steps (default 51). CVODE still refactors (and re-evaluates J)
        after a Newton convergence failure."""
        calls = (("CVodeSetDeltaGammaMaxLSetup", ctypes.c_double, delta_gamma),
                 ("CVodeSetLSetupFrequency", ctypes.c_long, frequency),
                 ("CVodeSetJacEvalFrequency", ctypes.c_long, jacobian_frequency))
        for name, kind, value in calls:
            if value is None:
                continue
            function = getattr(self.lib, name)
            function.argtypes = [ctypes.c_void_p, kind]
            if function(self.mem, kind(value)) != 0:
                raise ValueError(f"{name}({value}) refused by CVODE")


    def last_step(self, n: int) -> tuple[float, np.ndarray] | None:
        """(t, y) of CVODE's last accepted step, `n` unknowns: its current time
        (``CVodeGetCurrentTime``; a step that failed or was interrupted has been undone) and the
        state there, ``CVodeGetDky`` of order 0 at that time (the interpolant at its own node:
        the Nordsieck array's first column). None before the first step (no step size yet, no
        interpolant) or where CVODE refuses."""
        lib = self.lib
        if not self.ctx or self.get("steps") == 0:
            return None
        t = ctypes.c_double()
        lib.CVodeGetCurrentTime.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double)]
        if lib.CVodeGetCurrentTime(self.mem, ctypes.byref(t)) != 0:
            return None
        y = np.empty(n)
        # a serial vector on y's memory (sunindextype: scikit-sundae's build has int)
        lib.N_VMake_Serial.restype = ctypes.c_void_p
        lib.N_VMake_Serial.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
        lib.N_VDestroy.argtypes = [ctypes.c_void_p]
        lib.CVodeGetDky.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_int, ctypes.c_void_p]
        vector = lib.N_VMake_Serial(n, y.ctypes.data, self.ctx)
        if not vector:
            return None
        try:
            found = lib.CVodeGetDky(self.mem, t, 0, vector) == 0
        finally:
            lib.N_VDestroy(vector)  # y's memory stays numpy's
        return (float(t.value), y) if found else None

    def set_eps_lin(self, eps_lin: float) -> None:
        """The Krylov solver's tolerance factor (``CVodeSetEpsLin``, SUNDIALS' default 0.05): the
        iterative linear solves stop at a residual below eps_lin times the Newton tolerance."""
        function = self.lib.CVodeSetEpsLin
        function.argtypes = [ctypes.c_void_p, ctypes.c_double]
        if function(self.mem, ctypes.c_double(eps_lin)) != 0:
            raise ValueError(f"CVodeSetEpsLin({eps_lin}) refused by CVODE")


def attach(solver, nfev: int) -> CvodeCounters | None:
    """Counters of scikit-sundae's `solver` (a ``sksundae.cvode.CVODE`` after ``init_step``)
    whose right-hand-side count is `nfev` now; None where the checks of the module
    docstring fail."""
    lib = _library()
    inner = getattr(solver, "_CVODE__CVODE", None)
    if lib is None or inner is None or type(inner).__basicsize__ < 40:
        return None
    mem = ctypes.c_void_p.from_address(id(inner) + 24).value
    ctx = ctypes.c_void_p.from_address(id(inner) + 32).value
    if not mem or not ctx or ctypes.c_void_p.from_address(mem).value != ctx:
        return None
    counters = CvodeCounters(lib, mem, inner, ctx)
    try:
        return counters if counters.get("rhs") == nfev else None
    except (AttributeError, RuntimeError):
        return None
