"""``icidr-pde law {check,list}``: the rheology workbench from the command line.

``law check NAME|FILE [--json out.json]`` prints conditions (4.3)-(4.5) (status, method,
counterexample), whether p and c are finite and >= 0 on the sample (else the verdict is
ILL-DEFINED, with the state), the equation of state, the symbol in 1-D, 2-D and 3-D and,
separately, the verdict: the symbol's on its grid of states ((4.3)-(4.5) are sufficient,
not necessary: they prove well-posedness at every state where they hold), and writes the full report (:func:`stability.workbench.law_report`) as JSON.
``law list`` lists the registered laws. Exit codes: 0 (the report was made, whatever the
verdict), 2 (bad input: unknown law, a law file that cannot be used, a law whose p or c is
not finite; one line).

A law FILE is ``*.toml`` (declarative: formulas read by a whitelist, nothing in it is run;
:mod:`icidr_pde.rheology.declarative`) or ``*.py``: **a Python law file is a program, and
checking it runs it** with your rights before anything is checked (docs/security.md).
"""

from __future__ import annotations

import json
import sys

from .argtypes import subcommand


def _check(args) -> int:
    from stability.report import stderr_progress
    from stability.workbench import law_report, write_report

    from ..outputs import check_outputs

    check_outputs({"--json": args.json})  # before the law file is run
    report = law_report(args.law, with_curves=not args.no_curves, progress=stderr_progress())
    print(f"law {report['law']} ({report['kind']}; phi in ({report['phi_domain'][0]:g}, "
          f"{report['phi_domain'][1]:g}))")
    for key, c in report["conditions"].items():
        where = "" if c["counterexample"] is None else "  e.g. at " + ", ".join(
            f"{k} = {v:.4g}" for k, v in c["counterexample"].items())
        method = f" ({c['method']})" if c["method"] else ""
        if c["status"] == "fails" and c["method"] == "symbolic":  # proved: the expression says why
            method = f" (symbolic: {c['expression']} {'!= 0' if key == '(4.3)' else ''})".replace(" )", ")")
        print(f"  {key}: {c['status']}{method}{where}")
    pos = report.get("positivity")
    if pos:
        where = "" if pos["counterexample"] is None else "  e.g. at " + ", ".join(
            f"{k} = {v:.4g}" for k, v in pos["counterexample"].items())
        print(f"  Y > 0: {pos['status']} ({pos['method']}){where}")
    defined = report["defined"]
    print(f"  p, c finite, >= 0: {defined['status']} ({defined['method']})" + "".join(
        f"; {f['what']} (= {f['value']:.4g}) e.g. at " + ", ".join(f"{k} = {v:.4g}" for k, v in f["counterexample"].items())
        for f in defined["failures"]))
    eos = report.get("equation_of_state")
    if eos:
        print(f"  equation of state: {eos['method']}; sqrt(p) = {eos['sqrt_p']}")
        if eos["no_positive_root_at"]:
            s = eos["no_positive_root_at"]
            print("  flow rule has no positive solution for p at " + ", ".join(f"{k} = {v:.4g}" for k, v in s.items())
                  + ": stability analysis only")
    st = report["stability"]
    for dim in ("one_d", "two_d"):
        w = st[dim]["max_Lambda_plus"]
        print(f"  symbol {dim.replace('_', '-')}: {'well-posed' if st[dim]['well_posed'] else 'ILL-POSED'} "
              f"(max Re Lambda_+ = {w['Lambda_plus']:.4g} at phi = {w['phi']:.4g}, gamma-dot = {w['gamma_dot']:.4g}, "
              f"div u/||S|| = {w['div_u_over_norm_S']:.3g}; {w['ill_posed_states']} of {st['grid']['states']} "
              "states ill-posed)")
    w3 = st["three_d"]["max_Lambda_plus"]
    print(f"  symbol three-d: {'well-posed' if st['three_d']['well_posed'] else 'ILL-POSED'} (max Re Lambda_+ = "
          f"{w3['Lambda_plus']:.4g} at phi = {w3['phi']:.4g}, gamma-dot = {w3['gamma_dot']:.4g}, div u/||S|| = "
          f"{w3['div_u_over_norm_S']:.3g}, Lode angle {w3['lode_deg']:g} deg; {w3['ill_posed_states']} of "
          f"{st['three_d']['states']} states ill-posed, each over {st['three_d']['directions']} directions)")
    hold = report["conditions_hold"]
    if hold is not None:  # a CIDR law: (4.3)-(4.5) prove well-posedness at every state, the symbol samples it
        failed = [k for k, c in report["conditions"].items() if c["status"] != "holds"]
        print("  CIDR conditions (4.3)-(4.5), sufficient: " + ("hold: well-posed at every state" if hold else
              "not shown (" + ", ".join(failed) + "): no proof for every state, the symbol decides"))
    verdict = ("WELL-POSED" if report["well_posed"] else "ILL-POSED") + f" (the symbol at the {st['grid']['states']} " \
        "sampled states" + (", and (4.3)-(4.5) hold" if hold else "") + ")"
    if defined["failures"]:
        verdict = "ILL-DEFINED (" + ", ".join(f["what"] for f in defined["failures"]) + ")"
    print(f"  verdict: {verdict}")
    if args.json:
        write_report(report, args.json)
        print(f"report written to {args.json}")
    return 0


def _list(args) -> int:
    from stability.workbench import law_list

    laws = law_list()
    if args.json:
        json.dump(laws, sys.stdout, indent=2)
        print()
        return 0
    for law in laws:
        print(f"{law['name']:<22} {law['kind']:<7} {law['doc']}")
    return 0


PYTHON_FILE_WARNING = ("A Python law file is a program: `law check FILE.py` and `run --rheology FILE.py` RUN it with "
                       "your rights before anything is checked. Use only files you would run yourself; share laws "
                       "as *.toml (see docs/security.md).")


def add_parser(subparsers):
    """Add ``law check`` and ``law list`` to the ``icidr-pde`` command."""
    p = subparsers.add_parser("law", help="rheology workbench: check a law for well-posedness, list laws",
                              description="Check a constitutive law: a registered name, a declarative law file "
                                          "*.toml (yield_function/dilatancy_function or pressure/shear_stress "
                                          "formulas, read as data; e.g. examples/icidr.toml) or a Python law file "
                                          "*.py defining those functions.\n" + PYTHON_FILE_WARNING)
    sub = p.add_subparsers(dest="law_command", required=True)
    c = subcommand(sub, "check", _check, help="conditions (4.3)-(4.5), equation of state, symbol over a grid of states",
                   description="Conditions (4.3)-(4.5), p and c finite and >= 0, the equation of state and "
                               "the symbol over a grid of states.\n" + PYTHON_FILE_WARNING
                               + "\nexit status: 0 the report was made (whatever the verdict); 2 bad input "
                                 "(one line; a Python law file may have run by then)")
    c.add_argument("law", help="registered name (see `law list`), a .toml law file, or a .py law file (run!)")
    c.add_argument("--json", default=None, help="write the full report here")
    c.add_argument("--no-curves", action="store_true", help="skip the Y/p and steady mu(I), Phi(I) curves")
    ls = subcommand(sub, "list", _list, help="the registered laws")
    ls.add_argument("--json", action="store_true", help="print the list as JSON")
    return p


def cmd(args) -> int:
    """Run ``law check`` or ``law list``, as parsed."""
    return args.func(args)
