"""Caveats attached to a claim (compare.caveats): which claims get which, and that the CLI's messages, the JSON
(schema-valid) and the HTML report carry them. Source for the local-fault caveat's figures:
experiments/pit_shape_check.py (a pit's size is read through the effect's own shape)."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from compare.caveats import LOCAL_FAULT_EFFECTS, claim_caveats


def _claimed(effect):
    return SimpleNamespace(claimed=[SimpleNamespace(effect=effect)])


@pytest.mark.parametrize("effect", LOCAL_FAULT_EFFECTS)
def test_a_claimed_local_fault_says_its_size_is_its_shapes(effect):
    (c,) = claim_caveats(_claimed(effect))
    assert c.startswith(f"{effect}'s size is that of its own shape") and "statistical" in c
    assert ("[pits]" in c) == (effect == "tooth_pit")     # a pit map describes a pit, not a broken tooth


@pytest.mark.parametrize("effect", ["tip_relief", "profile_error", "hertz_nonlinear"])
def test_an_effect_on_the_mesh_harmonics_only_keeps_its_caveat(effect):
    (c,) = claim_caveats(_claimed(effect))
    assert c.startswith(f"{effect} acts alike on every tooth")


@pytest.mark.parametrize("effect", ["pitch_error", "eccentricity_pinion", "transmission_path", "backlash"])
def test_other_claims_get_none(effect):
    assert claim_caveats(_claimed(effect)) == []


def test_no_claim_gets_none():
    assert claim_caveats(SimpleNamespace(claimed=[])) == [] and claim_caveats(None) == []


def test_a_claimed_pit_carries_the_caveat_into_the_json_and_the_report(tmp_path):
    """The suite's rig with a hidden pit, attributed over tooth_pit alone (as written): the document has
    ``claim_caveats`` and validates against the schema; the HTML shows it; a document without a claim has none."""
    import json

    import jsonschema

    from compare.escalation import compare_and_attribute
    from compare.model import ComparisonModel
    from compare.report import document, write_html
    from compare.schema import SCHEMA
    from compare.synthetic import hidden_effect_measurement

    m, ex = hidden_effect_measurement("tooth_pit", duration_s=1.0)
    s = compare_and_attribute(m, ComparisonModel(), candidates=["tooth_pit"], calibrate=False)
    assert [c.effect for c in s.attribution.claimed] == ["tooth_pit"]
    doc = document(s.comparison, s.attribution)
    jsonschema.validate(doc, SCHEMA)
    (caveat,) = doc["claim_caveats"]
    assert caveat.startswith("tooth_pit's size is that of its own shape")
    html = write_html(s.comparison, doc, tmp_path / "r.html").read_text()
    assert "tooth_pit&#x27;s size is that of its own shape" in html      # escaped, as every text of the report
    bare = document(s.comparison, None)
    assert "claim_caveats" not in bare
    jsonschema.validate(json.loads(json.dumps(bare)), SCHEMA)
