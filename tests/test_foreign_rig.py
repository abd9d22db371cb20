"""The independent simulator of tests/foreign_rig.py: checked against textbook values before the comparison is
checked against it (experiments/foreign_rig_check.py; the loop tests are at the end, slow)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import foreign_rig as fr


def _line_db(y: np.ndarray, fs_hz: float, f_hz: float, n: int) -> float:
    """Level (dB re 1) of the DFT line at f_hz over the first n samples (n a whole number of revolutions)."""
    spec = np.abs(np.fft.rfft(y[:n])) / n
    return 20 * math.log10(spec[int(round(f_hz * n / fs_hz))] + 1e-300)


def test_contact_ratio_matches_gearpit_geometry():
    """Source: the textbook contact ratio (path of contact / base pitch), computed here without gearpit, against
    datagen.geometry for the pair both use (spur-gds). Tolerance 1e-6 (same formula, two codes)."""
    from datagen.geometry import preset

    p = preset("spur-gds")
    assert fr.contact_ratio(fr.ForeignRig()) == pytest.approx(p.contact_ratio_transverse, abs=1e-6)


def test_mean_stiffness_near_iso_6336_and_static_deflection():
    """Source: ISO 6336-1 mesh stiffness c_gamma = (0.75 eps + 0.25) c' b (tolerance 10 %: the half-sine pair
    shape is ours), and the static limit: with no damping, errors or fluctuation the mean relative displacement of
    the steady state is F / k averaged over the mesh cycle, mean(F / k(t)) (tolerance 1 %: the dynamic part
    averages out over whole mesh cycles)."""
    rig = fr.ForeignRig(duration_s=0.3, snr_db=None, speed_rpm=300.0)
    g = fr.geometry(rig)
    eps = fr.contact_ratio(rig)
    out = fr.simulate_foreign(rig)
    k = out["k_n_per_m"]
    iso = (0.75 * eps + 0.25) * fr.C_PRIME * rig.face_width_m
    assert k.mean() == pytest.approx(iso, rel=0.10)          # measured 0.91 of it
    force = rig.torque_nm / g["rb1"]
    assert out["mesh_deflection_m"].mean() == pytest.approx(np.mean(force / k), rel=0.01)


def test_healthy_rig_has_no_shaft_sidebands_and_an_eccentric_one_has():
    """A healthy pair repeats every mesh cycle, so its pinion sidebands are numerical residue: at least 40 dB under
    the mesh line (measured 58 dB; a stiffness step quantised to the integration step put them 30 dB under it,
    which the RAMP removed). A 150 um pinion eccentricity raises them to within 15 dB of it (measured 8-11 dB)."""
    fs, rpm = 20000.0, 1000.0
    n = int(round(fs * 60 / rpm)) * 19                     # 19 whole revolutions
    f_r = rpm / 60
    f_m = 29 * f_r
    for ecc, lo, hi in ((0.0, None, -40.0), (150e-6, -15.0, None)):
        out = fr.simulate_foreign(fr.ForeignRig(duration_s=1.2, snr_db=None, eccentricity_m=(ecc, 0.0)))
        y = out["acc"]
        mesh = _line_db(y, fs, 5 * f_m, n)
        side = max(_line_db(y, fs, 5 * f_m + s * f_r, n) for s in (-1, 1))
        if hi is not None:
            assert side - mesh < hi, (ecc, side - mesh)
        if lo is not None:
            assert side - mesh > lo, (ecc, side - mesh)


def test_an_eccentric_wheel_starts_contact_early_without_a_stiffness_step():
    """Source: the path of contact a_w sin(alpha_w) minus the tip segments (Litvin & Fuentes 2004, ch. 10): a centre
    distance shortened by an eccentric wheel starts contact before the nominal start, so the pair there must
    be in the model from its own start on. When the rig's pair window began at the nominal start, that pair
    entered with up to a third of its stiffness at once, a step the integration grid quantised: a line at fm/2
    (the wheel's 50th order) 33 dB under the mesh line at 20 kHz, 36 and 42 dB at 40 and 80 kHz (it shrank with the
    step, so numerics, not physics). Now 58 dB under it (97 dB healthy); asserted: at least 50 dB."""
    rig = fr.ForeignRig(snr_db=None, eccentricity_m=(0.0, 50e-6))
    y = fr.simulate_foreign(rig)["acc"]
    w = np.hanning(y.size)
    spec = np.abs(np.fft.rfft(y * w))
    f = np.fft.rfftfreq(y.size, 1 / rig.fs_hz)
    f_m = rig.z1 * rig.speed_rpm / 60

    def level(fr_hz):
        return 20 * math.log10(spec[np.argmin(np.abs(f - fr_hz))])

    assert level(f_m / 2) - level(f_m) < -50.0


def test_housing_filter_is_a_unit_gain_base_excitation():
    """Source: the base-excited single-DOF transmissibility |H| = sqrt(1 + (2 z r)^2) / sqrt((1 - r^2)^2 +
    (2 z r)^2), r = f / f_h: near 1 far below the mode and ~1 / (2 z) at it. Checked on the record's mesh lines
    (ratio with / without the housing at f_m, 483 Hz, r = 0.16: within 0.5 dB of the formula; at 6 f_m, 2.9 kHz,
    r = 0.97: within 1.5 dB)."""
    fs, rpm, fh, z = 20000.0, 1000.0, 3000.0, 0.05
    n = int(round(fs * 60 / rpm)) * 19
    f_m = 29 * rpm / 60
    a = fr.simulate_foreign(fr.ForeignRig(duration_s=1.2, snr_db=None))["acc"]
    b = fr.simulate_foreign(fr.ForeignRig(duration_s=1.2, snr_db=None, housing=(fh, z)))["acc"]
    for k, tol in ((1, 0.5), (6, 1.5)):
        r = k * f_m / fh
        h = math.sqrt(1 + (2 * z * r) ** 2) / math.sqrt((1 - r * r) ** 2 + (2 * z * r) ** 2)
        assert _line_db(b, fs, k * f_m, n) - _line_db(a, fs, k * f_m, n) == pytest.approx(20 * math.log10(h), abs=tol)


# ---------------------------------------------------------------- the comparison on the foreign rig (slow)


def _first_comparison(seed=5, **rig):
    """The first comparison of the user's loop (default calibration "auto", every registered effect) on a 2 s
    record of the foreign rig (draws ``seed``), with gearpit's bare model."""
    from compare.comparison import prepare_reference
    from compare.escalation import compare_and_attribute
    from compare.model import ComparisonModel

    m = fr.foreign_measurement(fr.ForeignRig(seed=seed, duration_s=2.0, **rig))
    st = compare_and_attribute(m, ComparisonModel(), reference=prepare_reference(m))
    return st.comparison, st.attribution


@pytest.mark.slow
def test_foreign_speed_fluctuation_is_found_at_its_frequency():
    """Source: the foreign rig's truth (1 % kinematic speed fluctuation at 23 Hz; its mesh phase swings 2.1 rad at
    the 10th harmonic, so the +/-46 Hz sidebands outshine the +/-23 Hz ones). A fluctuation is claimed (the speed
    one or its load-side twin: the accelerometer cannot tell them apart, README), at 23 Hz within 5 %, halving
    the error (measured 71 %). Before compare.fitspace.fundamental_seed the seeds held no 23 Hz and the fit
    landed at 45.8 Hz."""
    c, a = _first_comparison(speed_fluctuation=(0.01, 23.0))
    claimed = a.claimed[0]
    assert claimed.effect in ("speed_fluctuation", "torque_fluctuation"), [(x.effect, x.reduction) for x in a.candidates]
    assert claimed.params["frequency_hz"] == pytest.approx(23.0, rel=0.05)
    assert claimed.reduction >= 0.5


@pytest.mark.slow
def test_foreign_pinion_eccentricity_is_found_and_a_bearing_defect_claims_no_fault():
    """Source: the foreign rig's truth. A 150 um pinion eccentricity: eccentricity_pinion claimed (on the band's
    record: or named the rival of a claimed pitch error, below), its fit within a factor 2 (the foreign model
    moves the path of contact, not the mesh timing; measured 84 um, 70 % on the former record). A bearing defect
    (impacts at 71.3 Hz ringing 3.9 kHz, no shaft order): no effect claimed but those that reshape the mesh
    harmonics, which two simulators' healthy pairs differ by (foreign_rig.MESH_SHAPE),
    and disagreements flagged unexplained."""
    c, a = _first_comparison(eccentricity_m=(150e-6, 0.0))
    claimed = a.claimed[0]
    # on the band's mesh record (stop 34 on; measured at stop 35 with both stop 34's and stop 35's code) a pitch
    # error whose tooth-to-tooth deviations follow once per revolution fits this rig as well: 0.689-0.695 against
    # the eccentricity's 0.679-0.692, within the rival margin (0.05), and the report names the eccentricity as
    # the claimed effect's rival. Asserted: claimed, or a named rival of the claimed pitch error
    assert claimed.effect == "eccentricity_pinion" or (claimed.effect == "pitch_error"
                                                       and "eccentricity_pinion" in a.rivals), \
        ([(x.effect, x.reduction) for x in a.candidates], a.rivals)
    own = next(x for x in a.candidates if x.effect == "eccentricity_pinion")
    assert 0.5 <= own.params["amplitude_m"] / 150e-6 <= 2.0, own.params
    c, a = _first_comparison(bearing_defect=(71.3, 3900.0, 40.0))
    assert all(x.effect in fr.MESH_SHAPE for x in a.claimed), [(x.effect, x.reduction) for x in a.claimed]
    assert a.unexplained


@pytest.mark.slow
def test_foreign_random_walk_pitch_error_is_claimed_as_a_pinion_error_not_a_fluctuation_on_its_order():
    """Source: the foreign rig's truth (seed 6: a random-walk cumulative pitch error of the pinion, F_p = 40 um,
    whose first order is a once-per-revolution error of the pinion, as an eccentricity's is). Before
    compare.candidates.shaft_locked_twin a torque fluctuation of 75 % at 16.67 Hz, the pinion's rotation, was
    claimed (66.5 %) over the pinion eccentricity (64.3 %, on its 200 um bound). Now a once-per-revolution error
    of the pinion is claimed, halving the error (measured 64.3 %), the fluctuation is named its rival and the
    claim says why."""
    c, a = _first_comparison(seed=6, pitch_fp_m=40e-6)
    claimed = a.claimed[0]
    assert claimed.effect in ("eccentricity_pinion", "pitch_error"), [(x.effect, x.reduction) for x in a.candidates]
    assert "pinion" in claimed.shaft_lock["shafts"]
    assert claimed.reduction >= 0.5
    over = claimed.claimed_over
    assert over is not None and over["rule"] == "shaft_locked", over
    fluct = next(x for x in a.candidates if x.effect == over["effect"])
    assert fluct.effect in ("speed_fluctuation", "torque_fluctuation") and fluct.reduction > claimed.reduction
    assert fluct.shaft_lock == {"kind": "fluctuation", "shaft": "pinion", "order": 1}
    assert fluct.effect in a.rivals and "pinion's rotation" in a.claim_order
