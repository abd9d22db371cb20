"""The sensor channel's unit (sidecar ``sensor_unit``, compare.sensor_units): a record written in any declared
unit is read in SI at the file boundary (compare.measurement), and a bad declaration is refused naming the
field, the value and what is allowed.

Source of truth: the unit definitions (standard gravity 9.80665 m/s^2, ISO 80000-3; 1 in = 0.0254 m) and the
sensitivity rule of compare/sensor_units.py; each test writes its own small file. Tolerance: float64 round-off
of one multiplication (rtol 1e-12).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from compare.measurement import load_measurement
from gearpit.errors import InputError

FS = 5000.0
N = 5000  # 1 s: at 1500 rpm the spur-gds wheel turns 7.25 times


def _record(seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    return 3.0 * np.sin(2 * np.pi * 725.0 * t) + 0.3 * rng.standard_normal(N)


def _write(tmp_path, name, x, **side):
    p = tmp_path / f"{name}.npz"
    np.savez(p, acc=x, fs_hz=FS)
    (tmp_path / f"{name}.json").write_text(json.dumps({"speed_rpm": 1500.0, "torque_nm": 20.0, "pair": "spur-gds",
                                                       "sensor": "acc", **side}))
    return p


# file's numbers per SI unit (the inverse of the factor to SI), and the sidecar keys that declare them
CASES = [
    ("m/s^2", 1.0, {}),
    ("mm/s^2", 1000.0, {}),
    ("g", 1 / 9.80665, {}),
    ("V at 10.2 mV/(m/s^2)", 0.0102, {"sensor_unit": "V", "sensor_sensitivity": 0.0102,
                                      "sensor_sensitivity_unit": "m/s^2"}),
    ("mV at 100 mV/g", 100 / 9.80665, {"sensor_unit": "mV", "sensor_sensitivity": 100.0,
                                       "sensor_sensitivity_unit": "g"}),
    ("counts at 327.68 /g", 327.68 / 9.80665, {"sensor_unit": "counts", "sensor_sensitivity": 327.68,
                                               "sensor_sensitivity_unit": "g"}),
    ("fullscale of 50 g", 0.02 / 9.80665, {"sensor_unit": "fullscale", "sensor_sensitivity": 0.02,
                                           "sensor_sensitivity_unit": "g"}),
]


@pytest.mark.parametrize("label,per_si,side", CASES, ids=[c[0] for c in CASES])
def test_an_acceleration_in_any_declared_unit_is_read_in_m_s2(tmp_path, label, per_si, side):
    """Before, the sidecar had no unit key (refused as unknown) and the numbers were read as they were: the same
    record in g was 9.8 times smaller for every model that reads levels."""
    x = _record()
    side = side or {"sensor_unit": label}
    m = load_measurement(_write(tmp_path, "r", x * per_si, **side))
    np.testing.assert_allclose(m.signal, x, rtol=1e-12, atol=1e-12 * np.abs(x).max())
    assert m.sidecar.sensor_unit == side["sensor_unit"]


@pytest.mark.parametrize("quantity,unit,per_si", [("velocity", "mm/s", 1000.0), ("velocity", "in/s", 1 / 0.0254),
                                                  ("displacement", "um", 1e6), ("displacement", "mm", 1e3)])
def test_a_velocity_or_displacement_unit_is_brought_to_si_before_the_derivative(tmp_path, quantity, unit, per_si):
    """The derivative (features.derivative, linear) then sees the SI record: the acceleration is the same as
    from the record written in m/s or m."""
    x = _record(1) * 1e-3
    si = load_measurement(_write(tmp_path, "si", x, sensor_quantity=quantity))
    got = load_measurement(_write(tmp_path, "u", x * per_si, sensor_quantity=quantity, sensor_unit=unit))
    np.testing.assert_allclose(got.signal, si.signal, rtol=1e-9, atol=1e-12 * np.abs(si.signal).max())


def test_an_integer_wav_declared_fullscale_reads_in_si(tmp_path):
    """An int16 WAV is read as fractions of full scale ([-1, 1), compare.array_files.read_wav); with its full scale
    declared (0.02 per g: full scale 50 g) it reads in m/s^2 to the converter's resolution."""
    from scipy.io import wavfile

    x = _record(2)                                       # m/s^2, within +/- 50 g
    counts = np.round(x / (50 * 9.80665) * 32768).astype(np.int16)
    p = tmp_path / "r.wav"
    wavfile.write(p, int(FS), counts)
    side = {"speed_rpm": 1500.0, "torque_nm": 20.0, "pair": "spur-gds", "sensor_unit": "fullscale",
            "sensor_sensitivity": 0.02, "sensor_sensitivity_unit": "g"}
    (tmp_path / "r.json").write_text(json.dumps(side))
    m = load_measurement(p)
    np.testing.assert_allclose(m.signal, x, atol=50 * 9.80665 / 32768)
    (tmp_path / "r.json").write_text(json.dumps({**side, "sensor_unit": "counts"}))
    with pytest.raises(InputError, match=r"r\.json\.sensor_unit: got 'counts'; allowed: fullscale for a WAV"):
        load_measurement(p)


@pytest.mark.parametrize("side,match", [
    ({"sensor_unit": "m/s2"}, r"sensor_unit: got 'm/s2'; allowed: one of: m/s\^2, mm/s\^2, g \(acceleration\); "
                              r"m/s, mm/s, in/s \(velocity\); m, mm, um \(displacement\); V, mV, counts, fullscale"),
    ({"sensor_unit": "mm/s"}, r"sensor_unit: got 'mm/s'; allowed: a unit of acceleration \(sensor_quantity = "
                              r"\"acceleration\"\): m/s\^2, mm/s\^2, g; mm/s is a unit of velocity: if the sensor "
                              r"measures velocity, set sensor_quantity = \"velocity\""),
    ({"sensor_quantity": "displacement", "sensor_unit": "g"}, r"sensor_unit: got 'g'; allowed: a unit of "
                                                             r"displacement"),
    ({"sensor_unit": "V"}, r"sensor_sensitivity: got None; allowed: a finite number > 0 with sensor_unit = \"V\""),
    ({"sensor_unit": "V", "sensor_sensitivity": -0.1, "sensor_sensitivity_unit": "g"},
     r"sensor_sensitivity: got -0.1; allowed: a finite number > 0"),
    ({"sensor_unit": "V", "sensor_sensitivity": 0.1}, r"sensor_sensitivity_unit: got None; allowed: a unit of "
                                                      r"acceleration"),
    ({"sensor_unit": "V", "sensor_sensitivity": 0.1, "sensor_sensitivity_unit": "mm/s"},
     r"sensor_sensitivity_unit: got 'mm/s'; allowed: a unit of acceleration"),
    ({"sensor_unit": "g", "sensor_sensitivity": 0.1}, r"sensor_sensitivity: got 0.1; allowed: absent: the numbers "
                                                      r"are already in g"),
    ({"sensor_sensitivity": 0.1, "sensor_sensitivity_unit": "g"}, r"sensor_sensitivity: got 0.1; allowed: absent "
                                                                  r"unless sensor_unit is one of V, mV"),
])
def test_a_bad_unit_declaration_is_refused_naming_field_value_and_allowed(tmp_path, side, match):
    with pytest.raises(InputError, match=r"r\.json\." + match):
        load_measurement(_write(tmp_path, "r", _record(), **side))


@pytest.fixture(scope="module")
def rig_record():
    """A 1 s record of the model's own rig (no hidden effect, the default drive train) through a calibrated
    sensor (gain 1, m/s^2), with its tachometer."""
    from compare.synthetic import rig_measurement

    return rig_measurement((), duration_s=1.0, gain=1.0, nuisance={})


def _compare(tmp_path, name, m, k, capsys, **side):
    from gearpit.cli import main

    np.savez(tmp_path / f"{name}.npz", acc=m.channels["acc"] * k, tacho=m.channels["tacho"], fs_hz=m.fs_hz)
    (tmp_path / f"{name}.json").write_text(json.dumps({"speed_rpm": 1005.0, "torque_nm": 50.0, "pair": "spur-gds",
                                                       "sensor": "acc", "tacho": "tacho", **side}))
    capsys.readouterr()
    rc = main(["compare", str(tmp_path / f"{name}.npz"), "--no-attribution", "--no-calibrate",
               "--json", str(tmp_path / f"{name}.out.json"), "--report", str(tmp_path / f"{name}.html")])
    out = capsys.readouterr().out
    assert rc == 0, out
    return json.loads((tmp_path / f"{name}.out.json").read_text()), out


def test_compare_reports_the_gain_of_a_declared_unit_as_a_dimensionless_correction(tmp_path, rig_record, capsys):
    """Undeclared, the fitted gain carries the file's unit (a record in g: -19.83 dB = 20 log10(1 / 9.80665)),
    in dB as before; declared, the record is read in m/s^2 and the gain is the calibration's correction, x 1.00
    for this calibrated sensor (JSON gain_factor, CLI line, HTML report, schema-valid)."""
    plain, out_plain = _compare(tmp_path, "plain", rig_record, 1.0, capsys)
    in_g, _ = _compare(tmp_path, "in_g", rig_record, 1 / 9.80665, capsys)
    said, out_said = _compare(tmp_path, "said_g", rig_record, 1 / 9.80665, capsys, sensor_unit="g")
    assert plain["gain_factor"] is None and in_g["gain_factor"] is None
    assert in_g["gain_db"] == pytest.approx(plain["gain_db"] + 20 * np.log10(1 / 9.80665), abs=1e-6)
    assert f"sensor gain {plain['gain_db']:+.2f} dB\n" in out_plain
    assert said["measurement"]["sensor_unit"] == "g"
    assert said["gain_db"] == pytest.approx(plain["gain_db"], abs=1e-6)
    assert said["gain_factor"] == pytest.approx(10 ** (said["gain_db"] / 20), rel=1e-12)
    assert said["gain_factor"] == pytest.approx(1.0, abs=0.01)
    assert "sensor gain x 1.00 (" in out_said and "declared unit g (x 9.80665 to m/s^2)" in out_said
    assert "Sensor gain fitted: x 1.00 (" in (tmp_path / "said_g.html").read_text()
    assert f"Sensor gain fitted: {plain['gain_db']:+.2f} dB." in (tmp_path / "plain.html").read_text()
    jsonschema = pytest.importorskip("jsonschema")
    from compare.schema import SCHEMA

    for doc in (plain, said):
        jsonschema.validate(doc, SCHEMA)
