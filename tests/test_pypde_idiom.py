"""The README's py-pde snippet, run as written in a fresh interpreter.

A fresh process is the point: py-pde finds a solver by name in its registry, and the
registry holds "stiff" only once the module defining it has been imported. Importing
``ShearCellPDE`` must be enough.

Independent truth: iCIDR's simple shear (phi = 0.78 uniform, u = z/H, w = 0) is a steady
solution of (4.7)-(4.8) with the shear-cell walls, so the state at t = 10 is the initial one.
"""

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"

CHECK = """
import numpy as np
default = eq.solve(state, t_range=10, method="BDF", rtol=1e-6, atol=1e-9)  # no solver= named
phi, u, w = (np.asarray(f.data) for f in final)
z = grid.axes_coords[0]
print("DEV", np.abs(phi - 0.78).max(), np.abs(u - z / 30).max(), np.abs(w).max())
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
               for line in proc.stdout.splitlines() if line.startswith(("DEV", "SAME")))
    assert max(dev["DEV"]) < 1e-6  # steady simple shear stays put
    assert dev["SAME"][0] == 0.0  # solve() without solver= is the stiff solver
