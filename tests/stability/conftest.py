"""Fixtures for the stability tests; makes the repository root importable."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="session")
def all_checks():
    """All symbolic checks of the verify report (computed once per session)."""
    from stability import report

    return report.run_checks(crosscheck=False)


@pytest.fixture(scope="session")
def checks_by_eq(all_checks):
    out = {}
    for c in all_checks:
        out.setdefault(c.equation, []).append(c)
    return out


ILL_POSED = {"phi": 0.78, "uz": 1.0 / 30.0, "wz": 0.05}


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which turns the marks into groups
def pytest_collection_modifyitems(items):
    """The tests of the symbolic report share one worker under pytest-xdist, so that its ~30 s
    of sympy (all_checks) runs once per session instead of once per worker."""
    for item in items:
        if {"all_checks", "checks_by_eq"} & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.xdist_group("symbolic_report"))
