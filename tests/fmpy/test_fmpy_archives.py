"""The packaged archives: fmpy's validation, the FMI 2.0 archive layout, the generated
documentation, and the interface names that the FMUs share."""

import datetime
import io
import subprocess
import zipfile

import pytest
from lxml import etree
from PIL import Image
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
                         "model.png",
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


def _root_attributes(xml):
    return dict(etree.fromstring(xml).attrib)


def test_metadata_copyright_licence_and_generation_time(fmu):
    """The archived description names holder and licence (as the shipped licence
    texts do) and when it was generated; apart from that one attribute it is the repository's."""
    with zipfile.ZipFile(fmu) as archive:
        archived = archive.read("modelDescription.xml")
        licence = archive.read("documentation/licenses/LICENSE-MIT.txt").decode("utf-8")
    attributes = _root_attributes(archived)
    assert attributes["license"] == "MIT OR Apache-2.0"
    assert attributes["copyright"].startswith("Copyright (c) ")
    assert attributes["copyright"] in licence
    stamp = attributes["generationDateAndTime"]
    generated = datetime.datetime.strptime(stamp, "%Y-%m-%dT%H:%M:%SZ")
    repository = (support.ROOT / "modelDescription" / f"{fmu.stem}.xml").read_bytes()
    assert "generationDateAndTime" not in _root_attributes(repository)
    assert archived.replace(f'\n  generationDateAndTime="{stamp}"'.encode(), b"", 1) == repository
    # packaging takes SOURCE_DATE_EPOCH or the last commit's time; the archive may predate the
    # newest commit but never the project nor the present.
    last_commit = int(subprocess.run(["git", "-C", str(support.ROOT), "log", "-1", "--format=%ct"],
                                     capture_output=True, text=True, check=True).stdout)
    assert datetime.datetime(2026, 1, 1) <= generated <= \
        datetime.datetime.fromtimestamp(last_commit, datetime.UTC).replace(tzinfo=None)


def test_model_icon_is_a_drawn_png_at_the_archive_root(fmu, vehicle_fmu, estimator_fmu):
    with zipfile.ZipFile(fmu) as archive:
        icon = Image.open(io.BytesIO(archive.read("model.png")))
        icon.load()
    assert icon.format == "PNG" and icon.size[0] == icon.size[1] >= 64
    # A drawing, not a blank: many colours, none of which covers almost everything.
    histogram = icon.convert("RGB").getcolors(maxcolors=1 << 16)
    assert len(histogram) > 20
    assert max(count for count, _ in histogram) < 0.9 * icon.size[0] * icon.size[1]
    with zipfile.ZipFile(vehicle_fmu) as a, zipfile.ZipFile(estimator_fmu) as b:
        assert a.read("model.png") != b.read("model.png"), "both FMUs show the same icon"


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


def test_both_fmus_share_the_interface_names(vehicle, estimator):
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
    # Beside the FMUs, the driver inputs both components bind, and the car parameter-value files
    # that a user binds.
    cars = ["bmw_320i", "ford_escort", "seed_car", "vw_vanagon"]
    assert sorted(names) == sorted(["SystemStructure.ssd",
                                    f"resources/{support.VEHICLE}.fmu",
                                    f"resources/{support.ESTIMATOR}.fmu",
                                    "resources/driver_inputs.ssv"]
                                   + [f"resources/{car}.ssv" for car in cars])
    # read_ssd validates against the SSP 1.0 XML schema shipped with fmpy.
    ssd = read_ssd(str(ssp_file))
    assert ssd.version == "1.0"
    system = ssd.system
    # libcosim and Ecos need a startElement on every connection: no system connectors.
    assert system.connectors == []
    components = {element.name: element for element in system.elements}
    assert components[support.VEHICLE].source == f"resources/{support.VEHICLE}.fmu"
    assert components[support.ESTIMATOR].source == f"resources/{support.ESTIMATOR}.fmu"
    for component in components.values():
        assert [b.source for b in component.parameterBindings] == ["resources/driver_inputs.ssv"]
        bound = {p.name for p in component.parameterBindings[0].parameterValues[0].parameters}
        assert bound == set(support.DRIVER_INPUTS)
    connections = {(c.startElement, c.startConnector, c.endElement, c.endConnector)
                   for c in system.connections}
    # Connections by name: every vehicle output that is an estimator input.
    expected = {(support.VEHICLE, name, support.ESTIMATOR, name)
                for name in set(vehicle.names("output")) & set(estimator.names("input"))}
    assert connections == expected
    assert all(name in {c[3] for c in connections} for name in support.SENSOR_SIGNALS)
