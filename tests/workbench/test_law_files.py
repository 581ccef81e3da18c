"""Law files: ill-defined laws refused or flagged, errors in one line (exit 2), built-in names kept,
Python law files announced as programs, declarative (*.toml) laws parsed by a whitelist, never eval."""

import builtins
import json
import pathlib

import numpy as np
import pytest
import sympy as sp

from icidr_pde.cli import main
from icidr_pde.rheology import RHEOLOGIES, define_cidr_law, define_direct_law, define_rheology, get_rheology
from icidr_pde.rheology import symbols as s
from icidr_pde.rheology.cidr import ill_defined, pressure_symbol
from icidr_pde.rheology.law_files import load_law_file
from icidr_pde.rheology.declarative import parse_expression

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
DIRECT = '''name = "{name}"
def pressure(phi, div_u, norm_S, M, Psi, prm):
    return {p}
def shear_stress(phi, div_u, norm_S, M, Psi, prm):
    return M * (norm_S / Psi)**2
'''


def law_file(tmp_path, name, p="(norm_S / Psi)**2", text=None, suffix=".py"):
    path = tmp_path / f"{name.replace('-', '_')}{suffix}"
    path.write_text(text if text is not None else DIRECT.format(name=name, p=p))
    return str(path)


def one_line_error(capsys, argv):
    """Run the CLI; assert exit 2 and a single error line without a traceback; return that line."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


# --- item 11: ill-defined laws ---------------------------------------------------------------

def test_nan_pressure_is_refused_by_check_and_run(tmp_path, capsys):
    f = law_file(tmp_path, "nan-law", p="sp.nan", text="import sympy as sp\n" + DIRECT.format(name="nan-law", p="sp.nan"))
    for argv in (["law", "check", f, "--no-curves"], ["run", "--rheology", f, "--t-end", "0.1", "--no-progress"]):
        err = one_line_error(capsys, argv)
        assert "not finite" in err and "nan" in err and "WELL-POSED" not in err


def test_pressure_nan_on_part_of_the_states_is_refused_with_a_state(tmp_path, capsys):
    # sqrt(div_u) is not real where the flow compacts (div_u < 0)
    f = law_file(tmp_path, "sqrt-div", p="(norm_S / Psi)**2 + sp.sqrt(div_u)",
                 text="import sympy as sp\n" + DIRECT.format(name="sqrt-div", p="(norm_S / Psi)**2 + sp.sqrt(div_u)"))
    err = one_line_error(capsys, ["law", "check", f, "--no-curves"])
    assert "p is not finite" in err and "div_u = -" in err


def test_negative_pressure_is_flagged_by_check_and_refused_by_run(tmp_path, capsys):
    f = law_file(tmp_path, "negative-p", p="-(norm_S / Psi)**2")
    assert main(["law", "check", f, "--no-curves", "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "verdict: ILL-DEFINED (p < 0)" in out and "WELL-POSED" not in out
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["well_posed"] is False and report["runnable"] is False
    (failure,) = report["defined"]["failures"]
    st = failure["counterexample"]
    psi = (0.817 - st["phi"]) / 0.314                      # (2.13) with Table 1
    assert failure["value"] == pytest.approx(-(st["norm_S"] / psi) ** 2, rel=1e-12)
    err = one_line_error(capsys, ["run", "--rheology", f, "--t-end", "0.1", "--no-progress"])
    assert "p < 0" in err and "phi = " in err and "cannot be run" in err


def test_the_shipped_laws_are_defined_where_they_are_run():
    # (4.12): p is a square; (4.14): c = 4 G/Psi^2 with the gap G >= 0; mu(I): p = (2||S||/Psi)^2, c = mu p/||S||
    for name in ("icidr", "mui"):
        assert ill_defined(get_rheology(name)) == []


@pytest.mark.parametrize("body, expected", [
    ("(norm_S / Psi)**2 * foo", "NameError: name 'foo' is not defined"),
    ("(norm_S / Psi)**2 + 1/(phi - phi)", "not finite"),
    ("(norm_S / Psi)**2 * sp.Symbol('gamma')", "uses gamma, not a symbol of the law"),
    ("'(norm_S / Psi)**2'", "must return a sympy expression"),
    ("(norm_S / Psi)**2 * sp.Function('f')(phi)", "uses f(phi), not a symbol of the law"),
    ("(norm_S / Psi)**2 * (1 + sp.besselj(0, phi))", "numba/numpy kernels cannot be generated"),
])
def test_law_function_errors_are_one_line(tmp_path, capsys, body, expected):
    f = law_file(tmp_path, "faulty", text="import sympy as sp\n" + DIRECT.format(name="faulty", p=body))
    err = one_line_error(capsys, ["law", "check", f, "--no-curves"])
    assert expected in err and ("faulty.py" in err or "law 'faulty'" in err)


def test_syntax_error_and_sys_exit_are_one_line(tmp_path, capsys):
    f = law_file(tmp_path, "syntax", text="def pressure(phi:\n    return 1\n")
    err = one_line_error(capsys, ["law", "check", f])
    assert "syntax error at line 1" in err and "nothing in it was run" in err
    f = law_file(tmp_path, "leaves", text="import sys\nsys.exit(0)\n")
    assert "sys.exit(0)" in one_line_error(capsys, ["law", "check", f])


# --- item 12: built-in names --------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".py", ".toml"])
def test_a_law_file_cannot_take_a_builtin_name(tmp_path, capsys, suffix):
    text = (DIRECT.format(name="icidr", p="(norm_S / Psi)**2") if suffix == ".py" else
            'name = "icidr"\npressure = "(norm_S / Psi)**2"\nc = "M * norm_S / Psi**2"\n')
    f = law_file(tmp_path, "impostor", text=text, suffix=suffix)
    for argv in (["law", "check", f], ["run", "--rheology", f, "--t-end", "0.1", "--no-progress"]):
        err = one_line_error(capsys, argv)
        assert "'icidr' is a built-in law's" in err
    assert RHEOLOGIES["icidr"].__module__ == "icidr_pde.rheology.icidr"


def test_the_api_cannot_take_a_builtin_name_either():
    p, c = (2 * s.norm_S / s.Psi) ** 2, 4 * s.M * s.norm_S / s.Psi**2
    for define in (lambda: define_rheology("mui", p, c, register=False),
                   lambda: define_direct_law("icidr", p, c * s.norm_S, register=False),
                   lambda: define_cidr_law("mu-psi", s.M * pressure_symbol(), s.M, register=False)):
        with pytest.raises(ValueError, match="is a built-in law's"):
            define()
    define_rheology("mui_twice_for_test", p, c)           # a law defined at run time may be redefined
    define_rheology("mui_twice_for_test", p, c)


# --- item 19: Python law files are programs; declarative files are data ---------------------------

def test_a_python_law_file_that_ran_says_so(tmp_path, capsys):
    marker = tmp_path / "it-ran"
    f = law_file(tmp_path, "runs", text=f"open({str(marker)!r}, 'w').close()\nname = 'runs'\n")
    err = one_line_error(capsys, ["law", "check", f])
    assert marker.exists() and "(it was run)" in err and "nothing" not in err


def test_help_says_a_python_law_file_is_run(capsys):
    for argv in (["law", "check", "--help"], ["run", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        text = " ".join(capsys.readouterr().out.split())
        assert "RUN" in text and "*.toml" in text and "security.md" in text


@pytest.mark.parametrize("text, token", [
    ("__import__('os').system('true')", "__import__"),
    ("phi.__class__", "phi.__class__"),
    ("exp.__globals__", "exp"),
    ("M * os.getcwd()", "os"),
    ("[phi][0]", "[phi][0]"),
    ("phi.real", "phi.real"),
    ("'phi'", "'phi'"),
    ("(lambda: 1)()", "lambda: 1"),
    ("phi if phi else 1", "phi if phi else 1"),
    ("phi < 1", "phi < 1"),
    ("M * gamma", "gamma"),
    ("sqrt(phi, 2)", "sqrt(phi, 2)"),
    ("sqrt(x=phi)", "sqrt(x=phi)"),
    ("2**10**10", "2**10**10"),
    ("phi // 2", "phi // 2"),
    ("1/(phi - phi)", "1/(phi - phi)"),
    ("True * phi", "True"),
])
def test_the_parser_refuses_everything_but_formulas(text, token):
    names = {"phi": s.phi, "M": s.M}
    with pytest.raises(ValueError) as err:
        parse_expression(text, names, "law file 'x.toml': pressure")
    message = str(err.value)
    assert message.startswith("law file 'x.toml': pressure: expression ") and f"{token!r} is not allowed" in message
    assert "\n" not in message


def test_the_parser_reads_formulas_exactly():
    names = {"phi": s.phi, "M": s.M, "Psi": s.Psi, "k": sp.Rational(1, 2)}
    got = parse_expression("-M * sqrt(phi)**3 / (4 * Psi) + Max(phi, 0.1, k) - abs(-Psi) + 2.5e-1**2", names)
    assert got == -s.M * s.phi ** sp.Rational(3, 2) / (4 * s.Psi) + sp.Max(s.phi, sp.Rational(1, 2)) - s.Psi \
        + sp.Rational(1, 16)
    with pytest.raises(ValueError, match="not a formula"):
        parse_expression("phi +", names)


def test_declarative_files_are_never_evaluated(tmp_path, monkeypatch):
    """Loading a .toml law calls neither eval, exec nor sympify on text."""
    def refuse(*args, **kwargs):
        raise AssertionError("eval/exec/sympify of text")

    real = sp.sympify

    def sympify(a, *args, **kwargs):
        if isinstance(a, str):
            refuse()
        return real(a, *args, **kwargs)

    monkeypatch.setattr(builtins, "eval", refuse)
    monkeypatch.setattr(builtins, "exec", refuse)
    monkeypatch.setattr(sp, "sympify", sympify)
    cls = load_law_file(EXAMPLES / "half_rate_law.toml")
    assert cls.name == "half-rate-toml"


def test_declarative_errors_name_file_key_expression_and_token(tmp_path, capsys):
    f = law_file(tmp_path, "hostile", suffix=".toml",
                 text='pressure = "(norm_S / Psi)**2"\nc = "M * __import__(\'os\').getpid()"\n')
    err = one_line_error(capsys, ["law", "check", f])
    assert f"law file {f!r}: c: expression" in err and "'__import__' is not allowed" in err
    f = law_file(tmp_path, "broken", suffix=".toml", text='pressure = "(norm_S / Psi)**2\n')
    assert "is not valid TOML" in one_line_error(capsys, ["law", "check", f])
    f = law_file(tmp_path, "typo", suffix=".toml", text='pressure = "1"\nshear_stres = "1"\n')
    assert "must define yield_function and dilatancy_function" in one_line_error(capsys, ["law", "check", f])
    f = law_file(tmp_path, "material", suffix=".toml",
                 text='pressure = "(norm_S / Psi)**2"\nc = "M"\n[material]\nmu_s = "low"\n')
    err = one_line_error(capsys, ["law", "check", f])
    assert err.startswith(f"icidr-pde: error: law file {f!r}: ") and "`mu_s` must be a finite number" in err


def test_define_rheology_reads_text_with_the_safe_parser():
    cls = define_rheology("mui_from_text", "(2 * norm_S / Psi)**2", "4 * M * norm_S / Psi**2", register=False)
    p, c = cls().law(s.phi, s.div_u, s.norm_S, s.M, s.Psi, {})
    assert p == (2 * s.norm_S / s.Psi) ** 2 and c == 4 * s.M * s.norm_S / s.Psi**2
    with pytest.raises(ValueError, match="`p`: expression .*'__import__' is not allowed"):
        define_rheology("hostile_text", "__import__('os').getpid()", "1", register=False)


def test_icidr_written_declaratively_is_the_builtin_law():
    """examples/icidr.toml, (4.7)-(4.8) as formulas: the workbench's (p, c) from them is (4.12), (4.14)."""
    mine = load_law_file(EXAMPLES / "icidr.toml")()
    builtin = get_rheology("icidr")
    args = (s.phi, s.div_u, s.norm_S)
    for a, b in zip(mine.symbolic_stress(*args, symbolic=True), builtin.symbolic_stress(*args, symbolic=True)):
        assert sp.simplify(a - b) == 0
    phi, div, S = np.array([0.6, 0.7, 0.78]), np.array([-0.5, 0.0, 0.4]), np.array([0.3, 1.0, 2.0])
    for a, b in zip(mine.invariant_stress(phi, div, S), builtin.invariant_stress(phi, div, S)):
        np.testing.assert_allclose(a, b, rtol=1e-12)


def test_half_rate_law_toml_is_the_python_example():
    toml, py = load_law_file(EXAMPLES / "half_rate_law.toml")(), load_law_file(EXAMPLES / "half_rate_law.py")()
    for a, b in zip(toml.symbolic_yield(), py.symbolic_yield()):
        assert sp.simplify(a - b) == 0


def test_a_declarative_law_runs_from_the_cli(tmp_path, capsys):
    out = tmp_path / "run.json"
    code = main(["run", "--rheology", str(EXAMPLES / "icidr.toml"), "--accuracy", "draft", "--t-end", "1",
                 "--times", "0", "1", "--no-progress", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    assert data["rheology"] == "icidr-toml" and data["blew_up"] is False and abs(data["mass_drift"]) < 1e-10
