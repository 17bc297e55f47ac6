"""Every citation key the repository uses must resolve to an anchor of the in-repo theory docs.

The code cites the equations and experiments it implements as ``(000: 5.42)`` (seed 000,
equation 5.42), ``(001: eqs 6-11)``, ``(003: §3.2)``, ``(000: table 5.1)``, ``(000: ch. 7)`` and
``SPEC §7``. Their targets are written out, in the project's own words, in
``docs/explanation/models.md``, ``docs/explanation/estimators.md`` and the FMU documentation
under ``packaging/doc/``. Each target carries an HTML anchor whose id encodes the key:

===============================  ==============================================
key in the code                  anchor id in the docs
===============================  ==============================================
``(000: 5.42)`` (bare number)    ``000-eq-5.42`` or ``000-sec-5.42``
``(001: eq 9)``                  ``001-eq-9``
``(003: §3.2)``, ``(000: ch. 7)``  ``003-sec-3.2``, ``000-sec-7``
``(000: table 5.1)``             ``000-table-5.1``
``(000: fig. 7.18)``             ``000-fig-7.18``
``(001: ref. 7)``                ``001-ref-7``
``SPEC §7``                      ``spec-7``
any key of seed 00N              ``seed-00N`` (the source itself)
===============================  ==============================================

A range (``5.66-5.73``, ``A.25-A.32``, ``eqs 6-11``) needs both ends, ``7.4/7.5`` both numbers.
Words around the number (``text before table 5.2``, ``table after 5.73``, ``ch. 7 intro``,
``4.64-4.75 order: ...``) are read past; an item that starts with no number (``18 m/s``,
``about 3.7``, a quoted phrase) quotes the source and names no target. The same keys in running
text (``seed 000, ch. 7.2``, ``Seed 003 §3.2``, ``SPEC section 7``) are checked too. Standard
library only.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
THIS_FILE = Path(__file__).resolve()

SCANNED_SUFFIXES = {".rs", ".py", ".xml", ".toml", ".md", ".html"}
SKIPPED_DIRECTORIES = {"target", ".venv", "out", ".git", "__pycache__", "node_modules"}

# The documents whose anchors are citation targets.
THEORY_DOCS = [
    ROOT / "docs" / "explanation" / "models.md",
    ROOT / "docs" / "explanation" / "estimators.md",
]
THEORY_DOC_FOLDER = ROOT / "packaging" / "doc"

# Citations in code that point at the wrong place of the seed. They are listed here (with the
# correct target) until the comment is corrected; an anchor for a place the seed does not have
# would make the docs wrong instead.
KNOWN_MISCITATIONS = {
    # Seed 000 has no §7.4/§7.5 (figures 7.4/7.5 belong to the moderate ramp); the step steer
    # is §7.3, fig. 7.18.
    "(000: 7.4/7.5, fig. 7.18)": "(000: 7.3, fig. 7.18)",
}

CITATION_START = re.compile(r"\((00[0-4]):")
SEED_PREFIX = re.compile(r"\b(00[0-4]):\s*")
SPEC_KEY = re.compile(r"SPEC (?:§|section )\s*(\d+(?:\.\d+)*)")
QUOTED = re.compile(r'"[^"]*"|“[^”]*”|„[^“”]*[“”]|`[^`]*`')
# The same keys in running text: "seed 000, ch. 7.2", "Seed 003 §3.2", "000 table 5.1".
PROSE_KEY = re.compile(
    r"\b(?:[Ss]eed\s+)?(00[0-4]),?\s+((?:§|ch\.|eqs?|table|fig\.)\s*"
    r"(?:A\.)?\d+(?:\.\d+)*(?:\s*[-–/]\s*(?:A\.)?\d+(?:\.\d+)*)?)"
)
ANCHOR = re.compile(r"""\bid\s*=\s*["']([^"']+)["']""")

NUMBER = r"(?:A\.)?\d+(?:\.\d+)*"
ITEM = re.compile(
    r"""^(?:(?:text|before|after|see)\s+)*
        (?:(?P<kind>eqs?\.?|equations?|§|ch\.?|chapter|sec\.?|section|tables?|figs?\.?|figures?|refs?\.?)\s*)?
        (?P<qualifier>(?:after|before)\s+)?
        (?P<first>"""
    + NUMBER
    + r""")
        (?:\s*(?P<joint>[-–/])\s*(?P<second>"""
    + NUMBER
    + r"""))?
        (?P<rest>.*)$""",
    re.VERBOSE | re.IGNORECASE,
)

# Kind of target per word, singular and without the abbreviation's dot ("eqs." -> "eq").
KIND_OF_WORD = {
    "eq": "eq", "equation": "eq", "§": "sec", "ch": "sec", "chapter": "sec", "sec": "sec",
    "section": "sec", "table": "table", "fig": "fig", "figure": "fig", "ref": "ref",
}


def kind_of(word: str | None) -> str | None:
    return KIND_OF_WORD.get(word.lower().rstrip(".").removesuffix("s")) if word else None


# Kinds whose lists continue without repeating the word; a bare dotted number after "§3.1, "
# or "eq 2.1, " is left open (equation or section), as the seeds cite both that way.
LISTED_KINDS = {"fig", "table", "ref"}


@dataclass(frozen=True)
class Target:
    """One place a citation points at: seed, kind (eq/sec/table/fig/ref, or None for a bare
    dotted number, which may be an equation or a section) and number."""

    seed: str
    kind: str | None
    number: str

    def anchor_ids(self) -> list[str]:
        if self.kind is None:
            return [f"{self.seed}-eq-{self.number}", f"{self.seed}-sec-{self.number}"]
        return [f"{self.seed}-{self.kind}-{self.number}"]

    def __str__(self) -> str:
        kind = "eq or §" if self.kind is None else self.kind
        return f"{self.seed} {kind} {self.number}"


def citation_text(line: str, start: int) -> str:
    """The citation from its "(" to the matching ")" (or the end of the line), quotes removed."""
    tail = QUOTED.sub("", line[start + 1:])
    depth = 1
    for position, character in enumerate(tail):
        if character == "(":
            depth += 1
        elif character == ")":
            depth -= 1
            if depth == 0:
                return tail[:position]
    return tail


def parse_items(seed: str, body: str) -> list[Target]:
    """The targets of one seed's part of a citation, e.g. body "eqs 2, 11" of seed 001."""
    targets = []
    inherited_kind = None
    for item in re.split(r"[,;]", body):
        match = ITEM.match(item.strip())
        if not match:
            continue  # a quotation or a value ("18 m/s", "about 3.7"): no target
        word_kind = kind_of(match["kind"])
        numbers = [match["first"]] + ([match["second"]] if match["second"] else [])
        if word_kind and match["qualifier"]:
            kind = None  # "table after 5.73": the table that follows equation 5.73
        elif word_kind:
            kind = inherited_kind = word_kind
        elif "." not in match["first"]:
            if match["rest"].strip():
                continue  # "60 rad/s": a value, not a reference
            kind = inherited_kind or "sec"  # "eqs 2, 11"; "(002: 4)" is section 4
        elif inherited_kind in LISTED_KINDS:
            kind = inherited_kind  # "fig. 7.1, 7.18"
        else:
            kind = None
        targets.extend(Target(seed, kind, number) for number in numbers)
    return targets


def parse_citation(text: str, seed: str) -> list[Target]:
    """All targets of a citation body such as "5.40 with 001: eq 1"."""
    parts = SEED_PREFIX.split(text)
    targets = parse_items(seed, parts[0])
    for inner_seed, body in zip(parts[1::2], parts[2::2]):
        targets.extend(parse_items(inner_seed, body))
    return targets


@dataclass(frozen=True)
class Citation:
    path: Path
    line_number: int
    raw: str
    targets: tuple[Target, ...]
    anchor_ids: tuple[tuple[str, ...], ...]


def seed_citation(path: Path, line_number: int, raw: str, seed: str, targets: list[Target]):
    anchors = [(f"seed-{seed}",)] + [tuple(t.anchor_ids()) for t in targets]
    return Citation(path, line_number, raw, tuple(targets), tuple(anchors))


def citations_in_line(path: Path, line_number: int, line: str) -> list[Citation]:
    found = []
    for match in CITATION_START.finditer(line):
        seed = match[1]
        body = citation_text(line, match.start())
        targets = parse_citation(body[len(seed) + 1:], seed)
        found.append(seed_citation(path, line_number, "(" + body + ")", seed, targets))
    for match in PROSE_KEY.finditer(line):
        targets = parse_items(match[1], match[2])
        found.append(seed_citation(path, line_number, match[0], match[1], targets))
    for match in SPEC_KEY.finditer(line):
        found.append(Citation(path, line_number, match[0], (), ((f"spec-{match[1]}",),)))
    return found


def scanned_files() -> list[Path]:
    files = []
    for directory, subdirectories, names in os.walk(ROOT):
        subdirectories[:] = [d for d in subdirectories if d not in SKIPPED_DIRECTORIES]
        for name in names:
            path = Path(directory) / name
            if path.suffix in SCANNED_SUFFIXES and path.resolve() != THIS_FILE:
                files.append(path)
    return sorted(files)


def all_citations() -> list[Citation]:
    citations = []
    for path in scanned_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for line_number, line in enumerate(text.splitlines(), start=1):
            citations.extend(citations_in_line(path, line_number, line))
    return citations


def theory_docs() -> list[Path]:
    docs = [path for path in THEORY_DOCS if path.is_file()]
    docs += sorted(p for p in THEORY_DOC_FOLDER.rglob("*") if p.suffix in {".html", ".md"})
    return docs


def doc_anchors() -> set[str]:
    anchors = set()
    for path in theory_docs():
        anchors.update(ANCHOR.findall(path.read_text(encoding="utf-8")))
    return anchors


def unresolved(citations: list[Citation], anchors: set[str]) -> list[str]:
    """One line "file:line: citation -> missing target" per target that has no anchor."""
    problems = []
    for citation in citations:
        if citation.raw in KNOWN_MISCITATIONS:
            continue
        names = ["the source itself"] + [str(t) for t in citation.targets]
        if not citation.targets and citation.raw.startswith("SPEC"):
            names = [citation.raw]
        for name, alternatives in zip(names, citation.anchor_ids):
            if not any(anchor in anchors for anchor in alternatives):
                where = citation.path.relative_to(ROOT)
                problems.append(
                    f"{where}:{citation.line_number}: {citation.raw} -> {name} "
                    f"(no anchor {' / '.join(alternatives)})"
                )
    return problems


def test_the_theory_docs_exist():
    for path in THEORY_DOCS:
        assert path.is_file(), f"{path.relative_to(ROOT)} is missing"


def test_the_repository_cites_something():
    # Guards against a scan that silently finds nothing (wrong root, wrong patterns).
    citations = all_citations()
    assert len(citations) > 300, f"only {len(citations)} citations found under {ROOT}"
    assert any(c.raw.startswith("SPEC") for c in citations)


def test_every_citation_resolves_to_an_anchor_of_the_docs():
    problems = unresolved(all_citations(), doc_anchors())
    assert not problems, (
        f"{len(problems)} citation targets are not written out in the docs "
        f"({', '.join(str(p.relative_to(ROOT)) for p in theory_docs())}):\n"
        + "\n".join(problems)
    )


def test_known_miscitations_are_still_present():
    # Once a listed comment is corrected its entry must go, or the list hides a future error.
    raws = {citation.raw for citation in all_citations()}
    stale = [raw for raw in KNOWN_MISCITATIONS if raw not in raws]
    assert not stale, f"corrected citations still listed in KNOWN_MISCITATIONS: {stale}"


@pytest.mark.parametrize(
    "line, expected",
    [
        ("x (000: 5.42) y", [("000", None, "5.42")]),
        ("(000: 5.66-5.73)", [("000", None, "5.66"), ("000", None, "5.73")]),
        ("(001: eqs 6-11)", [("001", "eq", "6"), ("001", "eq", "11")]),
        ("(001: eqs 2, 11)", [("001", "eq", "2"), ("001", "eq", "11")]),
        ("(003: §3.2)", [("003", "sec", "3.2")]),
        ("(000: table 5.1)", [("000", "table", "5.1")]),
        ("(000: ch. 7 intro)", [("000", "sec", "7")]),
        ("(002: §4)", [("002", "sec", "4")]),
        ("(002: 4)", [("002", "sec", "4")]),
        ("(000: 4.64-4.75 order: predict with `u(k)`, then update)",
         [("000", None, "4.64"), ("000", None, "4.75")]),
        ("(000: table after 5.73, sR ≤ 0.5)", [("000", None, "5.73")]),
        ("(000: table 5.2, table after 5.73)", [("000", "table", "5.2"), ("000", None, "5.73")]),
        ("(000: text before table 5.2)", [("000", "table", "5.2")]),
        ("(000: 5.40 with 001: eq 1)", [("000", None, "5.40"), ("001", "eq", "1")]),
        ("(000: 4.99 ff., 003: 2.22-2.23)",
         [("000", None, "4.99"), ("003", None, "2.22"), ("003", None, "2.23")]),
        ("(003: A.25-A.32)", [("003", None, "A.25"), ("003", None, "A.32")]),
        ("(000: 7.4/7.5, fig. 7.18)",
         [("000", None, "7.4"), ("000", None, "7.5"), ("000", "fig", "7.18")]),
        ("(000: 7.2, \"ca. 0.122 rad, bzw. 7 Grad\")", [("000", None, "7.2")]),
        ("(000: 18 m/s, straight driving)", []),
        ("(000: about 3.7)", []),
        ("(001: ref. 7)", [("001", "ref", "7")]),
        ("(000: fig. 7.1, 7.18)", [("000", "fig", "7.1"), ("000", "fig", "7.18")]),
        ("as in seed 000, ch. 7.2.1 and", [("000", "sec", "7.2.1")]),
        ("Seed 003 §3.2 in simulation", [("003", "sec", "3.2")]),
        ("(seed 000, eqs 5.16-5.22)", [("000", "eq", "5.16"), ("000", "eq", "5.22")]),
        ("(003: §2.2, 2.76-2.78)",
         [("003", "sec", "2.2"), ("003", None, "2.76"), ("003", None, "2.78")]),
    ],
)
def test_citation_keys_are_parsed(line, expected):
    (citation,) = [c for c in citations_in_line(Path("x"), 1, line) if not c.raw.startswith("SPEC")]
    assert [(t.seed, t.kind, t.number) for t in citation.targets] == expected


def test_a_missing_anchor_is_reported_with_file_and_line():
    anchors = doc_anchors()
    citations = all_citations()
    cited = next(c for c in citations if c.targets and c.raw not in KNOWN_MISCITATIONS)
    removed = next(a for a in cited.anchor_ids[1] if a in anchors)
    problems = unresolved([cited], anchors - {removed, *cited.anchor_ids[1]})
    where = f"{cited.path.relative_to(ROOT)}:{cited.line_number}:"
    assert problems and all(p.startswith(where) for p in problems), problems


def test_a_missing_spec_section_is_reported():
    (citation,) = citations_in_line(ROOT / "README.md", 3, "see SPEC §9")
    assert unresolved([citation], doc_anchors()) == [
        "README.md:3: SPEC §9 -> SPEC §9 (no anchor spec-9)"
    ]
