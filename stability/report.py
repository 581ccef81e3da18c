"""Verification report (issue item 6): every checked equation with its status.

Statuses: ``exact`` (sympy proves it), ``numeric`` (holds numerically: 30-digit mpmath
for identities; for the numerical cross-checks of item 8 the tolerance is in the
detail), ``fails`` (does not hold; the corrected expression is given).
"""

from __future__ import annotations

import json
import sys
import textwrap
import time

from . import cidr, dissipation, icidr, linearize, mui, rheologies
from .checks import FAILS, NUMERIC, Check

# failures that are transcription errors of the paper (verify exits 0 if only these fail)
KNOWN_TRANSCRIPTION_ERRORS = {"(2.2)", "(5.1)", "(5.6)"}


def crosscheck_rows() -> list[Check]:
    """Fast numerical cross-checks of the symbols (item 8) as report rows."""
    from . import growth  # noqa: PLC0415

    st = growth.DEFAULT_STATE
    out = []
    rows, sn = growth.eigen_vs_symbol("mui", st["phi"], st["uz"], st["wz"], [1e4])
    r = rows[0]
    err = max(abs(r["lambda_plus"] - sn.lambda_plus) / abs(sn.lambda_plus),
              abs(r["lambda_minus"] - sn.lambda_minus) / abs(sn.lambda_minus),
              abs(r["lambda0"] - sn.lambda0_limit) / abs(sn.lambda0_limit))
    out.append(Check("(A9) numeric", "eig A(xi)/xi^2 -> Lambda_pm and lambda_0 -> -C/B (mu(I), xi = 1e4)",
                     NUMERIC if err < 1e-6 else FAILS, f"max relative deviation {err:.1e} (O(1/xi))",
                     section="cross-check"))
    errs = []
    for name in ("mui", "icidr"):
        for xi in (3.0, 30.0):
            g = growth.measured_growth_rate(name, st["phi"], st["uz"], st["wz"], xi)
            errs.append(g["rel_error"])
    e = max(errs)
    out.append(Check("(A4) growth", "growth rates measured by time integration of (A2) = max Re eig A(xi)",
                     NUMERIC if e <= 1e-6 else FAILS, f"both rheologies, xi in {{3, 30}}: max rel. error {e:.1e}",
                     section="cross-check"))
    tab = growth.fd_growth_table(Ns=(64, 128, 256), dense_max=64)
    ratios = [tab[i + 1]["mui"] / tab[i]["mui"] for i in range(len(tab) - 1)]
    ic = [t["icidr"] for t in tab]
    ok = all(abs(q - 4) < 0.05 for q in ratios) and max(ic) < 1.0
    out.append(Check("(A16) FD", "FD operator: mu(I) growth ~ 1/h^2 (ratio 4 per halving), iCIDR bounded",
                     NUMERIC if ok else FAILS,
                     f"mu(I) ratios {', '.join(f'{q:.4f}' for q in ratios)}; iCIDR max growth "
                     f"{', '.join(f'{v:.3f}' for v in ic)} (N = 64, 128, 256)", section="cross-check"))
    return out


def run_checks(crosscheck: bool = True, progress=None) -> list[Check]:
    """Run all symbolic checks (and, optionally, the fast numerical cross-checks);
    `progress(text)`, if given, is told each group as it starts."""
    out = []
    groups = [(mod.__name__.rpartition(".")[2], mod.checks) for mod in (rheologies, cidr, icidr, linearize, mui,
                                                                        dissipation)]
    if crosscheck:
        groups.append(("numerical cross-checks", crosscheck_rows))
    for k, (name, checks) in enumerate(groups):
        if progress is not None:
            progress(f"verify [{k + 1}/{len(groups) + 1}] {name} ...")
        out.extend(checks())
    return out


def unexpected_failures(checks) -> list[Check]:
    """Failed checks that are not known transcription errors."""
    return [c for c in checks if c.status == FAILS and c.equation not in KNOWN_TRANSCRIPTION_ERRORS]


def format_table(checks, width: int = 60) -> str:
    """Plain-text table: equation | status | claim (wrapped) [| corrected]."""
    lines = [f"{'equation':<22} {'status':<8} claim", "-" * (32 + width)]
    for c in checks:
        claim = textwrap.wrap(c.claim, width) or [""]
        lines.append(f"{c.equation:<22} {c.status:<8} {claim[0]}")
        for extra in claim[1:]:
            lines.append(f"{'':<31} {extra}")
        if c.status == FAILS and c.corrected:
            for i, extra in enumerate(textwrap.wrap("corrected: " + c.corrected, width)):
                lines.append(f"{'':<31} {extra}")
    return "\n".join(lines)


def format_markdown(checks) -> str:
    """Markdown table for docs/verification.md."""
    esc = lambda s: (s or "").replace("|", "\\|")  # noqa: E731
    rows = ["| equation | claim | status | detail / corrected expression |", "|---|---|---|---|"]
    for c in checks:
        det = c.detail if c.status != FAILS else f"**corrected:** {c.corrected}. {c.detail}"
        if len(det) > 400:
            det = det[:400] + " ..."
        rows.append(f"| {esc(c.equation)} | {esc(c.claim)} | {c.status} | {esc(det)} |")
    return "\n".join(rows)


def write_json(checks, path) -> None:
    """JSON list of {equation, status, detail, claim[, corrected]}."""
    from icidr_pde.outputs import write_atomically  # noqa: PLC0415

    write_atomically(path, lambda fh: json.dump([c.to_json() for c in checks], fh, indent=2))


def stderr_progress():
    """A progress(text) that tells a person at a terminal each stage, on stderr (stdout holds the
    report; a pipe or a log gets only the report and, on bad input, the one error line); None
    where stderr is not a terminal."""
    if not sys.stderr.isatty():
        return None
    return lambda text: print(text, file=sys.stderr, flush=True)


def verify(json_path=None, markdown_path=None, crosscheck=True, stream=print) -> int:
    """Run the report, print the table, optionally write JSON/markdown; exit code 0 unless unexpected failures."""
    from icidr_pde.outputs import check_outputs, write_atomically  # noqa: PLC0415

    from . import plane  # noqa: PLC0415  (2-D plane waves: the direction the 1-D appendix A leaves out)
    from . import spatial  # noqa: PLC0415  (3-D plane waves: the deformations the x-z plane leaves out)

    check_outputs({"--json": json_path, "--markdown": markdown_path})
    t0 = time.perf_counter()
    progress = stderr_progress()  # at a terminal, on stderr: stdout holds the table
    checks = run_checks(crosscheck, progress)
    n_groups = 7 + bool(crosscheck)
    if progress is not None:
        progress(f"verify [{n_groups}/{n_groups}] plane waves ...")
    checks += plane.checks() + spatial.checks()
    stream(format_table(checks))
    n = {s: sum(c.status == s for c in checks) for s in ("exact", "numeric", "fails")}
    stream(f"\n{len(checks)} checks: {n['exact']} exact, {n['numeric']} numeric, {n['fails']} fail "
           f"(known transcription errors: {', '.join(sorted(KNOWN_TRANSCRIPTION_ERRORS))}); "
           f"{time.perf_counter() - t0:.1f} s")
    if json_path:
        write_json(checks, json_path)
    if markdown_path:
        text = format_markdown(checks) + "\n"
        write_atomically(markdown_path, lambda fh: fh.write(text))
    bad = unexpected_failures(checks)
    if bad:
        stream("UNEXPECTED failures: " + ", ".join(c.equation for c in bad))
        return 1
    return 0
