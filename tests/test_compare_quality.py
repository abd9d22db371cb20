"""A clipped sensor is named (compare.quality): records made here with and without clipping, whose truth is
known; and ``gearpit compare`` on a clipped recording says so in its messages, JSON and report."""
from __future__ import annotations

import numpy as np
import pytest

from compare.quality import clipping


def test_unclipped_records_are_not_called_clipped_whatever_their_distribution_or_converter():
    """Gaussian noise as floats and on converters of 1/200, 1, 1/5 of its sigma per code; a sine (its samples
    crowd its peaks) as floats and at 12 and 8 bits; uniform noise: none is clipped."""
    rng = np.random.default_rng(0)
    g = rng.standard_normal(40000)
    s = np.sin(2 * np.pi * 483.0 * np.arange(40000) / 20000.0)
    for x in (g, np.round(g * 200) / 200, np.round(g), np.round(g * 5), s, np.round(s * 2047), np.round(s * 127),
              rng.uniform(-1, 1, 40000)):
        c = clipping(x)
        assert not c["clipped"] and c["fraction"] == 0.0, c


@pytest.mark.parametrize("limit,sides", [(2.3, ("low", "high")), ((-10.0, 2.8), ("high",))])
def test_a_clipped_record_is_found_with_its_share_and_sides(limit, sides):
    rng = np.random.default_rng(1)
    x = rng.standard_normal(40000)
    lo, hi = (-limit, limit) if np.isscalar(limit) else limit
    y = np.clip(x, lo, hi)
    c = clipping(y)
    truth = np.count_nonzero((x <= lo) | (x >= hi)) / x.size
    assert c["clipped"] and c["fraction"] == pytest.approx(truth, rel=1e-9)
    assert {s for s in ("low", "high") if c[s]} == set(sides)


def test_gearpit_compare_names_a_clipped_recording(tmp_path, capsys):
    """The suite's healthy test rig with 2 % of its sensor samples clipped, through the CLI without attribution:
    the message names the channel and the share; the JSON (schema-valid) and the report carry it."""
    import json
    from dataclasses import replace

    import jsonschema

    from compare.schema import SCHEMA
    from compare.synthetic import rig_measurement
    from compare.workflow import write_rig_files
    from gearpit.cli import main

    m = rig_measurement(())
    lim = float(np.quantile(np.abs(m.signal), 0.98))
    channels = dict(m.channels)
    channels[m.sensor] = np.clip(m.signal, -lim, lim)
    csv = write_rig_files(replace(m, channels=channels), tmp_path / "rig")
    assert main(["compare", str(csv), "--no-attribution", "--json", str(tmp_path / "c.json"),
                 "--report", str(tmp_path / "c.html")]) == 0
    out = capsys.readouterr().out
    assert "the sensor channel acc_x is clipped: 2 % of its samples" in out, out
    doc = json.loads((tmp_path / "c.json").read_text())
    jsonschema.validate(doc, SCHEMA)
    assert doc["measurement"]["clipping"]["clipped"] and doc["measurement"]["clipping"]["fraction"] > 0.015
    assert "Clipped:" in (tmp_path / "c.html").read_text()


def test_a_classifiers_clipped_measurement_carries_the_warning_into_its_predictions(tmp_path):
    """gearpit predict/evaluate read files through models.sources.load_measurements: the clipped file gets the
    message as ``clip_note`` and check_input turns it into a per-record warning; the unclipped one gets none."""
    from dataclasses import replace

    from compare.synthetic import rig_measurement
    from compare.workflow import write_rig_files
    from models.data import PairInfo
    from models.sources import load_measurements
    from models.spec import ModelSpec, check_input

    m = rig_measurement(())
    lim = float(np.quantile(np.abs(m.signal), 0.98))
    good = write_rig_files(m, tmp_path / "good")
    bad = write_rig_files(replace(m, channels={**m.channels, m.sensor: np.clip(m.signal, -lim, lim)}), tmp_path / "bad")
    data = load_measurements([good, bad])
    assert data.labels["clip_note"][0] == "" and "is clipped" in data.labels["clip_note"][1]
    spec = ModelSpec(model_type="rf", task="multi", fs_hz=data.fs_hz, n_samples=data.n_samples,
                     pair=PairInfo("spur-gds", 29, 100), representation={}, severity_classes=["healthy"],
                     teeth_classes=["0"], severity_scale=1.0)
    notes = check_input(spec, data)
    assert "clipped" not in notes[0] and "is clipped" in notes[1]


def test_a_classifiers_drifting_measurement_reaches_it_as_the_drift_free_record(tmp_path):
    """gearpit predict/evaluate: the test rig's record with a 2 RMS ramp, a 0.7 Hz wander of 1.5 RMS and a 3 RMS
    offset added is loaded (models.sources.load_measurements) as the record without them, to 2 % of its RMS
    away from the ends (the filter also takes the simulator's own 0.7 % there), with a ``drift_note``; the clean
    file is loaded as it is, with none."""
    from dataclasses import replace

    from compare.synthetic import rig_measurement
    from compare.workflow import write_rig_files
    from models.sources import load_measurements

    m = rig_measurement(())
    rms = float(np.std(m.signal))
    t = np.arange(m.n_samples) / m.fs_hz
    drift = 2.0 * rms * t / t[-1] + 1.5 * rms * np.sin(2 * np.pi * 0.7 * t) + 3.0 * rms
    good = write_rig_files(m, tmp_path / "good")
    bad = write_rig_files(replace(m, channels={**m.channels, m.sensor: m.signal + drift}), tmp_path / "bad")
    data = load_measurements([good, bad])
    assert data.labels["drift_note"][0] == "" and "removed before the classifier" in data.labels["drift_note"][1]
    a, b = data.signals[0].astype(float), data.signals[1].astype(float)
    mid = slice(a.size // 10, -a.size // 10)
    np.testing.assert_allclose(a, m.signal[:a.size], rtol=1e-5, atol=1e-6 * rms)     # the clean file: as it is
    assert np.std(b[mid] - a[mid]) <= 0.02 * rms
