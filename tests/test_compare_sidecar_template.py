"""A measurement without a sidecar: refused by name, and a template with the file's own channels is left beside it
(compare.sidecar_template); filled in, it loads the record; saved unfilled, it is refused naming the key."""
from __future__ import annotations

import re

import pytest

from compare.measurement import load_measurement
from gearpit.errors import InputError


def test_a_missing_sidecar_leaves_a_template_that_loads_the_record_once_filled(tmp_path):
    from compare.synthetic import rig_measurement
    from compare.workflow import write_rig_files

    m = rig_measurement(())
    csv = write_rig_files(m, tmp_path / "rig")
    csv.with_suffix(".toml").unlink()                     # a file as another rig delivers it: no sidecar
    with pytest.raises(InputError, match="a template with this file's channels was written") as err:
        load_measurement(csv)
    tpl = csv.with_name(csv.name + ".toml.template")
    assert str(tpl) in str(err.value) and tpl.is_file()
    text = tpl.read_text()
    assert 'sensor = ""' in text and '"acc_x"' in text and 'tacho = "tacho"' in text and "# fs_hz = 20000" in text
    side = csv.with_suffix(".toml")
    side.write_text(text)                                 # saved unfilled: refused by the key
    with pytest.raises(InputError, match="pair"):      # the first of the keys left unfilled
        load_measurement(csv)
    filled = re.sub(r"^speed_rpm = \S+", "speed_rpm = 1000.0", text, flags=re.M)
    filled = re.sub(r"^torque_nm = \S+", "torque_nm = 50.0", filled, flags=re.M)
    filled = re.sub(r'^pair = "[^"]*"', 'pair = "spur-gds"', filled, flags=re.M)
    filled = re.sub(r'^sensor = "[^"]*"', 'sensor = "acc_x"', filled, flags=re.M)
    side.write_text(filled)
    got = load_measurement(csv)
    assert got.sensor == "acc_x" and got.tacho == "tacho" and got.fs_hz == pytest.approx(m.fs_hz)
    assert got.n_samples == m.n_samples and got.speed_rpm == 1000.0


def test_no_template_over_an_existing_one_or_for_an_unreadable_file(tmp_path):
    bad = tmp_path / "x.csv"
    bad.write_text("a,b\n1,oops\n")
    with pytest.raises(InputError):
        load_measurement(bad)
    assert not (tmp_path / "x.csv.toml.template").exists()
    good = tmp_path / "y.csv"
    good.write_text("acc\n" + "\n".join(str(i % 7) for i in range(100)) + "\n")
    (tmp_path / "y.csv.toml.template").write_text("mine\n")
    with pytest.raises(InputError) as err:
        load_measurement(good)
    assert "template" not in str(err.value) and (tmp_path / "y.csv.toml.template").read_text() == "mine\n"


def test_the_template_takes_a_pulse_channel_for_the_tacho_not_a_speed_signal(tmp_path):
    """gearpit simulate's CSV holds speed_pinion_rpm (a speed) before tacho_pinion (pulses): the template named the
    speed signal as the tachometer; now the pulse channel."""
    import numpy as np

    from compare.sidecar_template import write_template

    csv = tmp_path / "case.csv"
    t = np.arange(2000) / 1e4
    np.savetxt(csv, np.column_stack([t, np.sin(t), 1000 + 0 * t, (np.mod(t * 16.7, 1) < 0.05).astype(float)]),
               delimiter=",", header="time_s,acc_pinion_loa_m_s2,speed_pinion_rpm,tacho_pinion", comments="")
    text = write_template(csv).read_text()
    assert 'tacho = "tacho_pinion"' in text and 'tacho = "speed_pinion_rpm"' not in text
