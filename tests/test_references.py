"""Each paper ("seed NNN") and erratum ("SPEC erratum N") cited in the repo is in references.md."""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCES = ROOT / "docs" / "references.md"

#: "seed 000", "Seed 004's", "seeds 000 and 004", "seed 001, 002": exactly three digits, so the
#: random-number seeds of the sea ("sea seed 0", "seeds 0-4", "seed=0") are not papers.
SEED = re.compile(r"\bseeds?\s+(\d{3}(?!\d)(?:\s*(?:,|and|&|or|/)\s*\d{3}(?!\d))*)", re.IGNORECASE)
#: "SPEC erratum 3", "erratum 11" (also across a line break); lists and ranges only after
#: the plural, "errata 3, 4", "errata 3-5", so "erratum 9, a sign slip" cites 9 alone.
ERRATUM = re.compile(r"\berratum\s+#?(\d+)", re.IGNORECASE)
ERRATA = re.compile(r"\berrata\s+#?(\d+(?:\s*(?:,|and|&|or|[-–])\s*\d+)*)", re.IGNORECASE)
CHECK_VALUE = re.compile(r"\bSPEC\s+check\s+values?\b", re.IGNORECASE)

#: Reference headings: "### seed 000" and "### Erratum 3"; fields "- **Title:** ...".
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*$")
SEED_HEADING = re.compile(r"seed (\d{3})")
ERRATUM_HEADING = re.compile(r"Erratum (\d+)")
FIELD = re.compile(r"^- \*\*([A-Za-z ]+):\*\*\s*(.*)$")


class Citation(NamedTuple):
    key: str  # "seed 000", "erratum 3" or "check values"
    line: int  # 1-based


def citations(text: str) -> list[Citation]:
    """All paper, erratum and check-value citations in `text`, in order of position."""
    found: list[tuple[int, str]] = []
    for match in SEED.finditer(text):
        found += [(match.start(), f"seed {n}") for n in re.findall(r"\d{3}", match.group(1))]
    for match in ERRATUM.finditer(text):
        found.append((match.start(), f"erratum {int(match.group(1))}"))
    for match in ERRATA.finditer(text):
        for part in re.split(r"\s*(?:,|and|&|or)\s*", match.group(1)):
            first, _, last = part.replace("–", "-").partition("-")
            numbers = range(int(first), int(last or first) + 1)
            found += [(match.start(), f"erratum {n}") for n in numbers]
    found += [(m.start(), "check values") for m in CHECK_VALUE.finditer(text)]
    found.sort(key=lambda item: item[0])  # stable: a list keeps its written order
    return [Citation(key, text.count("\n", 0, pos) + 1) for pos, key in found]


def entry_key(title: str) -> str | None:
    """The key a references.md heading defines, or None for other headings."""
    if seed := SEED_HEADING.fullmatch(title):
        return f"seed {seed.group(1)}"
    if erratum := ERRATUM_HEADING.fullmatch(title):
        return f"erratum {int(erratum.group(1))}"
    return "check values" if title.lower() == "check values" else None


def entries(markdown: str) -> dict[str, dict[str, str]]:
    """Entries of references.md by key ("seed 000", "erratum 3", "check values") → fields.

    An entry runs from its heading to the next heading of the same or a higher level; its
    fields are the `- **Name:** value` bullets (continuation lines are joined).
    """
    result: dict[str, dict[str, str]] = {}
    current: dict[str, str] | None = None
    level, field = 0, ""
    for line in markdown.splitlines():
        heading = HEADING.match(line)
        if heading:
            depth, title = len(heading.group(1)), heading.group(2)
            if current is not None and depth > level:
                continue  # a sub-heading inside the entry ("#### Seed 004 in brief")
            key = entry_key(title)
            current = result.setdefault(key, {}) if key else None
            level, field = depth, ""
            continue
        if current is None:
            continue
        bullet = FIELD.match(line)
        if bullet:
            field = bullet.group(1).strip().lower()
            current[field] = bullet.group(2).strip()
        elif field and line.startswith("  ") and line.strip():
            current[field] = f"{current[field]} {line.strip()}"
        elif not line.strip() or line.startswith("-"):
            field = ""
    return result


def unresolved(text: str, known: set[str]) -> list[Citation]:
    """The citations in `text` with no entry in `known`."""
    return [c for c in citations(text) if c.key not in known]


REFERENCE_ENTRIES = entries(REFERENCES.read_text(encoding="utf-8"))
KNOWN = set(REFERENCE_ENTRIES)
PAPERS = sorted(k for k in KNOWN if k.startswith("seed "))
ERRATA_NUMBERS = sorted(int(k.split()[1]) for k in KNOWN if k.startswith("erratum "))

#: Where citations are checked. twin/, scripts/ and benchmarks/ are the code; examples/,
#: tests/ and docs/ cite the same way and must resolve too.
SCANNED = {
    "twin": "*.py",
    "scripts": "*.py",
    "benchmarks": "*.py",
    "examples": "*.py",
    "tests": "*.py",
    "docs": "*.md",
}


def scanned_files(root: str) -> list[Path]:
    skip = {REFERENCES, Path(__file__).resolve()}  # the definitions and this test's samples
    return sorted(p for p in (ROOT / root).rglob(SCANNED[root]) if p.resolve() not in skip)


def test_references_define_papers_and_consecutive_errata() -> None:
    """references.md has paper entries and errata numbered 1..N with no gap or repeat."""
    assert PAPERS, "no '### seed NNN' headings in docs/references.md"
    assert ERRATA_NUMBERS == list(range(1, len(ERRATA_NUMBERS) + 1)), ERRATA_NUMBERS
    assert "check values" in KNOWN


@pytest.mark.parametrize("paper", PAPERS)
def test_each_paper_has_a_title_and_a_year(paper: str) -> None:
    """A paper entry names its title and a four-digit year."""
    fields = REFERENCE_ENTRIES[paper]
    assert fields.get("title"), f"{paper}: no '- **Title:**' field"
    assert re.search(r"\b(?:19|20)\d{2}\b", fields.get("year", "")), f"{paper}: no year"


@pytest.mark.parametrize("number", ERRATA_NUMBERS)
def test_each_erratum_says_what_it_corrects_and_what_we_do(number: int) -> None:
    """An erratum entry has a 'Corrects' and a 'We do' field."""
    fields = REFERENCE_ENTRIES[f"erratum {number}"]
    assert fields.get("corrects"), f"Erratum {number}: no '- **Corrects:**' field"
    assert "we do" in fields, f"Erratum {number}: no '- **We do:**' field"


@pytest.mark.parametrize("root", sorted(SCANNED))
def test_every_citation_resolves(root: str) -> None:
    """Each 'seed NNN' and 'erratum N' cited under `root` has an entry in references.md."""
    files = scanned_files(root)
    if not files:
        pytest.skip(f"no {SCANNED[root]} files under {root}/")
    missing = [
        f"{path.relative_to(ROOT)}:{c.line}: {c.key}"
        for path in files
        for c in unresolved(path.read_text(encoding="utf-8"), KNOWN)
    ]
    assert not missing, "cited but not in docs/references.md:\n" + "\n".join(missing)


def test_every_paper_is_cited() -> None:
    """Each listed paper is cited somewhere (guards against a scanner that matches nothing)."""
    files = [p for root in SCANNED for p in scanned_files(root)]
    cited = {c.key for p in files for c in citations(p.read_text(encoding="utf-8"))}
    assert set(PAPERS) <= cited, set(PAPERS) - cited


@pytest.mark.parametrize(
    ("text", "cited", "missing"),
    [
        ("as seed 000 eq (34) prints", ["seed 000"], []),
        ("Seed 004's weights, seed 002 Table 2", ["seed 004", "seed 002"], []),
        ("seeds 000 and 004 give none", ["seed 000", "seed 004"], []),
        ("see seed 007 eq (3)", ["seed 007"], ["seed 007"]),
        ("seeds 001 and 003", ["seed 001", "seed 003"], ["seed 003"]),
        ("SPEC erratum 3", ["erratum 3"], []),
        ("(SPEC\n    erratum 11)", ["erratum 11"], []),
        ("SPEC erratum 99", ["erratum 99"], ["erratum 99"]),
        ("SPEC Erratum 0", ["erratum 0"], ["erratum 0"]),
        ("(SPEC erratum 9, a sign slip)", ["erratum 9"], []),
        ("SPEC errata 3, 4 and 13", ["erratum 3", "erratum 4", "erratum 13"], ["erratum 13"]),
        ("errata 11–13", ["erratum 11", "erratum 12", "erratum 13"], ["erratum 13"]),
        ("SPEC check value 44.90", ["check values"], []),
        ("sea seed 0; seeds 0-4; seed=0; seeds 0-255", [], []),
        ("SEED001_G = 9.8; presets['seed000']; seed 0001", [], []),
        ("SPEC.md lists the errata we follow", [], []),
    ],
)
def test_parser(text: str, cited: list[str], missing: list[str]) -> None:
    """The scanner on synthetic text: what it reads as a citation, and what fails to resolve."""
    assert [c.key for c in citations(text)] == cited
    assert [c.key for c in unresolved(text, KNOWN)] == missing


def test_parser_reports_the_line_of_a_citation() -> None:
    """Line numbers count from 1; a citation split over lines is reported at its number."""
    text = '"""Docstring.\n\nSee seed 007 and (SPEC\nerratum 99)."""\n'
    assert unresolved(text, KNOWN) == [Citation("seed 007", 3), Citation("erratum 99", 4)]
