"""The note on a local fault's signature when nothing is claimed (compare.disagreements.local_fault_note).

Truth from outside gearpit's simulator: the independent simulator of ``tests/foreign_rig.py`` with and without a
pit on one pinion tooth, compared with gearpit's bare model (no effect). The leading candidate is given (the
attribution's ranking is tested elsewhere); what is tested is whether the note reads the synchronous averages
right: a pitted pinion's energy ratio stands far above the model's (Lebold et al. 2000: a local fault raises the
residual over the regular signal), a healthy one's does not."""
from types import SimpleNamespace

import pytest

from compare.calibration import calibrated_compare
from compare.candidates import CandidateResult
from compare.comparison import prepare_reference
from compare.disagreements import LOCAL_SIGNATURE_DB, local_fault_note
from compare.model import ComparisonModel


def _unclaimed_lead(gear: str, claimed: bool = False):
    c = CandidateResult(effect="tooth_pit", signature="", params={"gear": gear, "severity": 0.2}, sigma={},
                        error_db=7.0, baseline_error_db=10.0, view_error_db={}, window="record", n_evaluations=1,
                        claimed=claimed)
    return SimpleNamespace(claimed=[c] if claimed else [], candidates=[c])


@pytest.fixture(scope="module")
def comparisons():
    import foreign_rig as fr

    out = {}
    for name, pits in (("pitted", {3: (0.5, 0.3, 0.7)}), ("healthy", {})):
        m = fr.foreign_measurement(fr.ForeignRig(pits=pits))
        out[name] = calibrated_compare(m, ComparisonModel(), reference=prepare_reference(m),
                                       calibrate_nuisances=False)
    return out


def test_a_pitted_pinion_is_noted_on_the_gear_the_leader_names(comparisons):
    c = comparisons["pitted"]
    note = local_fault_note(c, _unclaimed_lead("pinion"))
    assert note is not None and "pinion's synchronous average" in note and "tooth_pit" in note
    i = [loc.key for loc in c.reference.plan.locations].index("stats:pinion_energy_ratio")
    assert c.evaluation.residuals.residual_db[i] >= LOCAL_SIGNATURE_DB
    assert local_fault_note(c, _unclaimed_lead("wheel")) is None        # the evidence is on the other gear
    assert local_fault_note(c, _unclaimed_lead("pinion", claimed=True)) is None     # a claim speaks for itself


def test_a_healthy_foreign_pinion_gets_no_note(comparisons):
    assert local_fault_note(comparisons["healthy"], _unclaimed_lead("pinion")) is None
