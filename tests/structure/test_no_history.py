"""Code says why, not when: no issue numbers, ISO dates or commit hashes in code comments, doc
comments, docstrings and test names. The issue tracker and the commit log are not part of the
repository, so a reader cannot follow "issue N" or "since <hash>"; the comment states the reason
instead, and CHANGELOG.md keeps the history.

The check covers the paths in CLEAN, the ones already rid of such remarks; widen the list as
others become clean. A remark is looked for in comments (`//`, `#`, `/* */`), Python docstrings
and string literals of test names (`fn name`, `def test_name`), not in data such as a CSV or a
parameter file."""

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# Files and folders checked (relative to the repository root).
CLEAN = [
    "fmu-src",
    "harness",
    "packaging",
    "tests",
    ".ci",
]

SUFFIXES = {".rs", ".py", ".sh", ".toml", ".ssv", ""}

ISSUE = re.compile(r"\bissues?\s*#?\d+", re.I)
DATE = re.compile(r"\b(?:19|20)\d\d-(?:0[1-9]|1[0-2])-(?:0[1-9]|[12]\d|3[01])\b")
# A short or full commit hash: 7-40 hex digits with at least one letter and one digit.
HASH = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b")
HISTORY = [("an issue number", ISSUE), ("an ISO date", DATE), ("a commit hash", HASH)]

LINE_COMMENT = {".rs": "//", ".py": "#", ".sh": "#", ".toml": "#", "": "#"}


def files():
    for entry in CLEAN:
        path = ROOT / entry
        assert path.exists(), f"{entry} is listed in CLEAN but does not exist"
        candidates = sorted(path.rglob("*")) if path.is_dir() else [path]
        for file in candidates:
            if file.is_file() and file.suffix in SUFFIXES and "__pycache__" not in file.parts \
                    and is_text(file):
                yield file


def is_text(path):
    """A binary file without a suffix (such as a fuzz corpus entry) is data, not code."""
    try:
        path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        return False
    return True


def prose(path, text):
    """The comments, docstrings and test names of a file, with their line numbers."""
    if path.suffix == ".ssv":
        yield from ((match.group(1), text[:match.start()].count("\n") + 1)
                    for match in re.finditer(r"<!--(.*?)-->", text, re.S))
        return
    marker = LINE_COMMENT[path.suffix]
    for number, line in enumerate(text.splitlines(), 1):
        position = line.find(marker)
        if position >= 0:
            yield line[position:], number
        test_name = re.match(r"\s*(?:fn|def)\s+(\w+)", line)
        if test_name:
            yield test_name.group(1).replace("_", " "), number
    if path.suffix == ".py":
        for match in re.finditer(r'"""(.*?)"""', text, re.S):
            yield match.group(1), text[:match.start()].count("\n") + 1
    if path.suffix == ".rs":
        for match in re.finditer(r"/\*(.*?)\*/", text, re.S):
            yield match.group(1), text[:match.start()].count("\n") + 1


def remarks(path):
    text = path.read_text(encoding="utf-8")
    for piece, line in prose(path, text):
        for what, pattern in HISTORY:
            for match in pattern.finditer(piece):
                yield f"{path.relative_to(ROOT)}:{line}: {what}: {match.group(0)!r} in {piece.strip()[:100]!r}"


def test_the_clean_paths_have_no_history_in_comments_or_test_names():
    found = [remark for path in files() for remark in remarks(path)]
    assert not found, "history in code (write the reason instead):\n" + "\n".join(found)


# The samples are put together from parts, so this file stays clean itself.
@pytest.mark.parametrize("comment, what", [
    ("// see " + "issue" + " 12 point 4", "an issue number"),
    ("// measured on " + "2026" + "-12-04", "an ISO date"),
    ("// since " + "20cc" + "07b the data differ", "a commit hash"),
])
def test_each_kind_of_history_is_found(tmp_path, comment, what, monkeypatch):
    path = tmp_path / "sample.rs"
    path.write_text(f"fn main() {{}}\n{comment}\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    assert [r for r in remarks(path) if what in r], comment


def test_hex_numbers_and_words_are_not_commit_hashes(tmp_path, monkeypatch):
    path = tmp_path / "sample.rs"
    path.write_text("// a decade of 0xdeadbeef values, 1234567 samples, the deadbeef word\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    assert not list(remarks(path))
