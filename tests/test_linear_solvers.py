"""The linear solvers as registered objects (icidr_pde.engines.linear).

* The choices of :func:`~icidr_pde.engines.choose.choose` over a table of cases (1-D fd and cheb at
  several N, 2-D grids of 32^2 to 1024^2 cells, thick and thin, every method, Jacobian and engine
  request) are those it made before the linear solvers were a registry: :data:`TABLE` was computed
  by the choose() of that commit and is written here, not derived from the code under test.
* A preconditioner is one subclass: :class:`ToyPreconditioned`, defined in this file only, is
  chosen where its Jacobian mode is asked for, counted by the memory check, set up by CVODE's engine
  and solves the run, and is gone from the registry afterwards.
"""

import numpy as np
import pytest

from icidr_pde.cells import choice_asks
from icidr_pde.engines.choose import choose
from icidr_pde.engines.linear import SOLVERS, jacobian_modes, unregister
from icidr_pde.engines.linear.gmres import Preconditioned
from icidr_pde.validation import ParameterError

#: the Jacobians of each row of TABLE, in its order (None: the method's default)
JACOBIANS = (None, "analytic", "sparse-fd", "banded-fd", "colored-fd", "krylov", "amg", "fourier", "sparse", "none")
METHODS = ("BDF", "Radau", "LSODA", "CVODE", "PETSC-BDF")
REQUESTS = ("auto", "native", "pde", "petsc")

# the behaviour before the registry: computed by choose() of the base commit (94a6a31), one
# outcome code per case and Jacobian
#: outcome code -> 'engine / jacobian / linear solver / max_order', or '! ' and the first 60 characters
#: of the ParameterError's message
OUTCOMES = {
    "A": "scipy / analytic / SuperLU / 5",
    "B": "petsc / sparse / PETSc TS bdf + SNES newtonls + KSP gmres + PC bjacobi / 5",
    "C": "! `jacobian` must be 'sparse' on the PETSc engine; got 'analyt",
    "D": "scipy / sparse-fd / SuperLU / 5",
    "E": "! `jacobian` must be 'sparse' on the PETSc engine; got 'sparse",
    "F": "! `jacobian` must be one of ('analytic', 'sparse-fd', 'colored",
    "G": "! `jacobian` must be 'sparse' on the PETSc engine; got 'banded",
    "H": "scipy / colored-fd / SuperLU / 5",
    "I": "! `jacobian` must be 'sparse' on the PETSc engine; got 'colore",
    "J": "! `jacobian` must be 'sparse' on the PETSc engine; got 'krylov",
    "K": "! `jacobian` must be 'sparse' on the PETSc engine; got 'amg'",
    "L": "! `jacobian` must be 'sparse' on the PETSc engine; got 'fourie",
    "M": "scipy / none / dense LU (LAPACK) / 5",
    "N": "! `jacobian` must be 'sparse' on the PETSc engine; got 'none'",
    "O": "scipy / banded-fd / band LU (LSODA) / 5",
    "P": "scipy / analytic / dense LU (LSODA) / 5",
    "Q": "! `jacobian` must be one of ('banded-fd', 'analytic', 'none') ",
    "R": "scipy / none / dense LU (LSODA) / 5",
    "S": "native / analytic / band LU / 5",
    "T": "sundae / analytic / band LU / 5",
    "U": "! `jacobian` must be one of ('analytic', 'banded-fd', 'krylov'",
    "V": "sundae / banded-fd / band LU / 5",
    "W": "sundae / krylov / GMRES / 5",
    "X": "! `jacobian`='amg' (GMRES preconditioned by algebraic multigri",
    "Y": "! `jacobian`='fourier' (GMRES preconditioned by the x-average ",
    "Z": "sundae / sparse / SuperLU_MT / 5",
    "a": "sundae / none / dense LU / 5",
    "b": "scipy / analytic / dense LU (LAPACK) / 5",
    "c": "! `engine`='petsc' needs a discretization with a sparse Jacobi",
    "d": "! `jacobian`='sparse-fd' needs a sparse Jacobian; this discret",
    "e": "! `jacobian`='colored-fd' needs a sparse Jacobian; this discre",
    "f": "! `jacobian`='banded-fd' needs a discretization with a banded ",
    "g": "native / analytic / GMRES + band preconditioner / 5",
    "h": "sundae / analytic / dense LU (LAPACK) / 5",
    "i": "scipy / analytic / SuperLU / 2",
    "k": "scipy / sparse-fd / SuperLU / 2",
    "l": "scipy / colored-fd / SuperLU / 2",
    "m": "scipy / none / dense LU (LAPACK) / 2",
    "n": "scipy / analytic / dense LU (LSODA) / 2",
    "o": "scipy / none / dense LU (LSODA) / 2",
    "p": "native / krylov / GMRES / 2",
    "q": "sundae / fourier / GMRES + x-Fourier preconditioner / 2",
    "r": "sundae / analytic / dense LU (LAPACK) / 2",
    "s": "sundae / krylov / GMRES (line preconditioner in thin cells) / 2",
    "t": "sundae / amg / GMRES + AMG preconditioner / 2",
    "u": "sundae / sparse / SuperLU_MT / 2",
    "v": "sundae / none / dense LU / 2",
    "w": "! `jacobian`='none' with method 'BDF' on the 2-D cell is a den",
    "x": "! `jacobian`='none' with method 'Radau' on the 2-D cell is a d",
    "y": "! `method`='LSODA' on the 2-D cell is a dense LU (LSODA) of 3 ",
    "z": "! `jacobian`='analytic' with method 'LSODA' on the 2-D cell is",
    "0": "! `jacobian`='none' with method 'LSODA' on the 2-D cell is a d",
    "1": "! `jacobian`='analytic' with method 'CVODE' on the 2-D cell is",
    "2": "! `jacobian`='none' with method 'CVODE' on the 2-D cell is a d",
    # since: PETSc's GMRES on the 2-D cell is preconditioned by the x-Fourier inverse (issue 39)
    "3": "petsc / sparse / PETSc TS bdf + SNES newtonls + KSP gmres + PC x-Fourier / 2",
}
#: 'discretization size thin|- method request' -> one outcome code per jacobian of JACOBIANS
TABLE = {
    "fd 21 - BDF auto": "AADFHFFFFM",
    "fd 21 - BDF native": "AADFHFFFFM",
    "fd 21 - BDF pde": "AADFHFFFFM",
    "fd 21 - BDF petsc": "BCEGIJKLBN",
    "fd 21 - Radau auto": "AADFHFFFFM",
    "fd 21 - Radau native": "AADFHFFFFM",
    "fd 21 - Radau pde": "AADFHFFFFM",
    "fd 21 - Radau petsc": "BCEGIJKLBN",
    "fd 21 - LSODA auto": "OPQOQQQQQR",
    "fd 21 - LSODA native": "OPQOQQQQQR",
    "fd 21 - LSODA pde": "OPQOQQQQQR",
    "fd 21 - LSODA petsc": "BCEGIJKLBN",
    "fd 21 - CVODE auto": "SSUVUWXYZa",
    "fd 21 - CVODE native": "SSUVUWXYZa",
    "fd 21 - CVODE pde": "TTUVUWXYZa",
    "fd 21 - CVODE petsc": "BCEGIJKLBN",
    "fd 21 - PETSC-BDF auto": "BCEGIJKLBN",
    "fd 21 - PETSC-BDF native": "BCEGIJKLBN",
    "fd 21 - PETSC-BDF pde": "BCEGIJKLBN",
    "fd 21 - PETSC-BDF petsc": "BCEGIJKLBN",
    "fd 201 - BDF auto": "AADFHFFFFM",
    "fd 201 - BDF native": "AADFHFFFFM",
    "fd 201 - BDF pde": "AADFHFFFFM",
    "fd 201 - BDF petsc": "BCEGIJKLBN",
    "fd 201 - Radau auto": "AADFHFFFFM",
    "fd 201 - Radau native": "AADFHFFFFM",
    "fd 201 - Radau pde": "AADFHFFFFM",
    "fd 201 - Radau petsc": "BCEGIJKLBN",
    "fd 201 - LSODA auto": "OPQOQQQQQR",
    "fd 201 - LSODA native": "OPQOQQQQQR",
    "fd 201 - LSODA pde": "OPQOQQQQQR",
    "fd 201 - LSODA petsc": "BCEGIJKLBN",
    "fd 201 - CVODE auto": "SSUVUWXYZa",
    "fd 201 - CVODE native": "SSUVUWXYZa",
    "fd 201 - CVODE pde": "TTUVUWXYZa",
    "fd 201 - CVODE petsc": "BCEGIJKLBN",
    "fd 201 - PETSC-BDF auto": "BCEGIJKLBN",
    "fd 201 - PETSC-BDF native": "BCEGIJKLBN",
    "fd 201 - PETSC-BDF pde": "BCEGIJKLBN",
    "fd 201 - PETSC-BDF petsc": "BCEGIJKLBN",
    "fd 2001 - BDF auto": "AADFHFFFFM",
    "fd 2001 - BDF native": "AADFHFFFFM",
    "fd 2001 - BDF pde": "AADFHFFFFM",
    "fd 2001 - BDF petsc": "BCEGIJKLBN",
    "fd 2001 - Radau auto": "AADFHFFFFM",
    "fd 2001 - Radau native": "AADFHFFFFM",
    "fd 2001 - Radau pde": "AADFHFFFFM",
    "fd 2001 - Radau petsc": "BCEGIJKLBN",
    "fd 2001 - LSODA auto": "OPQOQQQQQR",
    "fd 2001 - LSODA native": "OPQOQQQQQR",
    "fd 2001 - LSODA pde": "OPQOQQQQQR",
    "fd 2001 - LSODA petsc": "BCEGIJKLBN",
    "fd 2001 - CVODE auto": "SSUVUWXYZa",
    "fd 2001 - CVODE native": "SSUVUWXYZa",
    "fd 2001 - CVODE pde": "TTUVUWXYZa",
    "fd 2001 - CVODE petsc": "BCEGIJKLBN",
    "fd 2001 - PETSC-BDF auto": "BCEGIJKLBN",
    "fd 2001 - PETSC-BDF native": "BCEGIJKLBN",
    "fd 2001 - PETSC-BDF pde": "BCEGIJKLBN",
    "fd 2001 - PETSC-BDF petsc": "BCEGIJKLBN",
    "cheb 21 - BDF auto": "bbdFeFFFFM",
    "cheb 21 - BDF native": "bbdFeFFFFM",
    "cheb 21 - BDF pde": "bbdFeFFFFM",
    "cheb 21 - BDF petsc": "cccccccccc",
    "cheb 21 - Radau auto": "bbdFeFFFFM",
    "cheb 21 - Radau native": "bbdFeFFFFM",
    "cheb 21 - Radau pde": "bbdFeFFFFM",
    "cheb 21 - Radau petsc": "cccccccccc",
    "cheb 21 - LSODA auto": "PPQfQQQQQR",
    "cheb 21 - LSODA native": "PPQfQQQQQR",
    "cheb 21 - LSODA pde": "PPQfQQQQQR",
    "cheb 21 - LSODA petsc": "cccccccccc",
    "cheb 21 - CVODE auto": "ggUfUWXYZa",
    "cheb 21 - CVODE native": "ggUfUWXYZa",
    "cheb 21 - CVODE pde": "hhUfUWXYZa",
    "cheb 21 - CVODE petsc": "cccccccccc",
    "cheb 21 - PETSC-BDF auto": "cccccccccc",
    "cheb 21 - PETSC-BDF native": "cccccccccc",
    "cheb 21 - PETSC-BDF pde": "cccccccccc",
    "cheb 21 - PETSC-BDF petsc": "cccccccccc",
    "cheb 201 - BDF auto": "bbdFeFFFFM",
    "cheb 201 - BDF native": "bbdFeFFFFM",
    "cheb 201 - BDF pde": "bbdFeFFFFM",
    "cheb 201 - BDF petsc": "cccccccccc",
    "cheb 201 - Radau auto": "bbdFeFFFFM",
    "cheb 201 - Radau native": "bbdFeFFFFM",
    "cheb 201 - Radau pde": "bbdFeFFFFM",
    "cheb 201 - Radau petsc": "cccccccccc",
    "cheb 201 - LSODA auto": "PPQfQQQQQR",
    "cheb 201 - LSODA native": "PPQfQQQQQR",
    "cheb 201 - LSODA pde": "PPQfQQQQQR",
    "cheb 201 - LSODA petsc": "cccccccccc",
    "cheb 201 - CVODE auto": "ggUfUWXYZa",
    "cheb 201 - CVODE native": "ggUfUWXYZa",
    "cheb 201 - CVODE pde": "hhUfUWXYZa",
    "cheb 201 - CVODE petsc": "cccccccccc",
    "cheb 201 - PETSC-BDF auto": "cccccccccc",
    "cheb 201 - PETSC-BDF native": "cccccccccc",
    "cheb 201 - PETSC-BDF pde": "cccccccccc",
    "cheb 201 - PETSC-BDF petsc": "cccccccccc",
    "cheb 2001 - BDF auto": "bbdFeFFFFM",
    "cheb 2001 - BDF native": "bbdFeFFFFM",
    "cheb 2001 - BDF pde": "bbdFeFFFFM",
    "cheb 2001 - BDF petsc": "cccccccccc",
    "cheb 2001 - Radau auto": "bbdFeFFFFM",
    "cheb 2001 - Radau native": "bbdFeFFFFM",
    "cheb 2001 - Radau pde": "bbdFeFFFFM",
    "cheb 2001 - Radau petsc": "cccccccccc",
    "cheb 2001 - LSODA auto": "PPQfQQQQQR",
    "cheb 2001 - LSODA native": "PPQfQQQQQR",
    "cheb 2001 - LSODA pde": "PPQfQQQQQR",
    "cheb 2001 - LSODA petsc": "cccccccccc",
    "cheb 2001 - CVODE auto": "ggUfUWXYZa",
    "cheb 2001 - CVODE native": "ggUfUWXYZa",
    "cheb 2001 - CVODE pde": "hhUfUWXYZa",
    "cheb 2001 - CVODE petsc": "cccccccccc",
    "cheb 2001 - PETSC-BDF auto": "cccccccccc",
    "cheb 2001 - PETSC-BDF native": "cccccccccc",
    "cheb 2001 - PETSC-BDF pde": "cccccccccc",
    "cheb 2001 - PETSC-BDF petsc": "cccccccccc",
    "fv2d 1024 - BDF auto": "iikFlFFFFm",
    "fv2d 1024 - BDF native": "iikFlFFFFm",
    "fv2d 1024 - BDF pde": "iikFlFFFFm",
    "fv2d 1024 - BDF petsc": "3CEGIJKL3N",
    "fv2d 1024 - Radau auto": "iikFlFFFFm",
    "fv2d 1024 - Radau native": "iikFlFFFFm",
    "fv2d 1024 - Radau pde": "iikFlFFFFm",
    "fv2d 1024 - Radau petsc": "3CEGIJKL3N",
    "fv2d 1024 - LSODA auto": "nnQfQQQQQo",
    "fv2d 1024 - LSODA native": "nnQfQQQQQo",
    "fv2d 1024 - LSODA pde": "nnQfQQQQQo",
    "fv2d 1024 - LSODA petsc": "3CEGIJKL3N",
    "fv2d 1024 - CVODE auto": "prUfUptquv",
    "fv2d 1024 - CVODE native": "prUfUptquv",
    "fv2d 1024 - CVODE pde": "qrUfUstquv",
    "fv2d 1024 - CVODE petsc": "3CEGIJKL3N",
    "fv2d 1024 - PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 1024 - PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 1024 - PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 1024 - PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 1024 thin BDF auto": "iikFlFFFFm",
    "fv2d 1024 thin BDF native": "iikFlFFFFm",
    "fv2d 1024 thin BDF pde": "iikFlFFFFm",
    "fv2d 1024 thin BDF petsc": "3CEGIJKL3N",
    "fv2d 1024 thin Radau auto": "iikFlFFFFm",
    "fv2d 1024 thin Radau native": "iikFlFFFFm",
    "fv2d 1024 thin Radau pde": "iikFlFFFFm",
    "fv2d 1024 thin Radau petsc": "3CEGIJKL3N",
    "fv2d 1024 thin LSODA auto": "nnQfQQQQQo",
    "fv2d 1024 thin LSODA native": "nnQfQQQQQo",
    "fv2d 1024 thin LSODA pde": "nnQfQQQQQo",
    "fv2d 1024 thin LSODA petsc": "3CEGIJKL3N",
    "fv2d 1024 thin CVODE auto": "srUfUstquv",
    "fv2d 1024 thin CVODE native": "srUfUstquv",
    "fv2d 1024 thin CVODE pde": "srUfUstquv",
    "fv2d 1024 thin CVODE petsc": "3CEGIJKL3N",
    "fv2d 1024 thin PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 1024 thin PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 1024 thin PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 1024 thin PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 4096 - BDF auto": "iikFlFFFFw",
    "fv2d 4096 - BDF native": "iikFlFFFFw",
    "fv2d 4096 - BDF pde": "iikFlFFFFw",
    "fv2d 4096 - BDF petsc": "3CEGIJKL3N",
    "fv2d 4096 - Radau auto": "iikFlFFFFx",
    "fv2d 4096 - Radau native": "iikFlFFFFx",
    "fv2d 4096 - Radau pde": "iikFlFFFFx",
    "fv2d 4096 - Radau petsc": "3CEGIJKL3N",
    "fv2d 4096 - LSODA auto": "yzQfQQQQQ0",
    "fv2d 4096 - LSODA native": "yzQfQQQQQ0",
    "fv2d 4096 - LSODA pde": "yzQfQQQQQ0",
    "fv2d 4096 - LSODA petsc": "3CEGIJKL3N",
    "fv2d 4096 - CVODE auto": "p1UfUptqu2",
    "fv2d 4096 - CVODE native": "p1UfUptqu2",
    "fv2d 4096 - CVODE pde": "q1UfUstqu2",
    "fv2d 4096 - CVODE petsc": "3CEGIJKL3N",
    "fv2d 4096 - PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 4096 - PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 4096 - PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 4096 - PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 4096 thin BDF auto": "iikFlFFFFw",
    "fv2d 4096 thin BDF native": "iikFlFFFFw",
    "fv2d 4096 thin BDF pde": "iikFlFFFFw",
    "fv2d 4096 thin BDF petsc": "3CEGIJKL3N",
    "fv2d 4096 thin Radau auto": "iikFlFFFFx",
    "fv2d 4096 thin Radau native": "iikFlFFFFx",
    "fv2d 4096 thin Radau pde": "iikFlFFFFx",
    "fv2d 4096 thin Radau petsc": "3CEGIJKL3N",
    "fv2d 4096 thin LSODA auto": "yzQfQQQQQ0",
    "fv2d 4096 thin LSODA native": "yzQfQQQQQ0",
    "fv2d 4096 thin LSODA pde": "yzQfQQQQQ0",
    "fv2d 4096 thin LSODA petsc": "3CEGIJKL3N",
    "fv2d 4096 thin CVODE auto": "s1UfUstqu2",
    "fv2d 4096 thin CVODE native": "s1UfUstqu2",
    "fv2d 4096 thin CVODE pde": "s1UfUstqu2",
    "fv2d 4096 thin CVODE petsc": "3CEGIJKL3N",
    "fv2d 4096 thin PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 4096 thin PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 4096 thin PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 4096 thin PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 16384 - BDF auto": "iikFlFFFFw",
    "fv2d 16384 - BDF native": "iikFlFFFFw",
    "fv2d 16384 - BDF pde": "iikFlFFFFw",
    "fv2d 16384 - BDF petsc": "3CEGIJKL3N",
    "fv2d 16384 - Radau auto": "iikFlFFFFx",
    "fv2d 16384 - Radau native": "iikFlFFFFx",
    "fv2d 16384 - Radau pde": "iikFlFFFFx",
    "fv2d 16384 - Radau petsc": "3CEGIJKL3N",
    "fv2d 16384 - LSODA auto": "yzQfQQQQQ0",
    "fv2d 16384 - LSODA native": "yzQfQQQQQ0",
    "fv2d 16384 - LSODA pde": "yzQfQQQQQ0",
    "fv2d 16384 - LSODA petsc": "3CEGIJKL3N",
    "fv2d 16384 - CVODE auto": "q1UfUstqu2",
    "fv2d 16384 - CVODE native": "p1UfUptqu2",
    "fv2d 16384 - CVODE pde": "q1UfUstqu2",
    "fv2d 16384 - CVODE petsc": "3CEGIJKL3N",
    "fv2d 16384 - PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 16384 - PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 16384 - PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 16384 - PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 16384 thin BDF auto": "iikFlFFFFw",
    "fv2d 16384 thin BDF native": "iikFlFFFFw",
    "fv2d 16384 thin BDF pde": "iikFlFFFFw",
    "fv2d 16384 thin BDF petsc": "3CEGIJKL3N",
    "fv2d 16384 thin Radau auto": "iikFlFFFFx",
    "fv2d 16384 thin Radau native": "iikFlFFFFx",
    "fv2d 16384 thin Radau pde": "iikFlFFFFx",
    "fv2d 16384 thin Radau petsc": "3CEGIJKL3N",
    "fv2d 16384 thin LSODA auto": "yzQfQQQQQ0",
    "fv2d 16384 thin LSODA native": "yzQfQQQQQ0",
    "fv2d 16384 thin LSODA pde": "yzQfQQQQQ0",
    "fv2d 16384 thin LSODA petsc": "3CEGIJKL3N",
    "fv2d 16384 thin CVODE auto": "s1UfUstqu2",
    "fv2d 16384 thin CVODE native": "s1UfUstqu2",
    "fv2d 16384 thin CVODE pde": "s1UfUstqu2",
    "fv2d 16384 thin CVODE petsc": "3CEGIJKL3N",
    "fv2d 16384 thin PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 16384 thin PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 16384 thin PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 16384 thin PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 65536 - BDF auto": "iikFlFFFFw",
    "fv2d 65536 - BDF native": "iikFlFFFFw",
    "fv2d 65536 - BDF pde": "iikFlFFFFw",
    "fv2d 65536 - BDF petsc": "3CEGIJKL3N",
    "fv2d 65536 - Radau auto": "iikFlFFFFx",
    "fv2d 65536 - Radau native": "iikFlFFFFx",
    "fv2d 65536 - Radau pde": "iikFlFFFFx",
    "fv2d 65536 - Radau petsc": "3CEGIJKL3N",
    "fv2d 65536 - LSODA auto": "yzQfQQQQQ0",
    "fv2d 65536 - LSODA native": "yzQfQQQQQ0",
    "fv2d 65536 - LSODA pde": "yzQfQQQQQ0",
    "fv2d 65536 - LSODA petsc": "3CEGIJKL3N",
    "fv2d 65536 - CVODE auto": "q1UfUstqu2",
    "fv2d 65536 - CVODE native": "p1UfUptqu2",
    "fv2d 65536 - CVODE pde": "q1UfUstqu2",
    "fv2d 65536 - CVODE petsc": "3CEGIJKL3N",
    "fv2d 65536 - PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 65536 - PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 65536 - PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 65536 - PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 65536 thin BDF auto": "iikFlFFFFw",
    "fv2d 65536 thin BDF native": "iikFlFFFFw",
    "fv2d 65536 thin BDF pde": "iikFlFFFFw",
    "fv2d 65536 thin BDF petsc": "3CEGIJKL3N",
    "fv2d 65536 thin Radau auto": "iikFlFFFFx",
    "fv2d 65536 thin Radau native": "iikFlFFFFx",
    "fv2d 65536 thin Radau pde": "iikFlFFFFx",
    "fv2d 65536 thin Radau petsc": "3CEGIJKL3N",
    "fv2d 65536 thin LSODA auto": "yzQfQQQQQ0",
    "fv2d 65536 thin LSODA native": "yzQfQQQQQ0",
    "fv2d 65536 thin LSODA pde": "yzQfQQQQQ0",
    "fv2d 65536 thin LSODA petsc": "3CEGIJKL3N",
    "fv2d 65536 thin CVODE auto": "s1UfUstqu2",
    "fv2d 65536 thin CVODE native": "s1UfUstqu2",
    "fv2d 65536 thin CVODE pde": "s1UfUstqu2",
    "fv2d 65536 thin CVODE petsc": "3CEGIJKL3N",
    "fv2d 65536 thin PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 65536 thin PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 65536 thin PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 65536 thin PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 262144 - BDF auto": "iikFlFFFFw",
    "fv2d 262144 - BDF native": "iikFlFFFFw",
    "fv2d 262144 - BDF pde": "iikFlFFFFw",
    "fv2d 262144 - BDF petsc": "3CEGIJKL3N",
    "fv2d 262144 - Radau auto": "iikFlFFFFx",
    "fv2d 262144 - Radau native": "iikFlFFFFx",
    "fv2d 262144 - Radau pde": "iikFlFFFFx",
    "fv2d 262144 - Radau petsc": "3CEGIJKL3N",
    "fv2d 262144 - LSODA auto": "yzQfQQQQQ0",
    "fv2d 262144 - LSODA native": "yzQfQQQQQ0",
    "fv2d 262144 - LSODA pde": "yzQfQQQQQ0",
    "fv2d 262144 - LSODA petsc": "3CEGIJKL3N",
    "fv2d 262144 - CVODE auto": "q1UfUstqu2",
    "fv2d 262144 - CVODE native": "p1UfUptqu2",
    "fv2d 262144 - CVODE pde": "q1UfUstqu2",
    "fv2d 262144 - CVODE petsc": "3CEGIJKL3N",
    "fv2d 262144 - PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 262144 - PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 262144 - PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 262144 - PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 262144 thin BDF auto": "iikFlFFFFw",
    "fv2d 262144 thin BDF native": "iikFlFFFFw",
    "fv2d 262144 thin BDF pde": "iikFlFFFFw",
    "fv2d 262144 thin BDF petsc": "3CEGIJKL3N",
    "fv2d 262144 thin Radau auto": "iikFlFFFFx",
    "fv2d 262144 thin Radau native": "iikFlFFFFx",
    "fv2d 262144 thin Radau pde": "iikFlFFFFx",
    "fv2d 262144 thin Radau petsc": "3CEGIJKL3N",
    "fv2d 262144 thin LSODA auto": "yzQfQQQQQ0",
    "fv2d 262144 thin LSODA native": "yzQfQQQQQ0",
    "fv2d 262144 thin LSODA pde": "yzQfQQQQQ0",
    "fv2d 262144 thin LSODA petsc": "3CEGIJKL3N",
    "fv2d 262144 thin CVODE auto": "s1UfUstqu2",
    "fv2d 262144 thin CVODE native": "s1UfUstqu2",
    "fv2d 262144 thin CVODE pde": "s1UfUstqu2",
    "fv2d 262144 thin CVODE petsc": "3CEGIJKL3N",
    "fv2d 262144 thin PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 262144 thin PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 262144 thin PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 262144 thin PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 1048576 - BDF auto": "iikFlFFFFw",
    "fv2d 1048576 - BDF native": "iikFlFFFFw",
    "fv2d 1048576 - BDF pde": "iikFlFFFFw",
    "fv2d 1048576 - BDF petsc": "3CEGIJKL3N",
    "fv2d 1048576 - Radau auto": "iikFlFFFFx",
    "fv2d 1048576 - Radau native": "iikFlFFFFx",
    "fv2d 1048576 - Radau pde": "iikFlFFFFx",
    "fv2d 1048576 - Radau petsc": "3CEGIJKL3N",
    "fv2d 1048576 - LSODA auto": "yzQfQQQQQ0",
    "fv2d 1048576 - LSODA native": "yzQfQQQQQ0",
    "fv2d 1048576 - LSODA pde": "yzQfQQQQQ0",
    "fv2d 1048576 - LSODA petsc": "3CEGIJKL3N",
    "fv2d 1048576 - CVODE auto": "q1UfUstqu2",
    "fv2d 1048576 - CVODE native": "p1UfUptqu2",
    "fv2d 1048576 - CVODE pde": "q1UfUstqu2",
    "fv2d 1048576 - CVODE petsc": "3CEGIJKL3N",
    "fv2d 1048576 - PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 1048576 - PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 1048576 - PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 1048576 - PETSC-BDF petsc": "3CEGIJKL3N",
    "fv2d 1048576 thin BDF auto": "iikFlFFFFw",
    "fv2d 1048576 thin BDF native": "iikFlFFFFw",
    "fv2d 1048576 thin BDF pde": "iikFlFFFFw",
    "fv2d 1048576 thin BDF petsc": "3CEGIJKL3N",
    "fv2d 1048576 thin Radau auto": "iikFlFFFFx",
    "fv2d 1048576 thin Radau native": "iikFlFFFFx",
    "fv2d 1048576 thin Radau pde": "iikFlFFFFx",
    "fv2d 1048576 thin Radau petsc": "3CEGIJKL3N",
    "fv2d 1048576 thin LSODA auto": "yzQfQQQQQ0",
    "fv2d 1048576 thin LSODA native": "yzQfQQQQQ0",
    "fv2d 1048576 thin LSODA pde": "yzQfQQQQQ0",
    "fv2d 1048576 thin LSODA petsc": "3CEGIJKL3N",
    "fv2d 1048576 thin CVODE auto": "s1UfUstqu2",
    "fv2d 1048576 thin CVODE native": "s1UfUstqu2",
    "fv2d 1048576 thin CVODE pde": "s1UfUstqu2",
    "fv2d 1048576 thin CVODE petsc": "3CEGIJKL3N",
    "fv2d 1048576 thin PETSC-BDF auto": "3CEGIJKL3N",
    "fv2d 1048576 thin PETSC-BDF native": "3CEGIJKL3N",
    "fv2d 1048576 thin PETSC-BDF pde": "3CEGIJKL3N",
    "fv2d 1048576 thin PETSC-BDF petsc": "3CEGIJKL3N",
}


def _cases():
    for key, codes in TABLE.items():
        scheme, size, thin, method, request = key.split()
        for jacobian, code in zip(JACOBIANS, codes):
            yield key, scheme, int(size), thin == "thin", method, request, jacobian, code


def _outcome(scheme, size, thin, method, request, jacobian) -> str:
    grid = dict(cells=size, thin_cell=thin) if scheme == "fv2d" else {}
    try:
        choice = choose(method=method, jacobian=jacobian, request=request,
                        **choice_asks(scheme, request=request, **grid))
    except ParameterError as error:
        return "! " + str(error)[:60]
    return " / ".join(map(str, (choice.engine, choice.jacobian, choice.linear_solver, choice.max_order)))


def test_the_table_covers_every_case():
    assert len(TABLE) == 6 * len(METHODS) * len(REQUESTS) + 12 * len(METHODS) * len(REQUESTS)
    assert {len(codes) for codes in TABLE.values()} == {len(JACOBIANS)}


def test_choices_are_those_made_before_the_registry():
    differ = [(key, jacobian, OUTCOMES[code], found) for key, *case, jacobian, code in _cases()
              if (found := _outcome(*case, jacobian)) != OUTCOMES[code]]
    assert differ == []


def test_each_choice_carries_its_solver_and_the_name_is_the_solvers():
    for key, scheme, size, thin, method, request, jacobian, code in _cases():
        if OUTCOMES[code].startswith("!"):
            continue
        grid = dict(cells=size, thin_cell=thin) if scheme == "fv2d" else {}
        choice = choose(method=method, jacobian=jacobian, request=request,
                        **choice_asks(scheme, request=request, **grid))
        assert choice.solver is not None and choice.solver.name == choice.linear_solver, (key, jacobian)


@pytest.fixture
def toy():
    """A preconditioner defined here and nowhere else: the identity, counting its solves."""
    from icidr_pde.engines.linear.precond import mass_keeping_precond

    class ToyPreconditioned(Preconditioned):
        name = "GMRES + toy preconditioner"
        modes = ("toy",)
        preference = 65
        what = "the identity"
        bytes_per_unknown = 1e5
        memory_note = "the toy preconditioner's tables"
        solves = 0

        def preconditioner(self, problem):
            def setup(t, y, gamma, jok):
                return False

            def solve(r, z):
                type(self).solves += 1
                z[:] = r

            return mass_keeping_precond(setup, solve, problem.jacobian.weights)

    yield ToyPreconditioned
    unregister(ToyPreconditioned)
    assert all(type(s) is not ToyPreconditioned for s in SOLVERS) and "toy" not in jacobian_modes("CVODE")


def test_a_preconditioner_is_chosen_where_its_mode_is_asked_for(toy):
    assert jacobian_modes("CVODE") == ("analytic", "banded-fd", "krylov", "amg", "fourier", "toy", "sparse", "none")
    choice = choose(method="CVODE", jacobian="toy", **choice_asks("fv2d", cells=128 * 128))
    assert (choice.engine, choice.jacobian, choice.linear_solver) == ("sundae", "toy", toy.name)
    assert isinstance(choice.solver, toy)
    with pytest.raises(ParameterError, match="`jacobian`='toy' \\(GMRES preconditioned by the identity\\) needs"):
        choose(method="CVODE", jacobian="toy", request="pde", **choice_asks("fd", request="pde"))
    assert choose(method="CVODE", request="pde", **choice_asks("fv2d", request="pde", cells=128 * 128)
                  ).jacobian == "fourier"  # the default is not the newcomer's


def test_the_memory_check_counts_a_preconditioner(toy, monkeypatch):
    """100 kB an unknown at 64^2 (3 x 4096 unknowns: 1.2 GB) do not fit into 1 GB, GMRES alone does."""
    from icidr_pde.case import build_case
    from icidr_pde.engines.stiff import StiffSolver

    monkeypatch.setenv("ICIDR_PDE_MEMORY", "1e9")
    case = build_case("icidr", "bump2d", "fv2d", (64, 64))
    with pytest.raises(ParameterError, match="`Nx` x `Nz` = 64 x 64 .*'toy'.*the toy preconditioner's tables"):
        StiffSolver(case.pde, method="CVODE", jacobian="toy").check_memory(case.state)
    StiffSolver(case.pde, method="CVODE", jacobian="krylov").check_memory(case.state)


def test_the_engine_sets_a_preconditioner_up(toy):
    """CVODE's GMRES with the identity as preconditioner solves what it solves without one: the
    x-independent 2-D state follows the 1-D cell (as tests/test_amg.py checks the AMG path)."""
    from .test_amg import x_independent_runs

    solver, one_d, two_d = x_independent_runs("toy")
    assert solver.info["linear_solver"] == toy.name and toy.solves > 0
    assert np.max(np.abs(two_d - one_d[:, None, :])) < 1e-7
    assert np.max(np.abs(one_d[2])) > 1e-4
