"""Every subcommand of ``icidr-pde`` (and every subcommand of a subcommand: ``law check``, ``study
sim2d``, ``figures sim2d-fields``, ...) answers ``--help``, in process, with exit status 0 and a
usage line that names it; and every registered subcommand is a module with ``add_parser`` and ``cmd``."""

import argparse
import importlib
import re

import pytest

from icidr_pde import cli


def _paths(parser, prefix=()):
    """Every command path below `parser`: ('law',), ('law', 'check'), ..."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield (*prefix, name)
                yield from _paths(sub, (*prefix, name))


PATHS = list(_paths(cli.make_parser()))


def test_the_walk_finds_the_nested_subcommands():
    assert {("run",), ("law", "check"), ("cache", "clear"), ("dem", "pool"), ("study", "sim2d"),
            ("study", "grid-convergence"), ("study", "references"), ("figures", "sim2d-fields"),
            ("figures", "fd-growth"), ("figures", "plane-waves")} <= set(PATHS)
    assert {path[0] for path in PATHS} == set(cli.SUBCOMMANDS)


@pytest.mark.parametrize("path", PATHS, ids=" ".join)
def test_help_of_every_subcommand(path, capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main([*path, "--help"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: icidr-pde {' '.join(path)}"), out[:200]
    # no default appended to a help that already gives one, and only a default that means something
    for option in re.split(r"\n  (?=-)", out.split("options:", 1)[-1]):
        option = " ".join(option.split())
        said = option.rsplit("(default", 1)[0]
        assert not ("default" in said and re.search(r"\(default: [^()]*\)$", option)), option
        assert "(default: None)" not in option and "(default: False)" not in option, option


@pytest.mark.parametrize("name", list(cli.SUBCOMMANDS))
def test_each_subcommand_is_a_module_with_add_parser_and_cmd(name):
    module = importlib.import_module(cli.SUBCOMMANDS[name][0])
    assert callable(module.add_parser) and callable(module.cmd)
    parser = argparse.ArgumentParser()
    sub = module.add_parser(parser.add_subparsers(dest="command"))
    assert isinstance(sub, argparse.ArgumentParser) and sub.prog.endswith(f" {name}")
