"""The speed of a measurement without a tachometer when its sidecar's speed is further off than the first search
(compare.speed.spectrum_speed, widened_speed) - a set point, a nameplate speed.

Truth from outside the search: the simulated rigs' own speeds (gearpit's rig at 1000 rpm, the helical rig at 1500
rpm, the independent simulator of tests/foreign_rig.py at 1000 rpm); the sidecar is re-written with the speed
scaled. The hard records are those with a local fault, which hold every order of the faulty shaft: a family of
``k`` shaft orders for ``k`` near the tooth count stands out as a mesh line would."""
import dataclasses
import json

import numpy as np
import pytest

from compare.measurement import measurement_from_arrays
from compare.pair_check import check_pair
from compare.speed import SEARCH_FRACTION, WIDE_SEARCH_FRACTION, refine_speed
from compare.synthetic import rig_measurement
from datagen.geometry import preset

#: a speed read from the mesh line agrees with the true one to this fraction (the refinement's resolution is
#: ~1e-6; a wrong family is off by a shaft order, 3-6 %)
SPEED_RTOL = 1e-3


def _described(m, *, speed_rpm: float, pair: str | None = None):
    """The rig's sensor channel alone (no tachometer), with the sidecar's speed (and pair) re-written."""
    sc = dataclasses.replace(m.sidecar, speed_rpm=speed_rpm, tacho=None,
                             **({"pair": preset(pair)} if pair else {}))
    return measurement_from_arrays({"acc": m.channels["acc"]}, sc, source="re-described")


@pytest.fixture(scope="module")
def broken_wheel():
    """A broken wheel tooth: every one of the wheel's orders in the record."""
    return rig_measurement([{"name": "tooth_breakage", "width_fraction": 0.6, "gear": "wheel"}], pair="spur-gds",
                           speed_rpm=1000.0, duration_s=2.0), 1000.0


@pytest.fixture(scope="module")
def broken_helical_pinion():
    """A broken pinion tooth of the helical rig (17 teeth: its orders 16 and 18 lie 6 % from the mesh)."""
    return rig_measurement([{"name": "tooth_breakage", "width_fraction": 0.6}], pair="helical-dct",
                           speed_rpm=1500.0, duration_s=2.0), 1500.0


@pytest.mark.parametrize("rig", ["broken_wheel", "broken_helical_pinion"])
@pytest.mark.parametrize("factor", [0.72, 0.78, 0.84, 0.92, 1.08, 1.18, 1.26, 1.30])
def test_a_sidecar_speed_far_off_is_read_at_the_true_speed_or_left_alone(rig, factor, request):
    """Within 18 % of the true speed (the widened search's +/- 25 % around the sidecar's less the edge), the mesh
    line is found; further off, the widened search answers nothing rather than another family (the first search's
    answer stays, and the pair check questions it)."""
    m, true_rpm = request.getfixturevalue(rig)
    est = refine_speed(_described(m, speed_rpm=factor * true_rpm))
    reachable = abs(1.0 / factor - 1.0) < 0.95 * WIDE_SEARCH_FRACTION
    if reachable:
        assert est.speed_rpm == pytest.approx(true_rpm, rel=SPEED_RTOL)
        assert est.search_fraction == (SEARCH_FRACTION if abs(1 / factor - 1) < SEARCH_FRACTION else
                                       WIDE_SEARCH_FRACTION)
    else:
        assert est.search_fraction == SEARCH_FRACTION
        assert est.speed_rpm != pytest.approx(true_rpm, rel=SPEED_RTOL)


def test_a_broken_wheel_tooth_at_a_sidecar_8_percent_low_is_not_read_on_a_wheel_order_family(broken_wheel):
    """At 920 rpm for 1000 the first search (+/- 5 %) ends on 95 wheel orders, a family that stands out; the same
    tests as the widened search's reject it (its sidebands count another gear) and the widened search finds the
    mesh."""
    m, true_rpm = broken_wheel
    d = _described(m, speed_rpm=920.0)
    from compare.speed import speed_from_spectrum

    first = speed_from_spectrum(d.signal, d.fs_hz, z_pinion=29, nominal_rpm=920.0, search_fraction=SEARCH_FRACTION)
    assert first.speed_rpm != pytest.approx(true_rpm, rel=0.02)
    assert refine_speed(d).speed_rpm == pytest.approx(true_rpm, rel=SPEED_RTOL)


def test_a_broken_wheel_tooth_is_the_wheels_own_sideband_family(broken_wheel):
    """At the true speed the strongest comb is every fifth wheel order (20 "teeth"): a shaft's orders, not another
    gear, so the pair check does not say the pair is wrong."""
    m, _ = broken_wheel
    c = check_pair(m, refine_speed(m))
    assert c["z_measured"] in (10, 20, 25, 50, 100) and c["agrees"] and not c["other_family"]


def test_the_wrong_pair_is_still_questioned():
    """A 17/60 sidecar for the 29/100 rig (grade-6 pitch error) at its true speed: the widened search's best family
    (half the mesh frequency) stands out on its even harmonics only, so no speed is taken from it and the pair is
    questioned."""
    m = rig_measurement([{"name": "pitch_error", "grade": 6.0}], pair="spur-gds", duration_s=2.0)
    d = _described(m, speed_rpm=1000.0, pair="helical-dct")
    est = refine_speed(d)
    assert est.search_fraction == SEARCH_FRACTION
    assert check_pair(d, est)["questioned"]


def test_the_independent_simulators_rig_12_percent_off():
    import foreign_rig as fr
    from foreign_rig import foreign_measurement

    m = foreign_measurement(fr.ForeignRig(seed=5))
    for factor in (0.88, 1.12):
        sc = dataclasses.replace(m.sidecar, speed_rpm=1000.0 * factor, tacho=None)
        est = refine_speed(measurement_from_arrays({m.sidecar.sensor: m.signal}, sc, source="foreign"))
        assert est.speed_rpm == pytest.approx(1000.0, rel=SPEED_RTOL)
        assert est.search_fraction == WIDE_SEARCH_FRACTION


def test_gearpit_compare_says_the_sidecar_speed_is_off(tmp_path):
    """The workflow tells the user, in its messages, the JSON document and the report, and compares at the measured
    speed: the order view of the re-described record equals that of the right sidecar."""
    from compare.workflow import run, write_rig_files

    m = rig_measurement([{"name": "pitch_error", "grade": 6.0}], pair="spur-gds", duration_s=2.0)
    csv = write_rig_files(m, tmp_path)
    side = tmp_path / "rig.toml"
    text = side.read_text()
    side.write_text("\n".join(line for line in text.splitlines() if not line.startswith("tacho")))
    right = run(csv, attribution=False, json_path=tmp_path / "right.json", calibrate=False)
    side.write_text("\n".join(line if not line.startswith("speed_rpm") else "speed_rpm = 1150.0"
                              for line in text.splitlines() if not line.startswith("tacho")))
    off = run(csv, attribution=False, json_path=tmp_path / "off.json", report=tmp_path / "off.html", calibrate=False)
    doc = json.loads((tmp_path / "off.json").read_text())
    assert doc["measurement"]["speed_search_fraction"] == WIDE_SEARCH_FRACTION
    assert doc["measurement"]["speed_rpm"] == pytest.approx(1000.0, rel=SPEED_RTOL)
    assert json.loads((tmp_path / "right.json").read_text())["measurement"]["speed_search_fraction"] == SEARCH_FRACTION
    msg = [s for s in off.messages if "check speed_rpm" in s]
    assert len(msg) == 1 and "13.0 % below the sidecar's speed_rpm 1150" in msg[0]
    assert not any("check speed_rpm" in s for s in right.messages)
    assert "<b>Speed:</b>" in (tmp_path / "off.html").read_text()
    np.testing.assert_allclose(off.comparison.error_db["order"], right.comparison.error_db["order"], atol=0.05)
