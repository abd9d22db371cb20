"""The sensor's unit for ``gearpit predict / evaluate`` (sidecar ``sensor_unit``, models.measurement_files,
models.spec.absolute_level_inputs): a model that reads absolute levels gives the same prediction for a record
whatever unit it is written in once the unit is declared, and warns, naming the file, where it is not; a
level-free model (a CNN on its per-record normalised representation) needs no unit and gets no warning.

Source of truth: the unit definitions of compare/sensor_units.py; toy records (models.toy) and a
logistic-regression baseline trained on them in m/s^2 (seconds). Tolerance: the class probabilities of the
record in m/s^2 and in g agree to 1e-6 (float32 records)."""
import json
from dataclasses import replace

import numpy as np
import pytest

from gearpit.cli import main
from gearpit.errors import InputError
from models.toy import toy_signal_set

FS = 4096.0
G = 9.80665


def _toy(seed: int, n: int = 10):
    return toy_signal_set(n_per_class=n, fs_hz=FS, duration_s=1.0, z_pinion=29, z_wheel=100,
                          speeds_rpm=(1200.0, 1500.0), classes=(("healthy", 0.0), ("severe", 0.35)), snr_db=20.0,
                          seed=seed)


def _write(folder, name, x, **side):
    folder.mkdir(exist_ok=True)
    np.save(folder / f"{name}.npy", x)
    (folder / f"{name}.json").write_text(json.dumps({"fs_hz": FS, "speed_rpm": 1200.0, "torque_nm": 50.0,
                                                     "pair": "spur-gds", "sensor": 0, **side}))
    return folder / f"{name}.npy"


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A logistic-regression baseline on 20 toy records of 4096 samples (healthy / severe), in m/s^2."""
    from toy_models import trained_toy_model

    return trained_toy_model(tmp_path_factory.mktemp("units"), _toy(1), FS)


def _predict(model, files, capsys):
    capsys.readouterr()
    rc = main(["predict", str(model), *map(str, files), "--json", "--sidecar-speed"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    return {r["record"]: r for r in map(json.loads, cap.out.strip().splitlines())}, cap.err


def test_a_baseline_predicts_the_same_for_a_record_in_m_s2_and_in_g_once_declared(model, tmp_path, capsys):
    """Before, the sidecar could not say the unit (sensor_unit refused as unknown) and a baseline read the
    record's numbers as m/s^2: the audit's random forest called one record minor 0.94 in m/s^2 and severe 0.56 in
    mm/s^2, without a warning."""
    x = _toy(7, n=1).signals[1].astype(float)            # a severe record, m/s^2
    folder = tmp_path / "u"
    ms2 = _write(folder, "in_ms2", x, sensor_unit="m/s^2")
    g = _write(folder, "in_g", x / G, sensor_unit="g")
    mv = _write(folder, "in_mv", x / G * 100.0, sensor_unit="mV", sensor_sensitivity=100.0,
                sensor_sensitivity_unit="g")
    rows, err = _predict(model, [ms2, g, mv], capsys)
    a = rows["in_ms2.npy"]
    for name in ("in_g.npy", "in_mv.npy"):
        b = rows[name]
        assert b["severity_class"] == a["severity_class"] and b["teeth_class"] == a["teeth_class"]
        for k in ("p_healthy", "p_severe", "severity"):
            assert b[k] == pytest.approx(a[k], abs=1e-6)
        assert "sensor_unit" not in b["warning"]
    assert "sensor_unit" not in err


def test_a_file_without_a_unit_warns_naming_it_when_the_model_reads_levels(model, tmp_path, capsys):
    """Undeclared, the g file's numbers are read as m/s^2 (9.8 times too small): every such file carries the
    warning, in the JSON row and on stderr, and gearpit evaluate lists them in metrics.json."""
    x = _toy(7, n=1).signals[1].astype(float)
    folder = tmp_path / "w"
    plain = _write(folder, "plain_g", x / G, fault="severe")
    said = _write(folder, "said_g", x / G, sensor_unit="g", fault="severe")
    rows, err = _predict(model, [plain, said], capsys)
    w = rows["plain_g.npy"]["warning"]
    assert "no sensor_unit in the sidecar of plain_g.npy, and this model reads absolute levels (its logreg " \
           "feature table" in w and "trained in m/s^2" in w
    assert "sensor_unit" not in rows["said_g.npy"]["warning"]
    assert "warning: plain_g.npy: no sensor_unit in the sidecar of plain_g.npy" in err
    assert "said_g.npy: no sensor_unit" not in err
    assert "1 no sensor_unit for a model that reads levels" in err

    capsys.readouterr()
    assert main(["evaluate", str(model), str(folder), "--out", str(tmp_path / "ev"), "--sidecar-speed"]) == 0
    cap = capsys.readouterr()
    metrics = json.loads((tmp_path / "ev" / "metrics.json").read_text())
    assert len(metrics["unit_notes"]) == 1
    assert metrics["unit_notes"][0].startswith("plain_g.npy: no sensor_unit in the sidecar of plain_g.npy")
    assert "warning: plain_g.npy: no sensor_unit in the sidecar" in cap.err
    assert json.loads(cap.out.strip().splitlines()[-1])["unit_notes"] == 1


@pytest.mark.parametrize("columns,reads", [
    ((), ""), (("speed_rpm", "torque_nm"), ""), (("torque_nm", "tooth_profile", "residual_rms"), ""),
    (("speed_rpm", "torque_nm", "signal_rms"), "signal_rms"),                         # tsa_level
    (("torque_nm", "signal_rms_no1x", "tsa_diff_rms", "tooth_profile"), "signal_rms_no1x, tsa_diff_rms"),  # tsa_te_diff
])
def test_which_models_read_absolute_levels(model, tmp_path, columns, reads):
    """A CNN reads its per-record normalised representation: level-free unless a side input carries the record's
    RMS in its unit (models.operating.LEVEL_COLUMNS); a baseline always reads levels. Only those warn."""
    from models.io import load_model
    from models.sources import load_data
    from models.spec import absolute_level_inputs

    base = load_model(model).spec
    cnn = replace(base, model_type="cnn", operating_inputs={"columns": list(columns)} if columns else {})
    assert absolute_level_inputs(cnn) == (f"the side input{'s' if ',' in reads else ''} {reads}" if reads else "")
    assert absolute_level_inputs(base).startswith("its logreg feature table")
    f = _write(tmp_path / "c", "plain", _toy(7, n=1).signals[1].astype(float))
    note = load_data([f], spec=cnn, refine_speed=False).single().labels["unit_note"][0]
    assert (note != "") == bool(reads)
    if reads:
        assert f"reads absolute levels (the side input{'s' if ',' in reads else ''} {reads}" in note


def test_a_record_and_its_reference_declare_a_unit_both_or_neither(tmp_path):
    """Each is brought to SI by its own sidecar; a reference read in its own unit beside a record read in SI would
    put the unit's factor into every ratio of the two."""
    from models.sources import load_data

    d = _toy(7, n=1)
    folder = tmp_path / "r"
    _write(folder, "ref", d.signals[0].astype(float) / G)
    rec = _write(folder, "rec", d.signals[1].astype(float) / G, sensor_unit="g", reference="ref.npy")
    with pytest.raises(InputError, match=r"ref\.npy: sensor_unit: got None; allowed: a sensor_unit, as its record "
                                         r"rec\.npy declares g"):
        load_data([rec], refine_speed=False)
    _write(folder, "ref", d.signals[0].astype(float) / G, sensor_unit="g")
    got = load_data([rec], refine_speed=False).single()
    np.testing.assert_allclose(got.reference[0], d.signals[0], rtol=1e-5, atol=1e-6)
