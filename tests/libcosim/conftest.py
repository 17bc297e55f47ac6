"""Fixtures of the libcosim tests: the fmpy tests' (tests/fmpy/fixture_export.py)."""

import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "fmpy"))

from fixture_export import export_fmpy_fixtures  # noqa: E402 (after the path it is found on)

export_fmpy_fixtures(globals())
