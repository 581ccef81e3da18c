"""The measurements section: one Markdown page per data/benchmarks file, written at each build.

A table shown here is the file a benchmark wrote, so that no table can outlive its data: each page
is headed by the command that measured it and the date and load the file records (or says "not
recorded"): the record benchmarks/provenance.py writes under "provenance" (command, date, load at
start and end, machine, commit) where the file has one, else the keys files measured before it
hold ("command", "measured", "date", "load", "note"). A file measured before provenance.py says
so on its page: it records no machine and no commit, and what it does not record of its command,
date and load is taken from where the guides say how it was made (:func:`guide_sources`): a
"*Dated record*" line naming the file, else a command in a guide that writes it, else the
benchmark whose default output it is, each quoted with the page it is on. Each table row names
the JSON entry it shows (``rows[2].fast``), so that a reader
and tests/test_benchmark_pages.py can find every number in the file. A file whose shape the
renderer does not know, or that records neither command, date nor load, is listed on the index
as raw data, not rendered, never skipped (with what the guides say of it).

Used by docs/conf.py (``write_pages``); ``render`` returns one file's page.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

# a float is shown with this many significant digits (the test checks the rounding shown)
DIGITS = 4
# the keys whose values a table holds one entry per element or member of
TABLE_KEYS = ("rows", "data", "cases", "runs")
# the entry column's name for the file's top-level values
TOP_LEVEL = "(top level)"
PROVENANCE_KEYS = ("provenance", "command", "commands", "measured", "date", "note", "load")
ROOT = Path(__file__).resolve().parents[1]
#: what a page says of a file measured before benchmarks/provenance.py
UNSTAMPED = ("not stamped: measured before benchmarks/provenance.py, so the file records no machine "
             "and no commit")
_DATED_RECORD = re.compile(r"^\*Dated record\*: `(?P<command>[^`]+)`(?P<rest>.*)$")
_INLINE_COMMAND = re.compile(r"`((?:[A-Z_]+=\S+ )*(?:nice -n \d+ )?python3? benchmarks/[^`]+)`")
_FENCED = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)
_DEFAULT_OUTPUT = re.compile(r"""add_argument\(\s*"--(?:json|out)",[^)]*default=["']data/benchmarks/([\w.]+)["']""")


def _names_file(text: str, name: str) -> bool:
    return re.search(rf"data/benchmarks/{re.escape(name)}(?![\w.])", text) is not None


def _guide_commands(text: str):
    """(command, its line) of each shell command of a page: the lines of its fenced blocks
    (continuations after a backslash joined) and the commands in backticks in its prose."""
    fence, pending = False, ""
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fence, pending = not fence, ""
            continue
        if fence:
            pending += line.strip()
            if pending.endswith("\\"):
                pending = pending[:-1].rstrip() + " "
                continue
            yield pending.split("  #", 1)[0].strip(), pending
            pending = ""
        else:
            for command in _INLINE_COMMAND.findall(line):
                yield command, line


def guide_sources(name: str, docs: Path | None = None, benchmarks: Path | None = None) -> list[str]:
    """What the guides say of how the data file `name` was made, as heading lines of its page:
    every "*Dated record*" line of docs/*.md that names it; if none, the commands of a guide
    that write it (``--json data/benchmarks/NAME``, or a comment naming it beside the command);
    if none, the benchmark whose default output it is."""
    docs = docs or ROOT / "docs"
    benchmarks = benchmarks or ROOT / "benchmarks"
    pages = sorted(p for p in docs.glob("*.md"))
    records, commands = [], []
    for page in pages:
        text = page.read_text()
        for line in text.splitlines():
            m = _DATED_RECORD.match(line)
            if m and _names_file(line, name):
                records.append(f"- **Dated record in a guide:** `{m['command']}`{m['rest'].rstrip()} "
                               f"(docs/{page.name})")
        for command, line in _guide_commands(text):
            if "benchmarks/" in command and _names_file(line, name) and not _DATED_RECORD.match(line):
                entry = f"- **Command in a guide:** `{command}` (docs/{page.name})"
                if entry not in commands:
                    commands.append(entry)
    if records:
        return records
    if commands:
        return commands
    for script in sorted(benchmarks.glob("*.py")):
        if name in _DEFAULT_OUTPUT.findall(script.read_text()):
            return [f"- **Written by:** `python benchmarks/{script.name}` (its default output; "
                    "the arguments are not recorded)"]
    # the benchmark whose name the file's begins with (cheb_krylov_rtol.json: cheb_krylov.py),
    # with the arguments a guide quotes beside the file's name, if any
    stem = Path(name).stem
    scripts = sorted((s for s in benchmarks.glob("*.py") if stem.startswith(s.stem)), key=lambda s: -len(s.stem))
    if not scripts:
        return []
    quoted = sorted({f"`{' '.join(fragment.split())}` (docs/{page.name})" for page in pages
                     for fragment in re.findall(r"`([^`]+)`", _FENCED.sub("", page.read_text()))
                     if _names_file(fragment, name) and "\n\n" not in fragment})
    return [f"- **Written by:** `python benchmarks/{scripts[0].name}` (the benchmark the file is named after; "
            + (f"the arguments a guide quotes: {' ; '.join(quoted)})" if quoted
               else "no guide quotes its arguments)")]


def _is_scalar(value) -> bool:
    return value is None or isinstance(value, (bool, int, float, str))


def _shown(value) -> str:
    if value is None:
        return "—"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:.{DIGITS}g}"
    return str(value).replace("|", "\\|").replace("\n", " ")


def _records(entries, path: str, context: dict) -> list[tuple[str, dict]]:
    """(JSON path, scalar fields) of each entry; an entry whose members are themselves records
    (a size's runs under several configurations) gives one record per member, with its own
    scalars as context."""
    items = enumerate(entries) if isinstance(entries, list) else entries.items()
    out = []
    for key, entry in items:
        here = f"{path}[{key}]" if isinstance(entries, list) else f"{path}.{key}"
        if not isinstance(entry, dict):
            continue
        scalars = {k: v for k, v in entry.items() if _is_scalar(v)}
        members = {k: v for k, v in entry.items()
                   if isinstance(v, dict) and any(_is_scalar(x) for x in v.values())
                   and any(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v.values())
                   and not all(_is_number_key(name) for name in v)}
        if members and isinstance(entries, dict) and not scalars:
            # cases.shear-fd.{first, baseline, project}: one record per variant
            out += _records(members, here, context)
        elif members and len(scalars) <= 3:
            out += _records(members, here, {**context, **scalars})
        elif scalars:
            out.append((here, {**context, **scalars}))
    return out


def _is_number_key(name: str) -> bool:
    try:
        float(name)
    except ValueError:
        return False
    return True


def _member(path: str) -> str:
    """The part of an entry's path below its row or case (``fast`` of ``rows[0].fast``): entries
    with the same member share a table, so that a column holds one quantity (a count in
    ``counts``, a time in ``parts``)."""
    steps = re.findall(r"\.?([^.\[\]]+)|\[(\d+)\]", path)[2:]
    return ".".join(key or f"[{index}]" for key, index in steps)


def tables(data) -> list[tuple[str, list[tuple[str, dict]]]]:
    """(title, records) of each table the renderer can show of `data`; [] if none."""
    if not isinstance(data, dict):
        return []
    out = []
    for key in TABLE_KEYS:
        if isinstance(data.get(key), (list, dict)) and data[key]:
            records = _records(data[key], key, {})
            if records:
                out.append((key, records))
    return out


def _table(records: list[tuple[str, dict]]) -> list[str]:
    columns: list[str] = []
    for _, fields in records:
        columns += [name for name in fields if name not in columns]
    lines = ["| entry | " + " | ".join(columns) + " |", "|" + "---|" * (len(columns) + 1)]
    for path, fields in records:
        lines.append(f"| {f'`{path}`' if path else TOP_LEVEL} | " + " | ".join(_shown(fields.get(c)) if c in fields else ""
                                                  for c in columns) + " |")
    return lines


def _recorded(record: dict, note) -> list[str]:
    """The heading lines of a file stamped by benchmarks/provenance.py."""
    lines = [f"- **Command:** `{record['command']}`" if record.get("command") else "- **Command:** not recorded",
             f"- **Date:** {record['date']}" if record.get("date") else "- **Date:** not recorded"]
    load = record.get("load") or {}
    for moment in ("start", "end"):
        if load.get(moment):
            lines.append(f"- **Load at {moment}:** " + ", ".join(_shown(x) for x in load[moment]))
    if not any(load.get(moment) for moment in ("start", "end")):
        lines.append("- **Load:** not recorded")
    machine = [f"{record['cores']} cores" if record.get("cores") else "",
               f"{_shown(record['memory_gib'])} GiB" if record.get("memory_gib") else "",
               f"Python {record['python']}" if record.get("python") else "", record.get("platform") or ""]
    if any(machine):
        lines.append("- **Machine:** " + ", ".join(m for m in machine if m))
    if record.get("commit"):
        lines.append(f"- **Commit:** `{record['commit']}`" + (" (tracked files modified)" if record.get("modified") else ""))
    if note:
        lines.append(f"- **Note:** {note}")
    return lines


def _provenance(data: dict, name: str | None = None) -> list[str]:
    if isinstance(data.get("provenance"), dict):  # preferred to the keys of files measured before it
        return _recorded(data["provenance"], data.get("note"))
    stamp = [f"- **Provenance:** {UNSTAMPED}"] + (guide_sources(name) if name else [])
    command = data.get("command") or data.get("commands")
    if isinstance(command, list):
        command = " ; ".join(command)
    date = data.get("measured") or data.get("date")
    load = data.get("load")
    note = data.get("note")
    lines = stamp + [
        f"- **Command:** `{command}`" if command else "- **Command:** not recorded in the file",
        f"- **Date:** {date}" if date
        else "- **Date:** as recorded in the note" if note and re.search(r"\b(19|20)\d\d\b", note)
        else "- **Date:** not recorded in the file"]
    if isinstance(load, list):
        lines.append("- **Load (as recorded):** " + ", ".join(_shown(x) for x in load))
    elif load is not None:
        lines.append(f"- **Load (as recorded):** {_shown(load)}")
    elif "load" in f"{date} {note}":
        # recorded in words, beside the date ("uptime load 0.5-1.0")
        lines.append("- **Load:** as recorded in the date or note")
    else:
        lines.append("- **Load:** not recorded in the file")
    if note:
        lines.append(f"- **Note:** {note}")
    return lines


def render(path: Path) -> str | None:
    """The Markdown page of one data file, or None if the renderer cannot place it."""
    try:
        data = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError):
        return None
    found = tables(data)
    # a table whose file records neither its command, date nor load is not a measurement a
    # reader can place (the work-precision files: their own page, work_precision_tables.md)
    if not found or not any(data.get(key) for key in PROVENANCE_KEYS if key != "note"):
        return None
    lines = [f"# {path.stem}", "", f"Generated from `data/benchmarks/{path.name}` at the build.", ""]
    lines += _provenance(data, path.name) + [""]
    settings = {k: v for k, v in data.items() if _is_scalar(v) and k not in PROVENANCE_KEYS}
    if settings:
        lines += ["## settings", ""] + _table([("", settings)]) + [""]
    for title, records in found:
        groups: dict[str, list] = {}
        for record in records:
            groups.setdefault(_member(record[0]), []).append(record)
        for member, group in groups.items():
            lines += [f"## {title}: {member}" if member else f"## {title}", ""] + _table(group) + [""]
    return "\n".join(lines)


def _raw_provenance(path: Path) -> str:
    """What the index says of how a raw file was made: its stamp, or that it has none and what
    the guides say of it."""
    try:
        data = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError):
        data = None  # JSON lines: the first line tells
        first = path.read_text().splitlines()[:1]
        try:
            data = json.loads(first[0]) if first else None
        except ValueError:
            pass
    if isinstance(data, dict) and isinstance(data.get("provenance"), dict):
        record = data["provenance"]
        return f"; stamped: `{record.get('command')}`, {record.get('date')}, commit `{record.get('commit')}`"
    sources = [line.split(":** ", 1)[1] for line in guide_sources(path.name)]
    return f"; {UNSTAMPED}" + (f"; the guides: {' ; '.join(sources)}" if sources else "")


def write_pages(data_dir: Path, out_dir: Path) -> dict[str, str | None]:
    """Write one page per renderable file of `data_dir` and an index listing every file into
    `out_dir`; returns {file name: page name or None}."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for old in out_dir.glob("*.md"):
        old.unlink()
    placed: dict[str, str | None] = {}
    for path in sorted(p for p in data_dir.iterdir() if p.suffix in (".json", ".jsonl")):
        page = render(path)
        placed[path.name] = path.stem if page is not None else None
        if page is not None:
            (out_dir / f"{path.stem}.md").write_text(page)
    rendered = [name for name, page in placed.items() if page]
    raw = [name for name, page in placed.items() if not page]
    index = ["# Measurements", "",
             "Each page below is generated at the build from the file a benchmark wrote in "
             "`data/benchmarks/`: its command, date and load as the file records them, and its "
             "tables as the file holds them.", "",
             "```{toctree}", ":maxdepth: 1", ""] + [placed[name] for name in rendered] + ["```", ""]
    if raw:
        index += ["## Raw data, not rendered", "",
                  "The renderer does not place these files: a shape it does not know, or no "
                  "command, date or load recorded. Read them as JSON; a guide that quotes one "
                  "names it.", ""]
        for name in raw:
            index.append(f"- `data/benchmarks/{name}`: raw data, not rendered" + _raw_provenance(data_dir / name))
        index.append("")
    (out_dir / "index.md").write_text("\n".join(index))
    return placed
