"""Feature-table baselines read against a healthy reference of the same machine (``models/reference_features.py``).

Checked against what trending an indicator against a baseline must do (Randall 2011, chapter 5): a sensor gain
the record and its reference share cancels in the residual's level columns; a healthy record's residual holds
noise only, a faulty one's the fault; and against the problem it exists for: toy machines whose own
tooth-to-tooth deviations are as strong as a fault (``models.toy.toy_machines_with_references``), where the
same baseline on the record's own indicators cannot tell them apart.
"""
import json

import numpy as np
import pytest

from gearpit.errors import InputError
from models.baselines import feature_config_for, feature_table, fit_baseline
from models.data import SignalSet
from models.io import load_model, save_model
from models.reference_features import RESIDUAL_NAMES, residual_indicators
from models.toy import toy_machines_with_references


@pytest.fixture(scope="module")
def machines():
    """40 training machines and 20 other ones for the test, each record with its reference."""
    return toy_machines_with_references(n_machines=40, seed=1), toy_machines_with_references(n_machines=20, seed=2)


@pytest.fixture(scope="module")
def tables(machines):
    """Feature tables of both sets, with and without the reference columns (the record's own columns come
    first in the referenced table: checked against the plain table of the test set)."""
    cfg = feature_config_for(machines[0], reference=True)
    x, names = feature_table(machines[0], cfg)
    xt, names_t = feature_table(machines[1], cfg)
    assert names_t == names
    plain_cfg = feature_config_for(machines[0])
    xp, names_p = feature_table(machines[1], plain_cfg)
    k = len(names_p)
    assert names[:k] == names_p
    np.testing.assert_array_equal(xt[:, :k], xp)
    return {True: (cfg, x, xt, names), False: (plain_cfg, x[:, :k], xp, names_p)}


def _fit(machines, tables, ref: bool, kind: str = "rf"):
    cfg, x, _, names = tables[ref]
    return fit_baseline(machines[0], kind, features=x, feature_names=names, feature_config=cfg, task="binary")


def test_the_reference_columns_tell_a_fault_from_the_machines_own_deviations(machines, tables):
    """On 20 machines it has not seen: a random forest on the table with the reference columns >= 90 % healthy vs
    damaged; the same forest on the record's own columns <= 75 % (measured: 100 % vs 58 %; logistic regression
    98 % vs 57 %, 60 / 30 machines)."""
    truth = machines[1].labels["severity_class"].to_numpy()
    acc = {}
    for ref in (False, True):
        pred = _fit(machines, tables, ref).predict_features(tables[ref][2])
        acc[ref] = np.mean(pred.severity_class == truth)
    assert acc[True] >= 0.9, acc
    assert acc[False] <= 0.75, acc


def test_the_table_holds_the_change_since_the_reference_and_the_residual(machines, tables):
    """Columns: the record's own, ``delta:`` = record - reference for each (checked against a table of the
    references computed on its own), and the residual indicators."""
    cfg, x, _, names = tables[True]
    n_own = tables[False][1].shape[1]
    assert x.shape[1] == 2 * n_own + len(RESIDUAL_NAMES)
    assert names[n_own:2 * n_own] == [f"delta:{n}" for n in names[:n_own]]
    d = machines[0]
    refs = SignalSet(d.reference, d.fs_hz, d.pair, d.labels)
    x_ref, _ = feature_table(refs, {k: v for k, v in cfg.items() if k != "reference"})
    np.testing.assert_allclose(x[:, n_own:2 * n_own], x[:, :n_own] - x_ref, rtol=1e-12, atol=1e-12)


def test_a_shared_gain_cancels_in_the_residual_levels_and_a_fault_raises_them(machines):
    """Record and reference x 7: the residual columns do not move (the levels are ratios of quantities read through
    one path; tolerance 1e-9). A damaged record's residual is stronger, relative to the machine's own
    difference signal, than a healthy one's (whose residual is the two noise draws only): medians apart by more
    than 0.3 decade."""
    d = machines[1]
    a = residual_indicators(d)
    scaled = SignalSet(7.0 * d.signals.astype(float), d.fs_hz, d.pair, d.labels, reference=7.0 * d.reference.astype(float))
    b = residual_indicators(scaled)
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9)
    damaged = d.labels["severity_class"].to_numpy() == "damaged"
    own = a[:, RESIDUAL_NAMES.index("residual:rms_over_own")]
    assert np.median(own[damaged]) - np.median(own[~damaged]) > 0.3


def test_save_load_and_refusals(machines, tables, tmp_path):
    """A saved baseline keeps the flag and predicts the same; records without a reference are refused, naming
    it, at training and at prediction."""
    model = _fit(machines, tables, True, kind="logreg")
    save_model(model, tmp_path / "m")
    loaded = load_model(tmp_path / "m")
    assert loaded.spec.representation["reference"] is True
    test = machines[1]
    # the loaded model computes the table itself; the fitted one is given the fixture's table
    np.testing.assert_array_equal(loaded.predict(test).severity_proba,
                                  model.predict_features(tables[True][2]).severity_proba)
    bare = SignalSet(test.signals, test.fs_hz, test.pair, test.labels)
    with pytest.raises(InputError, match="reference"):
        loaded.predict(bare)
    with pytest.raises(InputError, match="reference"):
        feature_config_for(bare, reference=True)


def test_cli_trains_a_baseline_against_the_reference(machines, tmp_path, capsys):
    """``gearpit train --model logreg --reference`` on a dataset with healthy twins: the model reads the twins,
    ``evaluate`` on its 20 training machines scores >= 90 %, and ``predict`` reads a measurement file's
    reference from its sidecar (without it: refused, naming the reference)."""
    from gearpit.cli import main
    from toy_files import evaluate_and_predict, write_toy_dataset

    train = machines[0].subset(np.arange(40))   # 20 machines
    root = tmp_path / "ds"
    write_toy_dataset(root, train)
    assert main(["train", str(root), "--out", str(tmp_path / "m"), "--model", "logreg", "--reference",
                 "--task", "binary"]) == 0
    spec = json.loads((tmp_path / "m" / "model.json").read_text())
    assert spec["representation"]["reference"] is True
    assert any(n.startswith("residual:") for n in spec["representation"]["feature_names"])
    meas = evaluate_and_predict(tmp_path / "m", root, train, tmp_path, capsys)
    rc = main(["predict", str(tmp_path / "m"), str(meas / "ref.npz"), "--json", "--sidecar-speed"])
    assert rc == 2 and "reference" in capsys.readouterr().err
