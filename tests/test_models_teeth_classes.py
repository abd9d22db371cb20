"""A sweep's pitted-teeth classes ("k", "k+": its sampling strata) reach the classifiers as their own classes
"0", "1", "2", "3+" by each record's count of pitted teeth (models.data.SignalSet.teeth_classes)."""
import numpy as np
import pandas as pd
import pytest

from gearpit.errors import InputError
from models.baselines import fit_baseline
from models.data import TEETH_CLASSES, PairInfo, SignalSet


def _set(teeth_class, n_pitted=None) -> SignalSet:
    n = len(teeth_class)
    labels = pd.DataFrame({"severity_class": ["healthy"] + ["minor"] * (n - 1), "severity": [0.0] + [0.05] * (n - 1),
                           "severity_class_index": [0] + [1] * (n - 1), "teeth_class": teeth_class})
    if n_pitted is not None:
        labels["n_pitted_teeth"] = n_pitted
    return SignalSet(np.zeros((n, 64), np.float32), 4096.0, PairInfo("toy", 13, 29), labels)


def test_sweep_teeth_classes_map_by_count():
    """Classes "5", "1+", "2+" of a sweep (generate accepts them) become "3+", "2", "3+" by their counts."""
    data = _set(["0", "5", "1+", "1+", "2+", "1"], [0, 5, 1, 2, 3, 1])
    assert data.teeth_classes().tolist() == ["0", "3+", "1", "2", "3+", "1"]
    assert set(data.teeth_classes()) <= set(TEETH_CLASSES)


def test_baseline_trains_on_a_dataset_with_sweep_only_teeth_classes():
    """Before: KeyError '5' in the label lookup of training; now the teeth head learns the counts' classes."""
    data = _set(["0", "5", "1+", "1+", "0", "5", "1+", "1+"], [0, 5, 1, 2, 0, 5, 1, 2])
    x = np.arange(len(data), dtype=float)[:, None] * [1.0, -1.0]
    clf = fit_baseline(data, "logreg", features=x, feature_names=["a", "b"], feature_config={})
    assert clf.spec.teeth_classes == list(TEETH_CLASSES)


def test_a_record_without_count_needs_a_classifier_class():
    """A measurement label "2+" with no n_pitted_teeth cannot be placed: refused by name."""
    with pytest.raises(InputError) as exc:
        _set(["0", "2+"]).teeth_classes()
    assert exc.value.field == "labels.teeth_class" and exc.value.value == "2+"
    assert _set(["0", "3+"]).teeth_classes().tolist() == ["0", "3+"]
