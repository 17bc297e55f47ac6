"""The fmpy tests' fixtures (tests/fmpy/conftest.py) for the other importers' test folders
(tests/libcosim, tests/fmipp): the packaged archives are found, and required, exactly as the fmpy
tests do it, so a missing archive fails with the command that builds it."""

import importlib.util
import pathlib

FIXTURES = ("vehicle_fmu", "estimator_fmu", "ssp_file", "vehicle", "estimator", "vehicle_dir",
            "estimator_dir")


def export_fmpy_fixtures(namespace):
    """Puts the fmpy tests' fixtures into `namespace` (a conftest module's globals())."""
    path = pathlib.Path(__file__).with_name("conftest.py")
    spec = importlib.util.spec_from_file_location("fmpy_test_fixtures", path)
    fixtures = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fixtures)
    for name in FIXTURES:
        namespace[name] = getattr(fixtures, name)
