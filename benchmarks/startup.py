"""Start-up cost of a run, measured as whole processes (imports and compilation included).

    python benchmarks/startup.py [--repeats 3] [--json out.json] [--against DIR] [--no-invocations]

In one fresh kernel cache (a new NUMBA_CACHE_DIR, so the first invocation generates and
compiles everything, as after installation) it runs, each as its own process:

* the baseline ``python -c "import icidr_pde"``;
* ``python -m icidr_pde.cli run --rheology icidr --scene sine --t-end 20 --json out.json``
  (the command ``icidr-pde run ...`` of the same tree) three ways: the first invocation, a
  second one, and a second one at a new N (--N 401);
* ``python -c "import icidr_pde.cli; icidr_pde.cli.make_parser(['run'])"`` for the import share
  (the parser a ``run`` invocation builds: the run subcommand only).

Each invocation's wall time is split into import (the separate import process), set-up
(kernel generation, compilation or cache loading: ``compile_s`` of the JSON), solve
(``wall_s``) and the rest (parsing, building the case, writing the JSON). The ratio of the
second invocation to baseline import + solve is printed (the target is <= 2), and beside
every timing the run's accuracy: the largest error of max|w| at the snapshot times against
the converged reference of data/reference (relative to the reference's largest max|w|).
Repeated invocations (--repeats) report the median.

Then, with the kernels in the cache, the commands a user types, each its own process,
interleaved round by round (medians of --repeats): the bare interpreter, ``import pde``,
``import icidr_pde``, ``from icidr_pde import run`` (the API ready to use), ``icidr-pde
--help``, ``icidr-pde run --help`` and a warm run of iCIDR scene shear (fd N = 201, t = 10,
the CLI's defaults: end_to_end.py's case shear-fd) with that case's error (max over
t in {3, 5, 10} of the relative error of max|w|); and the third-party packages that warm run
imports (from ``python -X importtime``). ``--against DIR`` runs every command also with
another source tree (e.g. ``git archive main | tar -x -C DIR``) in the same rounds and
prints the ratios; ``--no-invocations`` skips the compiling part above (the commands then
use the user's own kernel cache).
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

from provenance import write_json

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # the reference data of this tree
COMMAND = ["run", "--rheology", "icidr", "--scene", "sine", "--t-end", "20"]
WARM_RUN = ["run", "--rheology", "icidr", "--scene", "shear", "--t-end", "10", "--times", "0", "3", "5", "10",
            "--no-progress"]
#: label -> arguments after the interpreter (None: the warm run, with --json)
COMMANDS = {
    "python -c pass": ["-c", "pass"],
    "python -c 'import pde'": ["-c", "import pde"],
    "python -c 'import icidr_pde'": ["-c", "import icidr_pde"],
    "python -c 'from icidr_pde import run'": ["-c", "from icidr_pde import run"],
    "icidr-pde --help": ["-m", "icidr_pde.cli", "--help"],
    "icidr-pde run --help": ["-m", "icidr_pde.cli", "run", "--help"],
    "icidr-pde " + " ".join(WARM_RUN) + " --json out.json (warm, N = 201)": None,
}


def timed(args, env, cwd=None) -> tuple[float, subprocess.CompletedProcess]:
    start = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True, cwd=cwd)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall, proc


def max_w_error(summary: dict, case: str = "icidr-sine") -> float:
    """Largest |max|w|(t) - reference| over the snapshot times, relative to the reference's max."""
    from icidr_pde.studies.references import reference

    ref = reference(case)
    ref_max = np.abs(ref["w_series"]).max(axis=1)
    errors = [abs(value - np.interp(float(t), ref["series_t"], ref_max)) for t, value in summary["max_w"].items()]
    return float(max(errors) / ref_max.max())


def invocation(label: str, extra: list[str], env: dict, workdir: Path) -> dict:
    out = workdir / f"{label}.json"
    wall, proc = timed([sys.executable, "-m", "icidr_pde.cli", *COMMAND, *extra, "--json", str(out),
                        "--no-progress"], env)
    summary = json.loads(out.read_text())
    return {"label": label, "wall_s": wall, "compile_s": summary["compile_s"], "solve_s": summary["wall_s"],
            "N": summary["N"], "compiled": "compiling" in proc.stderr,
            "max_w_error": max_w_error(summary)}


def measure(repeats: int) -> dict:
    workdir = Path(tempfile.mkdtemp(prefix="icidr_startup_"))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(workdir / "cache"), PYTHONPATH=str(ROOT))
    rows = [invocation("first invocation", [], env, workdir)]
    for label, extra in (("second invocation", []), ("second invocation, new N = 401", ["--N", "401"])):
        runs = [invocation(label, extra, env, workdir) for _ in range(repeats)]
        rows.append({key: (statistics.median(r[key] for r in runs) if isinstance(runs[0][key], float)
                           else runs[0][key]) for key in runs[0]})
        rows[-1]["compiled"] = any(r["compiled"] for r in runs)  # same cache: must stay "no"
    baseline = statistics.median(timed([sys.executable, "-c", "import icidr_pde"], env)[0] for _ in range(repeats))
    cli_import = statistics.median(timed([sys.executable, "-c", "import icidr_pde.cli; icidr_pde.cli.make_parser(['run'])"],
                                         env)[0] for _ in range(repeats))
    for row in rows:
        row["import_s"] = cli_import
        row["rest_s"] = row["wall_s"] - cli_import - row["compile_s"] - row["solve_s"]
        row["ratio_to_import_plus_solve"] = row["wall_s"] / (baseline + row["solve_s"])
    return {"baseline_import_s": baseline, "cli_import_s": cli_import, "rows": rows, "repeats": repeats,
            "cache": env["NUMBA_CACHE_DIR"],
            "python": sys.version.split()[0], "command": " ".join(["icidr-pde", *COMMAND, "--json", "out.json"])}


def accuracy(case: str, max_w: dict, t_star) -> float:
    """The error of end_to_end.py's reference case `case` (max over t in {3, 5, 10} of the relative
    error of max|w| for shear-fd)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from end_to_end import accuracy as case_accuracy

    return case_accuracy(case, max_w, t_star)


def tree_env(env: dict, tree: Path) -> dict:
    return dict(env, PYTHONPATH=str(tree), MPLBACKEND="Agg")


def warm_run(env: dict, workdir: Path, tag: str) -> tuple[float, dict, str]:
    out = workdir / f"warm-{tag}.json"
    wall, proc = timed([sys.executable, "-m", "icidr_pde.cli", *WARM_RUN, "--json", str(out)], env, cwd=workdir)
    return wall, json.loads(out.read_text()), proc.stderr


IMPORTS_CHILD = r"""
import atexit, json, runpy, sys
path = sys.argv[1]
def dump():
    names = {m.split(".")[0] for m, mod in list(sys.modules.items()) if getattr(mod, "__file__", None)}
    with open(path, "w") as f:
        json.dump(sorted(names), f)
atexit.register(dump)
sys.argv = ["icidr-pde", *sys.argv[2:]]
runpy.run_module("icidr_pde.cli", run_name="__main__", alter_sys=True)
"""


def imported_packages(env: dict, workdir: Path) -> list[str]:
    """Third-party top-level packages in sys.modules at the end of a warm run (stdlib left out)."""
    out = workdir / "modules.json"
    timed([sys.executable, "-c", IMPORTS_CHILD, str(out), *WARM_RUN], env, cwd=workdir)
    return [n for n in json.loads(out.read_text()) if not n.startswith("_") and n not in sys.stdlib_module_names
            and not n.startswith("icidr_pde_")]  # the generated kernel modules (icidr_pde.kernel_cache)


def measure_commands(repeats: int, env: dict, workdir: Path, against: Path | None) -> dict:
    """Every command of COMMANDS per tree, interleaved round by round; medians and ranges."""
    trees = {"this tree": ROOT} | ({"against": against} if against else {})
    envs = {tag: tree_env(env, tree) for tag, tree in trees.items()}
    for tag in trees:  # fill the kernel cache of each tree (not timed)
        warm_run(envs[tag], workdir, tag)
    times = {tag: {label: [] for label in COMMANDS} for tag in trees}
    errors, compiled = {}, {}
    for _ in range(repeats):
        for label, args in COMMANDS.items():
            for tag in trees:
                if args is None:
                    wall, summary, stderr = warm_run(envs[tag], workdir, tag)
                    errors[tag] = accuracy("shear-fd", summary["max_w"], None)
                    compiled[tag] = compiled.get(tag, False) or "compiling" in stderr
                    times[tag].setdefault("solve", []).append(summary["wall_s"])
                    times[tag].setdefault("set-up", []).append(summary["compile_s"])
                else:
                    wall, _ = timed([sys.executable, *args], envs[tag], cwd=workdir)  # not a tree's folder
                times[tag][label].append(wall)
    rows = {tag: {label: dict(median=statistics.median(v), range=[min(v), max(v)]) for label, v in t.items()}
            for tag, t in times.items()}
    return {"trees": {tag: str(tree) for tag, tree in trees.items()}, "rows": rows, "max_w_error": errors,
            "compiled": compiled, "imports_of_warm_run": imported_packages(envs["this tree"], workdir)}


def report_commands(data: dict) -> str:
    trees, rows = data["trees"], data["rows"]
    against = "against" in trees
    head = "| command | this tree |" + (" against | this / against |" if against else "")
    lines = ["", f"commands with the kernels cached, median (range) of {data['repeats']} interleaved rounds"
             + (f"; against = {trees['against']}" if against else ""),
             "", head, "|" + " --- |" * (head.count("|") - 1)]
    for label in rows["this tree"]:
        cells = [f"{rows[t][label]['median']:.2f} s ({rows[t][label]['range'][0]:.2f}-{rows[t][label]['range'][1]:.2f})"
                 for t in trees]
        ratio = [f"{rows['this tree'][label]['median'] / rows['against'][label]['median']:.2f}"] if against else []
        lines.append(f"| {label} | " + " | ".join(cells + ratio) + " |")
    for tag in trees:
        r = rows[tag]
        med = {label: r[label]["median"] for label in r}
        lines.append(f"{tag}: import icidr_pde - import pde = {med[list(COMMANDS)[2]] - med[list(COMMANDS)[1]]:+.2f} s; "
                     f"from icidr_pde import run - import pde = {med[list(COMMANDS)[3]] - med[list(COMMANDS)[1]]:+.2f} s; "
                     f"warm run max|w| error {data['max_w_error'][tag]:.1e}"
                     + ("; it compiled kernels (cache was cold)" if data["compiled"][tag] else ""))
    lines.append("third-party packages imported by the warm run: " + " ".join(data["imports_of_warm_run"]))
    return "\n".join(lines)


def report(data: dict) -> str:
    lines = [f"command: {data['command']} (as python -m icidr_pde.cli, a fresh kernel cache); "
             f"median of {data['repeats']} for repeated rows",
             f"baseline python -c 'import icidr_pde': {data['baseline_import_s']:.2f} s; "
             f"import icidr_pde.cli + run parser: {data['cli_import_s']:.2f} s",
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
    parser.add_argument("--against", type=Path, default=None, help="another source tree to time the commands of")
    parser.add_argument("--no-invocations", action="store_true",
                        help="skip the fresh-cache invocations (compilation); time the commands only")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1; got {args.repeats}")
    if args.against is not None and not any((args.against / "icidr_pde" / name).is_file()
                                            for name in ("cli.py", "cli/__init__.py")):
        parser.error(f"--against must be a source tree with the icidr_pde.cli command; got {str(args.against)!r}")
    data = {} if args.no_invocations else measure(args.repeats)
    if data:
        print(report(data))
    env = dict(os.environ, **({"NUMBA_CACHE_DIR": data["cache"]} if data else {}))  # else: the user's cache
    with tempfile.TemporaryDirectory(prefix="icidr_startup_") as workdir:
        data["commands"] = measure_commands(args.repeats, env, Path(workdir), args.against)
    data["commands"]["repeats"] = args.repeats
    print(report_commands(data["commands"]))
    if args.json:
        write_json(args.json, data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
