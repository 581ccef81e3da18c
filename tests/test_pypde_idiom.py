"""The README's py-pde snippet, run as written in a fresh interpreter.

A fresh process is the point: py-pde finds a solver by name in its registry, and the
registry holds "stiff" only once the module defining it has been imported. Importing
``ShearCellPDE`` must be enough.

Independent truth: the snippet perturbs iCIDR's simple shear (phi = 0.78 uniform, u = z/H,
w = 0, a steady solution of (4.7)-(4.8) with the shear-cell walls) by 0.1 sin(2 pi z/H) in u;
the run is well-posed, conserves the mass of phi, and the perturbation decays toward the
steady shear.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"

CHECK = """
import numpy as np
default = eq.solve(state, t_range=10, method="BDF", rtol=1e-6, atol=1e-9)  # no solver= named
phi, u, w = (np.asarray(f.data) for f in final)
z = grid.axes_coords[0]
print("DEV", np.abs(u - z / 30).max(), np.abs(np.asarray(state[1].data) - z / 30).max(), np.abs(w).max())
print("MASS", abs(np.mean(phi) - 0.78))
print("SAME", max(np.abs(np.asarray(a.data) - np.asarray(b.data)).max() for a, b in zip(final, default)))
"""


def readme_pypde_snippet() -> str:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    matches = [b for b in blocks if "ShearCellPDE(" in b and "eq.solve(" in b]
    assert len(matches) == 1, "the README should hold exactly one py-pde snippet"
    return matches[0]


def test_readme_pypde_snippet_runs_in_a_fresh_interpreter():
    code = readme_pypde_snippet() + CHECK
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    dev = dict((line.split()[0], [float(x) for x in line.split()[1:]])
               for line in proc.stdout.splitlines() if line.startswith(("DEV", "SAME", "MASS")))
    after, before, w_max = dev["DEV"]
    assert before == pytest.approx(0.1, rel=1e-3) and 0 < after < 0.9 * before  # the perturbation decays
    assert 0 < w_max < 0.1 and dev["MASS"][0] < 1e-12  # phi is moved, its mass kept
    assert dev["SAME"][0] == 0.0  # solve() without solver= is the stiff solver
