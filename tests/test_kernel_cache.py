"""Kernels compile once per installation: a new process loads them from the on-disk cache
(no sympy, no numba compilation), and a new N or new parameter values compile nothing."""

import json
import os
import subprocess
import sys

from icidr_pde import build_case
from icidr_pde.rheology import Material

CHILD = r"""
import json, sys
from icidr_pde import build_case
case = build_case("icidr", "sine", "fd", int(sys.argv[1]))
rhs = case.pde.make_rates(case.state)
rhs(case.state.data)
rates = case.scheme.loops().rates
print(json.dumps({"sympy": "sympy" in sys.modules, "hits": sum(rates.stats.cache_hits.values()),
                  "misses": sum(rates.stats.cache_misses.values())}))
"""


def test_second_process_loads_cached_kernels_for_any_N():
    case = build_case("icidr", "sine", "fd", 31)
    case.pde.make_rates(case.state)  # compiles here if this installation never did
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    for N in (33, 57):  # sizes are arguments: a new N is the same compiled kernel
        proc = subprocess.run([sys.executable, "-c", CHILD, str(N)], capture_output=True, text=True, env=env,
                              check=True)
        out = json.loads(proc.stdout.strip().splitlines()[-1])
        assert out == {"sympy": False, "hits": 1, "misses": 0}, (out, proc.stderr)
        assert "compiling kernels" not in proc.stderr


def test_parameter_values_are_arguments_not_compiled_in():
    a = build_case("icidr", "sine", "fd", 21)
    b = build_case("icidr", "sine", "fd", 21, material=Material(mu_s=0.3, a=0.25))
    assert a.scheme.loops() is b.scheme.loops()  # one module for both: values are passed at run time
    ra, rb = a.pde.make_rates(a.state)(a.state.data), b.pde.make_rates(b.state)(b.state.data)
    assert abs(ra - rb).max() > 0


CHILD_2D = r"""
import json, sys
import numpy as np
from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
pde = ShearCell2DPDE("icidr")
grid = pde.make_grid((int(sys.argv[1]), 8), 30.0)
state = pde.make_state(grid, 0.78, 0.5, 0.0)
pde.make_rates(state)(state.data)
patches = pde.patches(state)
patches.rates(np.ones((3, 5, 6)), True, False, np.empty((3, 3, 4)))
loops = pde._loops()
kernels = (loops.rates, loops.halo, loops.walls, loops.patch_rates)
print(json.dumps({"sympy": "sympy" in sys.modules,
                  "hits": [sum(k.stats.cache_hits.values()) for k in kernels],
                  "misses": [sum(k.stats.cache_misses.values()) for k in kernels]}))
"""


def test_second_process_loads_the_2d_patch_kernels():
    """The whole-grid kernel calls the patch kernel and its halo and walls as module globals:
    all four load from the cache in a new process, for any grid size."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    for nx in (8, 8, 11):  # the first call may compile, if this installation never did
        proc = subprocess.run([sys.executable, "-c", CHILD_2D, str(nx)], capture_output=True, text=True, env=env,
                              check=True)
        out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out == {"sympy": False, "hits": [1, 0, 1, 1], "misses": [0, 0, 0, 0]}, (out, proc.stderr)
    assert "compiling kernels" not in proc.stderr
