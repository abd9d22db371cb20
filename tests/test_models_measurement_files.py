"""Measurement files for ``gearpit predict / evaluate`` (models.measurement_files, models.labels_file,
models.record_groups): the sensor's quantity brought to the model's, the files of a folder and their labels
checked before any work, every record cut to the trained length so that a file's prediction does not depend on
the other files of the call, and every error naming its file. Toy records (models.toy) and a logistic-regression
baseline trained on them (seconds)."""
import json
from dataclasses import replace

import numpy as np
import pytest

from gearpit.cli import main
from gearpit.errors import InputError
from models.toy import toy_signal_set

FS = 4096.0


def _toy(seed: int, *, n: int = 10, fs: float = FS, duration_s: float = 1.0):
    return toy_signal_set(n_per_class=n, fs_hz=fs, duration_s=duration_s, z_pinion=29, z_wheel=100,
                          speeds_rpm=(1200.0, 1500.0), classes=(("healthy", 0.0), ("severe", 0.35)), snr_db=20.0,
                          seed=seed)


def _write(folder, name, x, *, fs=FS, speed=1200.0, **side):
    """``x`` as ``name`` (.npy or a .csv with one named column) and a JSON sidecar beside it."""
    folder.mkdir(exist_ok=True)
    p = folder / name
    sensor = side.pop("sensor", "acc")
    if p.suffix == ".csv":
        np.savetxt(p, x, header=sensor, comments="")
    else:
        np.save(p, x)
    (folder / (p.stem + ".json")).write_text(json.dumps({"fs_hz": fs, "speed_rpm": speed, "torque_nm": 50.0,
                                                         "pair": "spur-gds", "sensor": sensor if p.suffix == ".csv"
                                                         else 0, **side}))
    return p


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A logistic-regression baseline on 20 toy records of 4096 samples (healthy / severe)."""
    from toy_models import trained_toy_model

    return trained_toy_model(tmp_path_factory.mktemp("mf"), _toy(1), FS)


def _spec(model, **kw):
    from models.io import load_model

    return replace(load_model(model).spec, **kw)


def _predict(model, files, capsys, *flags):
    capsys.readouterr()
    rc = main(["predict", str(model), *map(str, files), "--json", "--sidecar-speed", *flags])
    cap = capsys.readouterr()
    rows = {r["record"]: r for r in map(json.loads, cap.out.strip().splitlines())} if rc == 0 else {}
    return rc, rows, cap.err


# ---------------------------------------------------------------------------------------------- quantity
def test_the_sidecars_quantity_is_brought_to_the_models_or_refused(model, tmp_path):
    """Before, a measurement was always read as acceleration (a declared displacement differentiated twice even
    for a transmission-error model) and its channel's quantity never checked. Now: a displacement stays one for
    a displacement model (samples as written), is differentiated for an acceleration model
    (features.derivative); an acceleration for a displacement model is refused naming the file,
    sensor_quantity and the trained channel; a channel named dte_m read as acceleration (the default) warns."""
    from features.derivative import derivative
    from models.sources import load_data
    from models.spec import check_input

    x = _toy(5, n=1).signals[0].astype(float)
    folder = tmp_path / "q"
    disp = _write(folder, "disp.csv", x, sensor="dte_m", sensor_quantity="displacement")
    plain = _write(folder, "plain.csv", x, sensor="dte_m")
    acc = _write(folder, "acc.csv", x, sensor="acc_m_s2", sensor_quantity="acceleration")
    te, am = _spec(model, channel="dte_m"), _spec(model)
    n = te.n_samples
    kw = dict(refine_speed=False)

    got = load_data([disp], spec=te, **kw).single()
    np.testing.assert_allclose(got.signals[0], np.loadtxt(disp, skiprows=1)[:n], rtol=1e-6)
    got = load_data([disp], spec=am, allow_mismatch=True, **kw).single()      # 2 x 64 samples cut by the filter
    np.testing.assert_allclose(got.signals[0], derivative(np.loadtxt(disp, skiprows=1), FS, 2), rtol=1e-5,
                               atol=1e-6 * np.abs(got.signals[0]).max())
    for f, hint in ((acc, False), (plain, True)):
        with pytest.raises(InputError) as exc:
            load_data([f], spec=te, **kw)
        msg = str(exc.value)
        assert msg.startswith(f"{f.name}: sensor_quantity: got 'acceleration'") and "dte_m (displacement)" in msg
        assert ('sensor_quantity = "displacement"' in msg) == hint
    warn = check_input(am, load_data([plain], spec=am, **kw).single())[0]
    assert "dte_m's name suggests a displacement" in warn


# ---------------------------------------------------------------------------------------------- folders
def test_a_folders_files_without_sidecar_are_an_error_when_labelled_and_reported_when_not(model, tmp_path):
    """Before, a data file without a sidecar was dropped silently, labelled or not, and label rows of files not
    on disk passed. Now a labelled one is refused by name (a sidecar template written beside it), an unlisted one
    is reported as skipped on stderr, and rows of missing files are refused naming them."""
    from models.sources import load_data

    data = _toy(6, n=1)
    folder = tmp_path / "f"
    _write(folder, "a.npy", data.signals[0])
    np.save(folder / "b.npy", data.signals[1])                   # no sidecar, not listed
    (folder / "labels.csv").write_text("file,severity_class\na.npy,healthy\n")
    groups = load_data([folder], spec=_spec(model), refine_speed=False)
    assert len(groups) == 1 and groups.skipped == ("b.npy: skipped (no sidecar beside it, and not in labels.csv)",)
    (folder / "labels.csv").write_text("file,severity_class\na.npy,healthy\nb.npy,severe\n")
    with pytest.raises(InputError, match=r"^b\.npy: sidecar: .*template") as exc:
        load_data([folder], spec=_spec(model), refine_speed=False)
    assert (folder / "b.npy.toml.template").is_file() and "b.toml" in str(exc.value)
    (folder / "labels.csv").write_text("file,severity_class\na.npy,healthy\nc.npy,severe\nd.npy,severe\n")
    with pytest.raises(InputError, match=r"labels.csv: file: got \['c.npy', 'd.npy'\]; .*not on disk"):
        load_data([folder], spec=_spec(model), refine_speed=False)


# ---------------------------------------------------------------------------------------------- labels
@pytest.mark.parametrize("body,match", [
    ("a.npy,medium,0.1\nb.npy,severe,0.3\n", "labels.csv row a.npy: severity_class: got 'medium'; allowed: one of "
                                             "the model's classes: healthy, severe"),
    ("a.npy,healthy,0\na.npy,severe,0.3\n", "labels.csv row a.npy: file: got 'a.npy'; allowed: each file once"),
    ("a.npy,healthy,abc\nb.npy,severe,0.3\n", "labels.csv row a.npy: severity: got 'abc'; allowed: a number in "
                                              r"\[0, 1\]"),
    ("a.npy,healthy,0\nb.npy,severe,1.5\n", r"labels.csv row b.npy: severity: got '1.5'"),
    ("a.npy,healthy,0.3\nb.npy,severe,0.3\n", "labels.csv row a.npy: severity: got '0.3'; allowed: 0 for class "
                                              "'healthy'"),
])
def test_labels_csv_problems_name_the_row_the_column_and_what_is_allowed(model, tmp_path, body, match):
    """Before: an unknown class scored quietly (accuracy over the others), duplicates, text severities, case
    differences and out-of-range values gave tracebacks or passed. Now each is refused before any record is
    read, naming the row's file, the column, the value and what is allowed."""
    from models.sources import load_data

    data = _toy(6, n=1)
    folder = tmp_path / "l"
    for i, name in enumerate(("a.npy", "b.npy")):
        _write(folder, name, data.signals[i])
    (folder / "labels.csv").write_text("file,severity_class,severity\n" + body)
    spec = _spec(model)
    with pytest.raises(InputError, match=match):
        load_data([folder], spec=spec, refine_speed=False, classes=spec.severity_classes)


def test_labels_csv_with_semicolons_decimal_commas_and_any_case_reads_as_the_plain_one(model, tmp_path):
    """';' with a decimal comma (a German spreadsheet export) and class names in another case were a pandas
    ParserError and a scikit-learn traceback; they now read as the plain file does, teeth -1 is refused."""
    from models.sources import load_data

    data = _toy(6, n=1)
    folder = tmp_path / "s"
    for i, name in enumerate(("a.npy", "b.npy")):
        _write(folder, name, data.signals[i])
    spec = _spec(model)
    got = []
    for text in ("file,severity_class,severity,n_pitted_teeth\na.npy,healthy,0,0\nb.npy,severe,0.35,1\n",
                 "file;severity_class;severity;n_pitted_teeth\na.npy;Healthy;0;0\nb.npy;SEVERE;0,35;1\n"):
        (folder / "labels.csv").write_text(text)
        lab = load_data([folder], spec=spec, refine_speed=False, classes=spec.severity_classes).merged().labels
        got.append(lab[["file", "severity_class", "severity", "teeth_class"]].to_dict(orient="list"))
    assert got[0] == got[1] == {"file": ["a.npy", "b.npy"], "severity_class": ["healthy", "severe"],
                                "severity": [0.0, 0.35], "teeth_class": ["0", "1"]}
    (folder / "labels.csv").write_text("file,severity_class,n_pitted_teeth\na.npy,healthy,0\nb.npy,severe,-1\n")
    with pytest.raises(InputError, match="labels.csv row b.npy: n_pitted_teeth: got '-1'; allowed: an integer >= 0"):
        load_data([folder], spec=spec, refine_speed=False)


def test_sidecar_fault_unknown_is_predicted_not_scored_and_another_name_is_refused(model, tmp_path, capsys):
    """The README's own example ``fault = "unknown"`` (and any name that is no class) gave a scikit-learn
    traceback in evaluate. Now "unknown" files are predicted and left out of the scores (counted in metrics.json
    and on stderr), and a fault that is no class of the model is refused naming the file and the classes."""
    data = _toy(6, n=1)
    folder = tmp_path / "fa"
    _write(folder, "a.npy", data.signals[0], fault="healthy")
    _write(folder, "b.npy", data.signals[1], fault="severe")
    _write(folder, "c.npy", data.signals[1], fault="unknown")
    capsys.readouterr()
    assert main(["evaluate", str(model), str(folder), "--out", str(tmp_path / "ev"), "--sidecar-speed"]) == 0
    m = json.loads((tmp_path / "ev" / "metrics.json").read_text())
    assert m["n_records"] == 2 and m["n_unscored"] == 1 and sum(map(sum, m["severity_class"]["confusion"])) == 2
    assert "1 file(s) predicted but not scored (label 'unknown'): c.npy" in capsys.readouterr().err
    _write(folder, "c.npy", data.signals[1], fault="pitted")
    assert main(["evaluate", str(model), str(folder), "--out", str(tmp_path / "ev2"), "--sidecar-speed"]) == 2
    assert "c.npy: fault: got 'pitted'; allowed: one of the model's classes: healthy, severe" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------- lengths, rates
def test_a_files_prediction_does_not_depend_on_the_other_files_of_the_call(model, tmp_path, capsys):
    """Before, every record was cut to the shortest of the call: a 2 s file alone and beside a 1.5 s one got
    different features. Now each is cut to the trained 4096 samples: the same probabilities either way, and the
    same as the file cut by hand."""
    folder = tmp_path / "len"
    long = _write(folder, "long.npy", _toy(7, n=1, duration_s=2.0).signals[0])
    other = _write(folder, "other.npy", _toy(8, n=1, duration_s=1.5).signals[1])
    cut = _write(folder, "cut.npy", np.load(long)[:4096])
    _, alone, _ = _predict(model, [long], capsys)
    _, both, _ = _predict(model, [long, other], capsys)
    _, by_hand, _ = _predict(model, [cut], capsys)
    for key in ("p_healthy", "p_severe", "severity"):
        # (to float rounding: a batch of two goes through the matrix products together)
        assert alone["long.npy"][key] == pytest.approx(both["long.npy"][key], rel=1e-9, abs=1e-12)
        assert alone["long.npy"][key] == pytest.approx(by_hand["cut.npy"][key], rel=1e-9, abs=1e-12)


def test_a_record_shorter_than_the_trained_length_is_refused_or_warned_naming_the_file(model, tmp_path, capsys):
    """A baseline took any length down to half the trained one silently (3072 of 4096 samples here); the CNN's
    rule already refused short records. Now every model type refuses one shorter than the trained length,
    naming the file, and --allow-mismatch predicts it with a warning."""
    folder = tmp_path / "short"
    ok = _write(folder, "ok.npy", _toy(7, n=1).signals[0])
    short = _write(folder, "short.npy", _toy(7, n=1, duration_s=0.75).signals[1])
    rc, _, err = _predict(model, [ok, short], capsys)
    assert rc == 2 and "short.npy: n_samples: got 3072; allowed: >= 4096 samples" in err
    rc, rows, err = _predict(model, [ok, short], capsys, "--allow-mismatch")
    assert rc == 0 and list(rows) == ["ok.npy", "short.npy"]
    assert "short.npy: record of 3072 samples, shorter than the trained 4096" in err
    _, alone, _ = _predict(model, [ok], capsys)
    assert rows["ok.npy"]["p_severe"] == alone["ok.npy"]["p_severe"]


def test_files_at_several_rates_are_checked_one_by_one_and_errors_name_the_file(model, tmp_path, capsys):
    """A call with a file at the model's rate and one at twice it blamed the first file ("all files alike") even
    with --allow-mismatch; a NaN sample's error named no file. Now the odd file is named, --allow-mismatch reads
    each file on its own (the matching file's prediction is its prediction alone) and a NaN names its file."""
    folder = tmp_path / "fs"
    odd = _write(folder, "a_odd.npy", _toy(9, n=1, fs=2 * FS).signals[0], fs=2 * FS)
    ok = _write(folder, "ok.npy", _toy(7, n=1).signals[0])
    rc, _, err = _predict(model, [odd, ok], capsys)
    assert rc == 2 and err.startswith("gearpit predict: error: a_odd.npy: fs_hz: got 8192.0")
    rc, rows, err = _predict(model, [odd, ok], capsys, "--allow-mismatch")
    _, alone, _ = _predict(model, [ok], capsys)
    _, odd_alone, _ = _predict(model, [odd], capsys, "--allow-mismatch")
    assert rc == 0 and list(rows) == ["a_odd.npy", "ok.npy"]
    assert rows["ok.npy"]["p_severe"] == alone["ok.npy"]["p_severe"]
    assert rows["a_odd.npy"]["p_severe"] == odd_alone["a_odd.npy"]["p_severe"]
    x = _toy(7, n=1).signals[1].copy()
    x[100] = np.nan
    bad = _write(folder, "nan.npy", x)
    rc, _, err = _predict(model, [ok, bad], capsys)
    assert rc == 2 and "nan.npy: channel ch0: got '1 NaN/inf samples" in err
