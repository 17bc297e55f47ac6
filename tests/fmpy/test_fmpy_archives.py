"""The packaged archives: fmpy's validation, the FMI 2.0 archive layout, the generated
documentation, and the interface names issue 4 fixes."""

import zipfile

import pytest
from fmpy.ssp.ssd import read_ssd
from fmpy.validation import validate_fmu

import fmu_support as support


@pytest.fixture(params=[support.VEHICLE, support.ESTIMATOR])
def fmu(request):
    return request.getfixturevalue({support.VEHICLE: "vehicle_fmu", support.ESTIMATOR: "estimator_fmu"}[request.param])


def test_fmpy_validation_reports_no_problem(fmu):
    problems = validate_fmu(str(fmu))
    assert problems == [], f"{fmu.name}: " + "\n".join(problems)


def test_archive_layout(fmu):
    identifier = fmu.stem
    with zipfile.ZipFile(fmu) as archive:
        names = archive.namelist()
        assert archive.testzip() is None
        for required in ["modelDescription.xml",
                         f"binaries/linux64/{identifier}.so",
                         "documentation/index.html",
                         "documentation/licenses/LICENSE.txt",
                         "documentation/licenses/LICENSE-MIT.txt",
                         "documentation/licenses/LICENSE-APACHE.txt",
                         "documentation/licenses/THIRD-PARTY.txt"]:
            assert required in names, f"{fmu.name} lacks {required}: {names}"
        assert all("\\" not in name and not name.startswith("/") for name in names)
        library = archive.read(f"binaries/linux64/{identifier}.so")
        assert library[:4] == b"\x7fELF"
        assert (archive.getinfo(f"binaries/linux64/{identifier}.so").external_attr >> 16) & 0o111


def test_documentation_explains_every_variable(fmu):
    interface = support.Interface(fmu)
    with zipfile.ZipFile(fmu) as archive:
        html = archive.read("documentation/index.html").decode("utf-8")
    assert interface.description.guid in html
    for variable in interface.description.modelVariables:
        assert f"<code>{variable.name}</code>" in html, f"{variable.name} is not documented"
        if variable.type == "Real" and variable.unit:
            assert variable.unit.replace("&", "&amp;") in html
    # Prose about the models and filters precedes the tables.
    assert "What it does" in html
    if fmu.stem == support.ESTIMATOR:
        for word in ["Kalman", "unscented", "particle", "Luenberger", "sample_time"]:
            assert word in html, f"estimator documentation never mentions {word}"
    else:
        for word in ["HSRI", "Magic Formula", "quantisation", "latency", "seed"]:
            assert word in html, f"vehicle documentation never mentions {word}"


def test_interface_has_the_names_of_issue_4(vehicle, estimator):
    for name in support.DRIVER_INPUTS:
        assert vehicle[name].causality == "input" and vehicle[name].type == "Real"
        assert estimator[name].causality == "input" and estimator[name].type == "Real"
    for name in support.TRUTH_OUTPUTS + support.SENSOR_SIGNALS:
        assert vehicle[name].causality == "output", name
    for name in support.SENSOR_SIGNALS:
        assert estimator[name].causality == "input", name
        assert estimator[name].unit == vehicle[name].unit, name
    for name in support.ESTIMATE_OUTPUTS:
        assert estimator[name].causality == "output", name
    for name in ["model", "seed", "noise", "vx0"]:
        assert vehicle[name].causality == "parameter", name
    assert vehicle["noise"].type == "Boolean" and vehicle.start("noise") is True
    assert {item.name: int(item.value) for item in estimator["estimator"].declaredType.items} == \
        support.ESTIMATOR_KINDS
    for interface in (vehicle, estimator):
        co_simulation = interface.description.coSimulation
        assert co_simulation.canHandleVariableCommunicationStepSize
        assert not co_simulation.canBeInstantiatedOnlyOncePerProcess
        for variable in interface.description.modelVariables:
            if variable.type == "Real":
                assert variable.unit or (variable.declaredType and variable.declaredType.unit), \
                    f"{interface.description.modelName}.{variable.name} has no unit"


def test_ssp_structure(ssp_file, vehicle, estimator):
    with zipfile.ZipFile(ssp_file) as archive:
        names = archive.namelist()
    # Beside the FMUs, the car parameter-value files (issue 13 point 6) that a user binds.
    cars = ["bmw_320i", "ford_escort", "seed_car", "vw_vanagon"]
    assert sorted(names) == sorted(["SystemStructure.ssd",
                                    f"resources/{support.VEHICLE}.fmu",
                                    f"resources/{support.ESTIMATOR}.fmu"]
                                   + [f"resources/{car}.ssv" for car in cars])
    # read_ssd validates against the SSP 1.0 XML schema shipped with fmpy.
    ssd = read_ssd(str(ssp_file))
    assert ssd.version == "1.0"
    system = ssd.system
    assert [c.name for c in system.connectors] == support.DRIVER_INPUTS
    components = {element.name: element for element in system.elements}
    assert components[support.VEHICLE].source == f"resources/{support.VEHICLE}.fmu"
    assert components[support.ESTIMATOR].source == f"resources/{support.ESTIMATOR}.fmu"
    connections = {(c.startElement, c.startConnector, c.endElement, c.endConnector)
                   for c in system.connections}
    expected = set()
    for name in support.DRIVER_INPUTS:
        expected.add((None, name, support.VEHICLE, name))
        expected.add((None, name, support.ESTIMATOR, name))
    # Connections by name: every vehicle output that is an estimator input.
    for name in set(vehicle.names("output")) & set(estimator.names("input")):
        expected.add((support.VEHICLE, name, support.ESTIMATOR, name))
    assert connections == expected
    assert all(name in {c[3] for c in connections} for name in support.SENSOR_SIGNALS)
