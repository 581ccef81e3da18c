"""What keeping freed arrays in the heap (icidr_pde.heap) saves a large 2-D run, whole process.

The same run twice in child processes, timed by wait4 (wall, user and system CPU, minor page
faults, peak RSS): with glibc's malloc as it comes (the baseline: ``heap.keep_freed_arrays`` not
called) and with the run path's setting (``--rheology`` on bump2d, N^2 cells, the 2-D default
CVODE + GMRES + x-Fourier, rtol 1e-5, atol 1e-8, to --t-end). The accuracy beside the timing: the
two runs' steps and max|w| at t_end, which must be equal (malloc decides where arrays live, not
what is computed).

    nice -n 10 python benchmarks/heap_faults.py [--N 1024] [--rheology icidr] [--t-end 0.5] [--json F]
"""

import argparse
import json
import os
import sys
import tempfile

from provenance import write_json
from scaling import measured

CHILD = r'''
import json, sys
import numpy as np
from icidr_pde import heap, run
if sys.argv[1] == "baseline":
    heap._applied = False  # keep_freed_arrays then leaves malloc as glibc set it
rheology, n, t_end, out = sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
r = run(rheology, "bump2d", (n, n), t_end, ["0", f"{t_end:g}"], series_times=[], method="CVODE", rtol=1e-5,
        atol=1e-8, jacobian="fourier")
json.dump({"n_steps": r.n_steps, "reason": r.reason, "max_w": float(np.max(np.abs(r.final[2])))}, open(out, "w"))
'''


def child(mode: str, rheology: str, n: int, t_end: float) -> dict:
    """One whole process (scaling.measured): its result and its resource use."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.json")
        usage = measured([sys.executable, "-c", CHILD, mode, rheology, str(n), str(t_end), out], os.environ, tmp)
        with open(out) as f:
            result = json.load(f)
    return {**result, "wall": usage["wall_s"], "user": usage["user_s"], "system": usage["system_s"],
            "minor_faults": usage["minor_faults"], "max_rss": usage["peak_mib"] * 2**20}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--N", type=int, default=1024)
    parser.add_argument("--rheology", default="icidr", choices=("icidr", "mui"))
    parser.add_argument("--t-end", type=float, default=0.5)
    parser.add_argument("--json", default="data/benchmarks/heap_faults.json")
    args = parser.parse_args()
    rows = {}
    for mode in ("baseline", "kept"):
        rows[mode] = r = child(mode, args.rheology, args.N, args.t_end)
        print(f"{mode:<9} wall {r['wall']:7.1f} s  user {r['user']:7.1f} s  system {r['system']:6.1f} s  "
              f"faults {r['minor_faults']:>11,}  peak {r['max_rss'] / 1e9:5.2f} GB  {r['n_steps']} steps, "
              f"max|w|(t_end) {r['max_w']:.10e}", flush=True)
    base, kept = rows["baseline"], rows["kept"]
    cpu = lambda r: r["user"] + r["system"]  # noqa: E731
    same = base["n_steps"] == kept["n_steps"] and base["max_w"] == kept["max_w"]
    print(f"kept / baseline: wall {kept['wall'] / base['wall']:.2f}x, CPU {cpu(kept) / cpu(base):.2f}x, "
          f"system CPU {kept['system'] / base['system']:.2f}x, faults {kept['minor_faults'] / base['minor_faults']:.3f}x, "
          f"peak RSS {kept['max_rss'] / base['max_rss']:.2f}x; same steps and max|w|: {same}")
    write_json(args.json, {"N": args.N, "rheology": args.rheology, "t_end": args.t_end, **rows, "same_result": same})
    if not same:
        sys.exit(1)


if __name__ == "__main__":
    main()
