"""The documentation a user reads is consistent with the repository.

* docs/fmus.md is what `python -m ballmill.fmi.docs` generates from ballmill/fmi/interface.py
  (a stale page fails, with the command that fixes it);
* every relative link in README.md and docs/*.md points at a file that exists, and an anchor
  into a Markdown page at one of its headings (a doc never sends a user to a file they do not
  have);
* the design document is docs/design.md: no file cites the old upper-case design notes (a
  file in neither the repository nor its history), and every "design.md section N" names a
  section that docs/design.md has.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from ballmill.fmi import docs as fmi_docs
from ballmill.fmi.interface import INTERFACES

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
# where citations of the design document can be: code, tests, scenarios, docs
SOURCES = ("ballmill", "fmu_src", "drive_models", "tests", "docs", "scenarios", "benchmarks")
TEXT = {".py", ".c", ".h", ".md", ".toml", ".txt", ".cfg"}
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def _text_files():
    files = [p for p in ROOT.iterdir() if p.is_file() and p.suffix in TEXT]
    for top in SOURCES:
        files += [p for p in (ROOT / top).rglob("*") if p.is_file() and p.suffix in TEXT
                  and "__pycache__" not in p.parts and "_work" not in p.parts]
    return files


def _slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to '-'."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    seen, out = {}, set()
    in_code = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_code = not in_code
        m = re.match(r"#{1,6} (.+)$", line)
        if m and not in_code:
            slug = _slug(m.group(1))
            n = seen.get(slug, 0)
            seen[slug] = n + 1
            out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def _links(page: Path):
    """(line number, target) of every Markdown link outside code blocks and code spans."""
    in_code = False
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("```"):
            in_code = not in_code
        if in_code or line.startswith("    "):
            continue
        for m in LINK.finditer(re.sub(r"`[^`]*`", "", line)):
            yield number, m.group(1)


def test_fmus_md_is_generated_from_the_interface():
    page = ROOT / "docs" / "fmus.md"
    assert page.read_text(encoding="utf-8") == fmi_docs.reference(), (
        "docs/fmus.md is stale: regenerate it with `python -m ballmill.fmi.docs > docs/fmus.md`")


def test_fmus_md_lists_every_variable_of_every_fmu_with_its_attributes():
    text = fmi_docs.reference()
    assert set(INTERFACES) == {"BallInShell", "MotorStartup", "InductionMotor", "Fig1Drive", "Structure"}
    for name, interface in INTERFACES.items():
        section = text.split(f"## {name}\n", 1)[1].split("\n## ", 1)[0]
        rows = [line for line in section.splitlines() if re.match(r"\| \d+ \|", line)]
        assert len(rows) == len(interface.variables)
        for vr, (row, v) in enumerate(zip(rows, interface.variables)):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", row)[1:-1]]
            assert cells[:6] == [str(vr), f"`{v.name}`", v.causality, v.fmi_variability, v.type, v.unit or ""]
            for cell, value in ((cells[6], None if v.causality == "output" else v.start),
                                (cells[7], v.min), (cells[8], v.max)):  # start, min, max read back exactly
                if value is None:
                    assert cell == ""
                elif isinstance(value, bool):
                    assert cell == str(value).lower()
                else:
                    assert float(cell) == value
            assert cells[9] == ", ".join(f"`{d}`" for d in v.feedthrough)
            assert interface.value_reference(v.name) == vr


def test_the_generator_runs_as_documented():
    out = subprocess.run([sys.executable, "-m", "ballmill.fmi.docs"], capture_output=True, text=True,
                         cwd=ROOT, check=True)
    assert out.stdout == fmi_docs.reference()


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_point_at_files_that_exist(page):
    broken = []
    for number, target in _links(page):
        if re.match(r"[a-z]+:", target):  # https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{page.relative_to(ROOT)}:{number}: {target} (no file {dest})")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            broken.append(f"{page.relative_to(ROOT)}:{number}: {target} (no heading #{anchor} in "
                          f"{dest.relative_to(ROOT)})")
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_every_page_in_docs_is_in_the_docs_index():
    index = (ROOT / "docs" / "README.md").read_text(encoding="utf-8")
    linked = {target.partition("#")[0] for _, target in _links(ROOT / "docs" / "README.md")}
    missing = [p.name for p in sorted((ROOT / "docs").glob("*.md")) if p.name != "README.md"
               and p.name not in linked]
    assert not missing, f"docs/README.md does not list {missing}"
    assert "[docs/README.md](docs/README.md)" in (ROOT / "README.md").read_text(encoding="utf-8")
    assert index


def test_nothing_cites_the_old_design_notes():
    old = "DESIGN" + ".md"  # spelt apart, so this file does not cite it
    hits = [f"{p.relative_to(ROOT)}:{n}: {line.strip()}" for p in _text_files()
            for n, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
            if old in line]
    assert not hits, ("cite docs/design.md instead of the old design notes:\n" + "\n".join(hits))


def test_every_cited_design_section_exists():
    design = (ROOT / "docs" / "design.md").read_text(encoding="utf-8")
    sections = {int(m.group(1)) for m in re.finditer(r"^## (\d+)\. ", design, re.M)}
    assert sections == set(range(1, max(sections) + 1))
    cite = re.compile(r"design\.md\s+sections?\s+(\d+)(?:\s*(?:,|and|to)\s*(\d+))?")
    wrong = []
    for p in _text_files():
        text = p.read_text(encoding="utf-8", errors="replace")
        for m in cite.finditer(text):
            for number in filter(None, m.groups()):
                if int(number) not in sections:
                    wrong.append(f"{p.relative_to(ROOT)}: {m.group(0)!r}")
    assert not wrong, "citations of sections docs/design.md does not have:\n" + "\n".join(wrong)
