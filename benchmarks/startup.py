"""Start-up cost of a run, measured as whole processes (imports and compilation included).

    python benchmarks/startup.py [--repeats 3] [--json out.json]

In one fresh kernel cache (a new NUMBA_CACHE_DIR, so the first invocation generates and
compiles everything, as after installation) it runs, each as its own process:

* the baseline ``python -c "import icidr_pde"``;
* ``python -m icidr_pde.cli run --rheology icidr --scene sine --t-end 20 --json out.json``
  (the command ``icidr-pde run ...`` of the same tree) three ways: the first invocation, a
  second one, and a second one at a new N (--N 401);
* ``python -c "import icidr_pde.cli; icidr_pde.cli.make_parser()"`` for the import share.

Each invocation's wall time is split into import (the separate import process), set-up
(kernel generation, compilation or cache loading: ``compile_s`` of the JSON), solve
(``wall_s``) and the rest (parsing, building the case, writing the JSON). The ratio of the
second invocation to baseline import + solve is printed (the target is <= 2), and beside
every timing the run's accuracy: the largest error of max|w| at the snapshot times against
the converged reference of data/reference (relative to the reference's largest max|w|).
Repeated invocations (--repeats) report the median.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

COMMAND = ["run", "--rheology", "icidr", "--scene", "sine", "--t-end", "20"]


def timed(args, env) -> tuple[float, subprocess.CompletedProcess]:
    start = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall, proc


def max_w_error(summary: dict) -> float:
    """Largest |max|w|(t) - reference| over the snapshot times, relative to the reference's max."""
    from icidr_pde.reference import reference

    ref = reference("icidr-sine")
    ref_max = np.abs(ref["w_series"]).max(axis=1)
    errors = [abs(value - np.interp(float(t), ref["series_t"], ref_max)) for t, value in summary["max_w"].items()]
    return float(max(errors) / ref_max.max())


def invocation(label: str, extra: list[str], env: dict, workdir: Path) -> dict:
    out = workdir / f"{label}.json"
    wall, proc = timed([sys.executable, "-m", "icidr_pde.cli", *COMMAND, *extra, "--json", str(out),
                        "--no-progress"], env)
    summary = json.loads(out.read_text())
    return {"label": label, "wall_s": wall, "compile_s": summary["compile_s"], "solve_s": summary["wall_s"],
            "N": summary["N"], "compiled": "compiling kernels" in proc.stderr,
            "max_w_error": max_w_error(summary)}


def measure(repeats: int) -> dict:
    workdir = Path(tempfile.mkdtemp(prefix="icidr_startup_"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(workdir / "cache"))
    rows = [invocation("first invocation", [], env, workdir)]
    for label, extra in (("second invocation", []), ("second invocation, new N = 401", ["--N", "401"])):
        runs = [invocation(label, extra, env, workdir) for _ in range(repeats)]
        rows.append({key: (statistics.median(r[key] for r in runs) if isinstance(runs[0][key], float)
                           else runs[0][key]) for key in runs[0]})
        rows[-1]["compiled"] = any(r["compiled"] for r in runs)  # same cache: must stay "no"
    baseline = statistics.median(timed([sys.executable, "-c", "import icidr_pde"], env)[0] for _ in range(repeats))
    cli_import = statistics.median(timed([sys.executable, "-c", "import icidr_pde.cli; icidr_pde.cli.make_parser()"],
                                         env)[0] for _ in range(repeats))
    for row in rows:
        row["import_s"] = cli_import
        row["rest_s"] = row["wall_s"] - cli_import - row["compile_s"] - row["solve_s"]
        row["ratio_to_import_plus_solve"] = row["wall_s"] / (baseline + row["solve_s"])
    return {"baseline_import_s": baseline, "cli_import_s": cli_import, "rows": rows, "repeats": repeats,
            "python": sys.version.split()[0], "command": " ".join(["icidr-pde", *COMMAND, "--json", "out.json"])}


def report(data: dict) -> str:
    lines = [f"command: {data['command']} (as python -m icidr_pde.cli, a fresh kernel cache); "
             f"median of {data['repeats']} for repeated rows",
             f"baseline python -c 'import icidr_pde': {data['baseline_import_s']:.2f} s; "
             f"import icidr_pde.cli + parser: {data['cli_import_s']:.2f} s",
             "", "| invocation | N | wall | import | set-up (compile or load) | solve | rest | "
             "wall / (import + solve) | compiled? | max\\|w\\| error |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in data["rows"]:
        lines.append(f"| {r['label']} | {r['N']} | {r['wall_s']:.2f} s | {r['import_s']:.2f} s | {r['compile_s']:.2f} s | "
                     f"{r['solve_s']:.2f} s | {r['rest_s']:.2f} s | {r['ratio_to_import_plus_solve']:.2f} | "
                     f"{'yes' if r['compiled'] else 'no'} | {r['max_w_error']:.1e} |")
    first, second = data["rows"][0], data["rows"][1]
    lines.append("")
    lines.append(f"second / first invocation: {second['wall_s'] / first['wall_s']:.2f}; "
                 f"set-up {first['compile_s']:.1f} s -> {second['compile_s']:.2f} s")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3, help="invocations per repeated row (median)")
    parser.add_argument("--json", default=None, help="write the measurements here")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1; got {args.repeats}")
    data = measure(args.repeats)
    print(report(data))
    if args.json:
        Path(args.json).write_text(json.dumps(data, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
