"""The rules the repository's prose follows (README, docs/, XML descriptions): it states the
present. History (dates, commit hashes, issue numbers, "since ..."/"before ..." of a change) lives
in CHANGELOG.md and the commit log, where a reader can follow it; a description says what a thing
is and why, in at most two sentences and 60 words. Standard library only."""

from __future__ import annotations

import re

# A calendar date, an issue or pull-request number, a commit hash (7-40 hex digits with at least
# one digit and one letter), or a change told by its moment ("since 2026", "before the grip's ...
# was added", "until then", "previously", "no longer", "used to").
HISTORY = [
    (re.compile(r"\b(?:19|20)\d\d-\d\d-\d\d\b"), "a date"),
    (re.compile(r"\b(?:issues?|PR|pull request)\s*#?\d+", re.IGNORECASE), "an issue number"),
    (re.compile(r"(?<![\w(-])#\d{2,}\b(?!-)"), "an issue number"),
    (re.compile(r"(?<![.\w])(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b(?![-+.]\d)"), "a commit hash"),
    (re.compile(r"\b(?:since|before|until|after)\s+(?:(?:19|20)\d\d|the (?:last|previous) "
                r"(?:wave|change|commit|release)|commit|issue)", re.IGNORECASE), "a moment of change"),
    (re.compile(r"\b(?:previously|formerly|no longer|used to be|was changed|became the default)\b",
                re.IGNORECASE), "a change told as history"),
]

SENTENCE_END = re.compile(r"[.!?](?=\s+\S|\s*$)")
# Abbreviations whose dot ends no sentence.
ABBREVIATION = re.compile(r"\b(?:e\.g|i\.e|cf|sect|Sect|ed|eq|eqs|fig|ch|ref|vs|approx|Trans|Proc|"
                          r"J|No|Vol|al)\.$")


def history_in(text: str) -> list[str]:
    """What in `text` tells history, as "a date: '<the date found>'" items."""
    found = []
    for pattern, what in HISTORY:
        found += [f"{what}: {match.group(0)!r}" for match in pattern.finditer(text)]
    return found


def sentences(text: str) -> int:
    """Sentences in a description: ends of sentence that are not an abbreviation's dot."""
    count = 0
    for match in SENTENCE_END.finditer(text.strip()):
        if not ABBREVIATION.search(text[: match.end()]):
            count += 1
    if text.strip() and not SENTENCE_END.search(text.strip()[-1:] + " "):
        count += 1  # the last sentence may end without a full stop
    return count


def words(text: str) -> int:
    return len(text.split())
