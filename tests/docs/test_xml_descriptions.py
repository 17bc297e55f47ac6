"""Every `description` attribute of both model descriptions (the FMU, its variables, types and
enumeration items) is what importers show as a tooltip: at most two sentences and 60 words, no
history. The longer story of each default lives in docs/explanation/."""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

from prose_rules import history_in, sentences, words

ROOT = Path(__file__).resolve().parents[2]
MODEL_DESCRIPTIONS = sorted((ROOT / "modelDescription").glob("*.xml"))
MAX_WORDS = 60
MAX_SENTENCES = 2


def descriptions(path: Path):
    for element in ElementTree.parse(path).iter():
        text = element.get("description")
        if text is not None:
            yield f"{path.name}: <{element.tag} name={element.get('name')!r}>", text


def test_both_model_descriptions_are_checked():
    assert {p.name for p in MODEL_DESCRIPTIONS} >= {"VehicleStateEstimator.xml", "ReferenceVehicle.xml"}
    assert sum(1 for p in MODEL_DESCRIPTIONS for _ in descriptions(p)) > 300


@pytest.mark.parametrize("path", MODEL_DESCRIPTIONS, ids=lambda p: p.name)
def test_descriptions_are_short(path):
    long = [f"{where}: {words(text)} words, {sentences(text)} sentences"
            for where, text in descriptions(path)
            if words(text) > MAX_WORDS or sentences(text) > MAX_SENTENCES]
    assert not long, f"descriptions over {MAX_SENTENCES} sentences or {MAX_WORDS} words:\n" + "\n".join(long)


@pytest.mark.parametrize("path", MODEL_DESCRIPTIONS, ids=lambda p: p.name)
def test_descriptions_tell_no_history(path):
    found = [f"{where}: {item}" for where, text in descriptions(path) for item in history_in(text)]
    assert not found, "history belongs in CHANGELOG.md:\n" + "\n".join(found)


@pytest.mark.parametrize("text, expected", [
    ("One. Two.", 2),
    ("Factor (Pacejka 2012, sect. 4.3.2). 1 is the seed's tyre.", 2),
    ("e.g. 0.01 s for ay. Second", 2),
    ("No full stop", 1),
    ("One. Two. Three.", 3),
])
def test_sentences_are_counted(text, expected):
    assert sentences(text) == expected


@pytest.mark.parametrize("text", ["default since 2026-12-05", "see issue 17", "commit 8007db0",
                                  "the value used to be 1", "before the last wave"])
def test_history_is_found(text):
    assert history_in(text)


@pytest.mark.parametrize("text", ["set before initialisation", "a 1000 rad/s limit",
                                  "value 0.001 since it is", "deadbeef"])
def test_present_tense_prose_passes(text):
    assert not history_in(text)
