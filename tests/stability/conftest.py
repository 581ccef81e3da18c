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
