"""The README fits a screen and a half, its accuracy table is the one the studies' data files
generate, and the README and docs/ state the present (history lives in CHANGELOG.md) and link
only to files that exist."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

from prose_rules import history_in

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
MAX_README_LINES = 150
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def accuracy_table_module():
    spec = importlib.util.spec_from_file_location("accuracy_table", ROOT / "docs" / "tools" / "accuracy_table.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def prose_files() -> list[Path]:
    """README.md, the docs and every README below fmu-src/, harness/, packaging/, examples/."""
    files = [README, *sorted((ROOT / "docs").rglob("*.md"))]
    for folder in ("fmu-src", "harness", "packaging", "examples"):
        files += sorted(p for p in (ROOT / folder).rglob("README.md") if "target" not in p.parts)
    return files


def test_the_readme_fits_150_lines():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md has {len(lines)} lines, at most {MAX_README_LINES}"


def test_the_readme_names_the_two_commands():
    text = README.read_text(encoding="utf-8")
    assert "bash harness/demo.sh" in text and "bash tests/run.sh" in text


def test_the_accuracy_table_is_generated_from_docs_data():
    module = accuracy_table_module()
    text = README.read_text(encoding="utf-8")
    assert module.readme_block(text) == module.block(), (
        "README.md's accuracy table differs from docs/data/*.csv: refresh it with "
        "`.venv/bin/python docs/tools/accuracy_table.py --write`")


# Generated from the binary's --help (docs/tools/command_line.py): its texts are the code's.
GENERATED_FROM_CODE = {ROOT / "docs" / "reference" / "command-line.md"}


@pytest.mark.parametrize("path", [p for p in prose_files() if p not in GENERATED_FROM_CODE],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_prose_tells_no_history(path):
    text = path.read_text(encoding="utf-8")
    found = [f"{path.relative_to(ROOT)}:{number}: {item}"
             for number, line in enumerate(text.splitlines(), start=1) for item in history_in(line)]
    assert not found, "history belongs in CHANGELOG.md:\n" + "\n".join(found)


@pytest.mark.parametrize("path", prose_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(path):
    text = path.read_text(encoding="utf-8")
    broken = [target for target in LINK.findall(text)
              if "://" not in target and not (path.parent / target).exists()]
    assert not broken, f"{path.relative_to(ROOT)} links to missing files: {broken}"


MAX_FOLDER_README_LINES = 60


@pytest.mark.parametrize("path", [p for p in prose_files() if p.name == "README.md" and p != README
                                  and "docs" not in p.relative_to(ROOT).parts],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_folder_readmes_stay_short(path):
    """A crate or folder README says what the folder is and where things are; the explanation,
    the measurements and the how-to live in docs/, where a reader looks for them."""
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_FOLDER_README_LINES, (
        f"{path.relative_to(ROOT)} has {len(lines)} lines, at most {MAX_FOLDER_README_LINES}: "
        "move the long story into docs/")
