"""The sensor gain fit (compare.error.fit_gain_db) against numerical dust in a noise-free model.

Truth by construction: a model whose every clear line is the measurement's less a known gain. A noise-free
simulation's healthy sidebands are numerical dust 210-230 dB below its mesh line (measured on the baseline model
at 1439.8 rpm for an independent simulator's 31/47 rig), yet above that record's own floor, which is lower still;
taking them for lines fitted the gain 115 dB off on that rig, and the comparison claimed a pit on a healthy gear."""
import numpy as np

from compare.comparison import prepare_reference
from compare.error import DYNAMIC_RANGE_DB, fit_gain_db, gain_mask
from compare.views import SignalViews


def test_the_gain_ignores_numerical_dust_of_a_noise_free_model():
    import foreign_rig as fr

    m = fr.foreign_measurement(fr.ForeignRig(pits={3: (0.5, 0.3, 0.7)}))
    ref = prepare_reference(m)
    plan, meas = ref.plan, ref.views
    g = gain_mask(plan)
    keys = [loc.key for loc in plan.locations]
    mesh = np.array([k.startswith("order:fm") and "_" not in k for k in keys]) & g
    assert mesh.sum() >= 5 and (g & ~mesh).sum() > 2 * mesh.sum()
    gain = 60.0
    top = np.max(meas.levels[mesh]) - gain
    levels = np.where(mesh, meas.levels - gain, top - 220.0)      # every other line: dust, far below the mesh
    floors = np.full(levels.shape, top - 260.0)                    # ... and above the model's own floor
    model = SignalViews(levels=levels, floors=floors)
    assert abs(fit_gain_db(meas, model, plan) - gain) < 1e-9
    # a real line of the model within the dynamic range still counts
    assert DYNAMIC_RANGE_DB < 220.0
