"""docs/reference/command-line.md: the `harness` command line, from the binary's own --help.

    .venv/bin/python docs/tools/command_line.py [HARNESS] [--write]

HARNESS defaults to target/release/harness. Without --write the page is printed;
tests/docs/test_command_line.py fails when the committed page differs from the binary's help."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "reference" / "command-line.md"


def help_text(harness: Path, *command: str) -> str:
    # clap wraps the help at the terminal's width, else at $COLUMNS: a fixed width makes the
    # page the same from a terminal, a script and the tests.
    environment = {**os.environ, "COLUMNS": "100"}
    completed = subprocess.run([str(harness), *command, "--help"], capture_output=True, text=True,
                               check=True, timeout=60, env=environment)
    return completed.stdout.rstrip() + "\n"


def commands(top_help: str) -> list[str]:
    """The subcommands listed under "Commands:" (each line starts with two spaces and a name)."""
    section = top_help.split("Commands:", 1)[1].split("\n\n", 1)[0]
    return [m.group(1) for m in re.finditer(r"(?m)^  ([a-z][a-z0-9-]*)\s", section) if m.group(1) != "help"]


def page(harness: Path) -> str:
    top = help_text(harness)
    parts = ["# Command line: `harness`\n",
             "<!-- Generated from the binary's --help by docs/tools/command_line.py; do not edit. -->\n",
             "`cargo run --release -p harness -- <COMMAND>`, or `target/release/harness <COMMAND>`"
             " after a release build. The studies' scenario, map and campaign files are described"
             " in [file formats](files.md).\n",
             "```text\n" + top + "```\n"]
    for command in commands(top):
        parts.append(f"## `harness {command}`\n")
        parts.append("```text\n" + help_text(harness, command) + "```\n")
    return "\n".join(parts)


def main(argv: list[str]) -> int:
    arguments = [a for a in argv if a != "--write"]
    harness = Path(arguments[0]) if arguments else ROOT / "target" / "release" / "harness"
    text = page(harness)
    if "--write" in argv:
        PAGE.write_text(text, encoding="utf-8")
    else:
        print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
