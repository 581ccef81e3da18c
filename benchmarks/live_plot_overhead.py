"""Cost of ``run(..., live_plot=True)`` in a Jupyter kernel, measured as a user meets it.

    python benchmarks/live_plot_overhead.py [--repeats 3]

Executes a generated notebook with nbclient (a real ipykernel, the inline backend): for each
case one warm-up run (numba compilation), then `repeats` runs without and with the live
figure; prints the median wall time of the solve (``Result.wall_s``, which includes the
recorders) of each and the difference. The live figure redraws under a budget of 10 % of the
run's wall time plus a fixed cost per run (creating the figure, first and final frame), so
the relative overhead is large for runs far below a second and approaches 10 % for long ones.
Accuracy beside the timings: max|w| at t_end of both runs must agree exactly (the recorders
do not change the integrator's steps); the table prints their difference.
"""

from __future__ import annotations

import argparse
import json
import os

CASES = [
    ("mui shear fd N=201 (fails at t*~0.015)", "run('mui', 'shear', 201, 1.0, method='BDF', rtol=1e-6, atol=1e-9{})"),
    ("icidr sine, preset standard, t=20", "run('icidr', 'sine', t_end=20.0{})"),
    ("icidr sine fd N=201 BDF rtol 1e-6, t=20", "run('icidr', 'sine', 201, 20.0, method='BDF', rtol=1e-6, atol=1e-9{})"),
    ("icidr sine, preset publication (N=801), t=20", "run('icidr', 'sine', t_end=20.0, accuracy='publication'{})"),
]


def notebook(repeats: int):
    import nbformat

    cells = ["import json, statistics\nfrom icidr_pde import run\nrows = []"]
    for label, call in CASES:
        cells.append(f"""{call.format('')}  # compile
plain = [{call.format('')} for _ in range({repeats})]
live = [{call.format(', live_plot=True')} for _ in range({repeats})]
rows.append(dict(case={label!r}, plain=statistics.median(r.wall_s for r in plain),
                 live=statistics.median(r.wall_s for r in live),
                 max_w_difference=abs(plain[0].max_w_series[-1] - live[0].max_w_series[-1])))""")
    cells.append("print('ROWS', json.dumps(rows))")
    book = nbformat.v4.new_notebook()
    book.cells = [nbformat.v4.new_code_cell(c) for c in cells]
    return book


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    import nbclient

    book = notebook(args.repeats)
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    nbclient.NotebookClient(book, timeout=1800, kernel_name="python3").execute(env=env)
    text = "".join(o.get("text", "") for o in book.cells[-1].outputs)
    rows = json.loads(text.split("ROWS", 1)[1])
    print(f"{'case':48s} {'without [s]':>11s} {'with [s]':>9s} {'overhead':>9s} {'ratio':>6s} {'max|w| diff':>11s}")
    for r in rows:
        print(f"{r['case']:48s} {r['plain']:11.3f} {r['live']:9.3f} {r['live'] - r['plain']:8.3f}s "
              f"{r['live'] / r['plain']:6.2f} {r['max_w_difference']:11.1e}")


if __name__ == "__main__":
    main()
