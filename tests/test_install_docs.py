"""docs/distributed.md's install command for the [petsc] extra, which .ci/run also runs.

PETSc's source build takes the first MPI compiler wrappers on PATH, and pip builds every source
distribution of one command before it installs any package of it: the [dem] extra's MPICH (its
mpicc, mpi.h and libmpi.so) must come in the same command as [petsc], not before it, for the
build to take Debian's Open MPI with no variables set (docs/distributed.md, "Install (one-time
build)").
"""
import re
import subprocess
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "distributed.md"


def install_lines() -> list[str]:
    """The shell lines of the ```bash block of the page's "Install (one-time build)" section."""
    section = PAGE.read_text(encoding="utf-8").split("### Install (one-time build)", 1)[1]
    section = re.split(r"^#", section, maxsplit=1, flags=re.M)[0]
    block = re.search(r"^```bash[ \t]*\n(.*?)^```", section, re.S | re.M)
    assert block, "docs/distributed.md: no ```bash block in its Install section"
    return [re.split(r"\s+#", line, maxsplit=1)[0].strip() for line in block.group(1).splitlines() if line.strip()]


def ci_install_command(page: Path = PAGE) -> str:
    """The command .ci/run takes from the page: its own awk program, run on the page."""
    script = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    awk = re.search(r"petsc_install=\$\(awk '(.*?)' docs/distributed\.md\)", script, re.S)
    assert awk, ".ci/run no longer takes the PETSc install command from docs/distributed.md"
    out = subprocess.run(["awk", awk.group(1), str(page)], capture_output=True, text=True, check=True).stdout
    return out.split("#", 1)[0].strip()


def test_one_command_installs_petsc_with_dem_and_no_variables():
    pip = [line for line in install_lines() if line.startswith("pip ")]
    assert len(pip) == 1, pip
    extras = re.fullmatch(r'pip install -e "\.\[([\w,]+)\]"', pip[0])
    assert extras, f"not a plain pip install -e of the project's extras, with no variables: {pip[0]!r}"
    named = set(extras.group(1).split(","))
    assert {"dem", "petsc"} <= named
    defined = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert named <= set(defined)
    assert not any(line.startswith("export ") or re.match(r"[A-Z_]+=", line) for line in install_lines())


def test_ci_runs_the_command_the_page_gives():
    assert ci_install_command() == next(line for line in install_lines() if line.startswith("pip "))


def test_ci_takes_no_pip_line_of_another_section(tmp_path):
    """.ci/run's extraction stops at the Install section's end: a pip line of a later block is not
    taken for it (CI then says the page has none and stops)."""
    page = tmp_path / "page.md"
    page.write_text("### Install (one-time build)\n\n```bash\napt-get install x\n```\n\n### Options\n\n"
                    "```bash\npip install -e \".[petsc]\"\n```\n", encoding="utf-8")
    assert ci_install_command(page) == ""
    page.write_text(page.read_text(encoding="utf-8").replace("apt-get install x", "pip install -e \".[dem,petsc]\""),
                    encoding="utf-8")
    assert ci_install_command(page) == 'pip install -e ".[dem,petsc]"'
