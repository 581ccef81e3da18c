"""The README a newcomer reads: short, its links resolve, and it opens with the two set-up commands.

CI extracts the commands of the README's first ```bash block and runs them as written, so the
block holds exactly those two commands (comments after them are allowed).
"""

import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_LINES = 250
SETUP_COMMANDS = [
    "pip install -e . && icidr-pde demo",
    'pip install -e ".[test,dem,docs]" && python -m pytest',
]
FENCE = re.compile(r"^```.*?^```[ \t]*$", re.S | re.M)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def relative_links(markdown: str) -> list[str]:
    """Targets of the Markdown links and images outside fenced code, without URLs or pure anchors."""
    targets = LINK.findall(FENCE.sub("", markdown))
    return [t for t in targets if not re.match(r"^(#|[a-z][a-z0-9+.-]*:)", t, re.I)]


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(markdown: str) -> set[str]:
    """Anchors of the headings of `markdown` (outside fenced code)."""
    return {github_anchor(h) for h in re.findall(r"^#{1,6}\s+(.*)$", FENCE.sub("", markdown), re.M)}


def first_bash_block(markdown: str) -> list[str]:
    """The lines of the first ```bash block."""
    match = re.search(r"^```bash[ \t]*\n(.*?)^```", markdown, re.S | re.M)
    assert match, "README.md has no ```bash block"
    return match.group(1).splitlines()


def commands(lines: list[str]) -> list[str]:
    """Shell commands of `lines`: blank lines and comments dropped, a trailing `  # ...` cut off."""
    out = []
    for line in lines:
        command = re.split(r"\s+#", line, maxsplit=1)[0].strip()
        if command and not command.startswith("#"):
            out.append(command)
    return out


def test_readme_is_short():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"README.md has {n} lines; at most {MAX_LINES} (the rest belongs in docs/)"


def test_readme_opens_with_the_two_setup_commands():
    text = README.read_text(encoding="utf-8")
    assert text.index("```bash") < text.index("```python"), "the set-up commands come before any example"
    assert commands(first_bash_block(text)) == SETUP_COMMANDS


def generated_at_build(target: Path) -> bool:
    """A measurement page the site's build writes (docs/conf.py, docs/benchmark_pages.py): the
    index, or the page of a data/benchmarks file."""
    page = Path(os.path.normpath(str(target).split("#", 1)[0]))
    if page.parent != ROOT / "docs" / "measurements" or page.suffix != ".md":
        return False
    return page.stem == "index" or any((ROOT / "data" / "benchmarks").glob(f"{page.stem}.json*"))


@pytest.mark.parametrize("path", [README, *sorted((ROOT / "docs").glob("*.md"))], ids=lambda p: p.name)
def test_relative_links_point_to_existing_files(path):
    missing = [t for t in relative_links(path.read_text(encoding="utf-8"))
               if not (path.parent / t.split("#", 1)[0]).exists() and not generated_at_build(path.parent / t)]
    assert not missing, f"{path.relative_to(ROOT)} links to files that do not exist: {missing}"


@pytest.mark.parametrize("path", [README, *sorted((ROOT / "docs").glob("*.md"))], ids=lambda p: p.name)
def test_anchors_of_links_into_markdown_exist(path):
    broken = []
    for target in relative_links(path.read_text(encoding="utf-8")) + [
            "#" + a for a in re.findall(r"\]\(#([^)\s]+)\)", FENCE.sub("", path.read_text(encoding="utf-8")))]:
        file, _, anchor = target.partition("#")
        linked = (path.parent / file) if file else path
        if anchor and linked.suffix == ".md" and linked.exists() and \
                anchor not in anchors(linked.read_text(encoding="utf-8")):
            broken.append(target)
    assert not broken, f"{path.relative_to(ROOT)} links to headings that do not exist: {broken}"


def test_link_parser_on_known_cases():
    """The parser finds links and images, skips URLs, anchors and code, and keeps the path of path#anchor."""
    text = ("![a](docs/a.png) [b](docs/b.md#x) [c](https://example.org) [d](#top) [e](mailto:x@y)\n"
            "```\n[f](not/a/link.md)\n```\n")
    assert relative_links(text) == ["docs/a.png", "docs/b.md#x"]
    assert commands(["# comment", "", "a && b   # note", "c"]) == ["a && b", "c"]
    assert github_anchor("Integrators (`--method`) and Jacobians") == "integrators---method-and-jacobians"
    assert github_anchor("1-D: μ(I),Φ(I) fails") == "1-d-μiφi-fails"
