"""CLI: verify and stability subcommands wired into a fresh ArgumentParser."""

import argparse
import json

import pytest

from icidr_pde.cli import main
from icidr_pde.cli import stability as cli
from icidr_pde.cli import verify
from stability import report


def _parser():
    parser = argparse.ArgumentParser(prog="icidr-pde")
    sub = parser.add_subparsers(dest="command", required=True)
    verify.add_parser(sub)
    cli.add_parser(sub)
    return parser


def _cmd(args):
    return {"verify": verify, "stability": cli}[args.command].cmd(args)


def test_stability_subcommand_json(tmp_path, capsys):
    out = tmp_path / "s.json"
    args = _parser().parse_args(["stability", "--rheology", "mui", "--phi", "0.78", "--uz", "0.0333333", "--wz",
                                 "0.05", "--xi", "1e4", "--json", str(out)])
    assert _cmd(args) == 0
    data = json.loads(out.read_text())
    for k in ("M", "chi", "trace_gamma", "det_gamma", "lambda_plus", "lambda_minus", "max_re_eig_over_xi2",
              "lambda0_limit"):
        assert k in data
    assert data["lambda_plus"] > data["lambda_minus"]
    assert "ILL-POSED" in capsys.readouterr().out


def test_stability_subcommand_bad_input(capsys):
    args = _parser().parse_args(["stability", "--rheology", "icidr", "--phi", "0.9", "--uz", "0.1", "--wz", "0"])
    assert _cmd(args) == 2
    assert "phi" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _parser().parse_args(["stability", "--rheology", "newtonian", "--phi", "0.7", "--uz", "1", "--wz", "0"])


def test_verify_json_structure(all_checks, tmp_path, capsys):
    path = tmp_path / "v.json"
    report.write_json(all_checks, path)
    data = json.loads(path.read_text())
    assert all(set(d) >= {"equation", "status", "detail"} for d in data)
    assert {d["status"] for d in data} <= {"exact", "numeric", "fails"}
    assert {d["equation"] for d in data if d["status"] == "fails"} == report.KNOWN_TRANSCRIPTION_ERRORS
    assert all("corrected" in d for d in data if d["status"] == "fails")
    txt = report.format_table(all_checks)
    assert "(A13)" in txt and "corrected:" in txt


@pytest.mark.slow
def test_verify_subcommand_full(tmp_path):
    out = tmp_path / "v.json"
    args = _parser().parse_args(["verify", "--json", str(out)])
    assert _cmd(args) == 0
    data = json.loads(out.read_text())
    assert any(d["equation"] == "(A4) growth" and d["status"] == "numeric" for d in data)


def test_module_entry_point_help():
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
