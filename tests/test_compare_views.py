"""Views, residuals and the scalar error on synthetic gear signals written in numpy (compare.views, compare.error,
compare.speed, compare.comparison.evaluate, compare.disagreements).

Reference: the definitions in compare/error.py (error = weighted RMS of floored dB residuals after a fitted gain)
and compare/views.py (named locations). Signals: mesh harmonics of a 29/100 pair (spur-gds) at 1200 rpm with
amplitude modulation, white noise; all exact, so every expectation below follows from the definitions.
"""
from __future__ import annotations

import numpy as np
import pytest

from compare.comparison import evaluate, prepare_reference
from compare.disagreements import rank_disagreements
from compare.measurement import Sidecar, measurement_from_arrays
from compare.speed import speed_from_spectrum, speed_from_tacho

FS = 12800.0
RPM = 1200.0
Z1, Z2 = 29, 100
DUR = 2.0


def gear_record(*, rpm=RPM, sideband=0.0, tone_hz=None, am_hz=None, noise=0.02, seed=0, n=int(FS * DUR)):
    """Mesh harmonics 1..3 of the pinion, a pinion 1x modulation, optional fm + 1 fr_wheel sideband, a tone at
    ``tone_hz``, an amplitude modulation at ``am_hz``; and a once-per-revolution tacho."""
    t = np.arange(n) / FS
    th = 2 * np.pi * rpm / 60 * t
    thw = th * Z1 / Z2
    x = np.zeros(n)
    for m, a in ((1, 1.0), (2, 0.5), (3, 0.3)):
        x += a * np.cos(m * Z1 * th) * (1 + 0.1 * np.cos(th))
    x += sideband * np.cos(Z1 * th + thw)
    if tone_hz:
        x += 0.2 * np.cos(2 * np.pi * tone_hz * t)
    if am_hz:
        x *= 1 + 0.3 * np.cos(2 * np.pi * am_hz * t)
    x += noise * np.random.default_rng(seed).standard_normal(n)
    tacho = (np.mod(th, 2 * np.pi) < 0.5).astype(float)
    return x, tacho


def measured(x, tacho=None, nominal=RPM * 1.01):
    sc = Sidecar.from_dict({"pair": "spur-gds", "speed_rpm": nominal, "torque_nm": 10.0, "fs_hz": FS,
                            "sensor": "acc", **({"tacho": "tacho"} if tacho is not None else {})})
    ch = {"acc": x} if tacho is None else {"acc": x, "tacho": tacho}
    return measurement_from_arrays(ch, sc)


@pytest.fixture(scope="module")
def base():
    x, k = gear_record()
    return x, prepare_reference(measured(x, k))


def test_identical_signals_give_zero_error(base):
    """Model record = measured record: every residual, the gain and the total error are 0 (to 1e-9 dB)."""
    x, ref = base
    ev = evaluate(ref, x, FS)
    assert ev.residuals.gain_db == pytest.approx(0.0, abs=1e-9)
    assert np.max(np.abs(ev.residuals.residual_db)) < 1e-9
    assert ev.total_db < 1e-9


@pytest.mark.parametrize("factor", [7.3, 1e6, 1e-3])
def test_unknown_gain_is_fitted_not_assumed(base, factor):
    """A model ``factor`` times too small: gain fitted to 20 log10(factor) (to 0.01 dB), error still 0 (to 1e-6).
    1e6: a model channel in metres against a measurement in micrometres (a transmission error from encoders): no
    level may be floored at an absolute value (the record RMS once was, at -60 dB)."""
    x, ref = base
    ev = evaluate(ref, x / factor, FS)
    assert ev.residuals.gain_db == pytest.approx(20 * np.log10(factor), abs=0.01)
    assert ev.total_db < 1e-6


def test_error_grows_with_mismatch_and_names_the_sideband():
    """The measurement carries an fm + 1 fr_wheel sideband the model lacks: the error rises strictly with its
    amplitude (0.003 .. 0.3), and the largest disagreement is that line, measured higher."""
    x0, k = gear_record()
    errors = []
    for a in (0.003, 0.01, 0.03, 0.1, 0.3):
        xm, _ = gear_record(sideband=a)
        ref = prepare_reference(measured(xm, k))
        ev = evaluate(ref, x0, FS)
        errors.append(ev.total_db)
    assert all(b > a for a, b in zip(errors, errors[1:])), errors
    top = rank_disagreements(ref, ev)[0]
    assert top.label == "fm + 1 fr_wheel" and top.residual_db > 20
    assert top.text.startswith("fm + 1 fr_wheel: measured +")


def test_content_at_no_order_is_reported_as_such():
    """A 61.3 Hz tone (3.07 x fr_pinion) and a 0.43 x fr_pinion amplitude modulation in the measurement only:
    found as a 'line at 61.3 Hz ... not a shaft order' (band view; peak interpolated between bins) and an
    'envelope line at 0.43 x fr_pinion: not a shaft order' (envelope view)."""
    fr = RPM / 60
    xm, k = gear_record(tone_hz=61.3, am_hz=0.43 * fr)
    x0, _ = gear_record()
    ref = prepare_reference(measured(xm, k))
    dis = rank_disagreements(ref, evaluate(ref, x0, FS))
    texts = [d.text for d in dis]
    assert any("line at 61.3 Hz" in t and "not a shaft order" in t for t in texts), texts
    assert any("envelope line at 0.43 x fr_pinion: not a shaft order" in t for t in texts), texts


def test_noise_floor_is_matched_not_compared():
    """Measurement = clean record + white noise (sigma 0.05), model = the clean record x 0.5 (gain 2): noise of
    sigma 0.05 / 2 = 0.025 (model units) is added to the model (within 15 %); the total error stays below 1 dB
    (what is left is two different noise draws, mostly in the higher moments M6A/M8A)."""
    xm, k = gear_record(noise=0.05, seed=1)
    x0, _ = gear_record(noise=0.0)
    ref = prepare_reference(measured(xm, k))
    ev = evaluate(ref, 0.5 * x0, FS, seed=5)
    assert ev.noise_added_rms == pytest.approx(0.025, rel=0.15)
    assert ev.total_db < 1.0


def test_speed_refined_from_tacho_and_from_spectrum():
    """Nominal 2 % off: the tacho and the mesh harmonics both recover 1187.3 rpm to 1e-4 relative."""
    true = 1187.3
    x, k = gear_record(rpm=true)
    a = speed_from_tacho(k, FS, z_pinion=Z1, z_wheel=Z2, nominal_rpm=true * 1.02)
    b = speed_from_spectrum(x, FS, z_pinion=Z1, nominal_rpm=true * 1.02)
    assert a.speed_rpm == pytest.approx(true, rel=1e-4)
    assert b.speed_rpm == pytest.approx(true, rel=1e-4)
    assert (a.method, b.method) == ("tacho", "spectrum")


def test_noise_scatter_of_line_residuals_matches_monte_carlo():
    """compare.error step 5: the predicted scatter ``sigma_i`` of an order-view residual between two records of
    the same vibration with independent noise, against Monte Carlo (6 noise draws of one clean record, the 15
    pairs compared as measurement and model). Source: first-order variance of a line plus complex Gaussian
    noise in one bin, mapped through the floor power sum of step 3. Tolerance: pooled RMS within a factor 2 in
    each SNR band (measured ratios 0.68 for bins of noise only, where the floor estimate and the larger of two
    bins bias the level, 0.75-1.3 above 15 dB)."""
    import itertools

    from compare.error import noise_scatter_db, residuals
    from compare.views import analyse

    x0, k = gear_record(noise=0.0)
    checked = 0
    for noise in (0.01, 0.1):
        rng = np.random.default_rng(11)
        draws = [x0 + noise * rng.standard_normal(x0.size) for _ in range(6)]
        ref = prepare_reference(measured(draws[0], k))
        plan = ref.plan
        views = [ref.views] + [analyse(d, FS, ref.speed.track, plan) for d in draws[1:]]
        r = np.array([residuals(a, b, plan).residual_db for a, b in itertools.combinations(views, 2)])
        emp = np.sqrt(np.mean(r ** 2, axis=0))
        pred = noise_scatter_db(ref.views, plan)
        snr = ref.views.levels - ref.views.floors
        order = plan.view_index("order")
        assert np.all(np.isnan(pred[plan.view_index("stats")])) and np.all(np.isnan(pred[plan.view_index("band")]))
        for lo, hi in ((-np.inf, 5.0), (15.0, 35.0), (35.0, np.inf)):
            sel = order[(snr[order] >= lo) & (snr[order] < hi)]
            if sel.size < 3:
                continue
            ratio = np.sqrt(np.mean(emp[sel] ** 2) / np.mean(pred[sel] ** 2))
            assert 0.5 <= ratio <= 2.0, (noise, lo, hi, ratio)
            checked += 1
    assert checked >= 4


def test_reliability_weights_are_off_by_default(base):
    """compare.error step 5, "Status": by default every residual has reliability 1, so the weights used are the
    group weights and the headline error is the one the hidden-effect table was measured with."""
    from compare.error import MODEL_TOLERANCE_DB, location_weights

    x, ref = base
    assert MODEL_TOLERANCE_DB is None
    np.testing.assert_array_equal(evaluate(ref, 0.5 * x, FS).residuals.weights, location_weights(ref.plan))


def test_reliability_weights_depend_on_the_measurement_only(base, monkeypatch):
    """Switched on (s0 = the recommended 0.5 dB), the weights of compare.error step 5 are the measurement's: two
    different models are measured with the same weights (so E stays one fixed weighted RMS of the residuals), a
    clean mesh harmonic outweighs a sideband location that holds only noise by more than 5x (1 against
    0.14-0.18), and the group weights are unchanged outside the line views."""
    import compare.error
    from compare.error import location_weights

    monkeypatch.setattr(compare.error, "MODEL_TOLERANCE_DB", compare.error.RECOMMENDED_TOLERANCE_DB)
    x, ref = base
    x2, _ = gear_record(sideband=0.05, seed=3)
    w1 = evaluate(ref, 0.5 * x, FS).residuals.weights
    w2 = evaluate(ref, x2, FS).residuals.weights
    np.testing.assert_array_equal(w1, w2)
    g = location_weights(ref.plan)
    labels = [loc.label for loc in ref.plan.locations]
    fm = labels.index("fm")
    noise_only = [i for i, loc in enumerate(ref.plan.locations)
                  if loc.view == "order" and loc.group == "wheel sidebands"
                  and ref.views.levels[i] - ref.views.floors[i] < 3.0]
    assert noise_only
    assert (w1[fm] / g[fm]) > 5 * max(w1[i] / g[i] for i in noise_only)
    for view in ("band", "tsa", "stats"):
        idx = ref.plan.view_index(view)
        np.testing.assert_array_equal(w1[idx], g[idx])


def test_levels_are_read_where_each_location_says(base):
    """compare.views.analyse reads every location through index arrays made once per plan; here each line
    location is read again the plain way, one by one from the curves it returns (pinion-spectrum lines, bands,
    lines at no order, envelope lines), including a tone off the bin grid. Reference: the reading rules of the
    module docstring (a line at a fractional bin: the larger of the two bins around it; a line found at no order:
    the largest of three bins; a band: the mean power of its non-order bins). Tolerance: exact (same floats)."""
    from compare.spectra import db, non_order
    from compare.speed import constant_track
    from compare.views import _band_bins, analyse

    x, k = gear_record(tone_hz=611.3)
    ref = prepare_reference(measured(x, k))
    plan = ref.plan
    track = constant_track(len(x), FS, ref.speed.fr_pinion_hz)
    v = analyse(0.7 * x, FS, track, plan, keep_curves=True)
    pp, env = v.curves["order_power"], v.curves["envelope_power"]
    no_order = non_order(pp.size, plan)

    def at(p, b):
        if abs(b - round(b)) < 1e-6:
            return p[int(round(b))]
        return max(p[int(np.floor(b))], p[min(int(np.floor(b)) + 1, p.size - 1)])

    checked = {"order": 0, "line": 0, "band": 0, "envelope": 0}
    for i, loc in enumerate(plan.locations):
        view, name = loc.key.split(":", 1)
        if view == "order" and "wheel" not in name:
            want, kind = at(pp, loc.order_pinion * plan.n_revs), "order"
        elif view == "band" and name.startswith("line"):
            i0 = int(round(loc.freq_hz / plan.bin_hz))
            want, kind = pp[max(i0 - 1, 0):i0 + 2].max(), "line"
        elif view == "band":
            lo, hi = _band_bins(loc, plan)
            sel = no_order[lo:hi]
            want, kind = (pp[lo:hi][sel] if sel.any() else pp[lo:hi]).mean(), "band"
        elif view == "envelope" and not name.startswith("line"):
            want, kind = at(env, loc.order_pinion * plan.n_revs), "envelope"
        else:
            continue
        assert v.levels[i] == db(want), loc.key
        checked[kind] += 1
    assert min(checked.values()) >= 1, checked
    assert any(loc.key.startswith("band:line") for loc in plan.locations)


def test_a_sensor_offset_leaves_every_view_unchanged():
    """An offset on the record (an accelerometer's bias, 10 x the signal's RMS) carries nothing of the gears, and
    every view is of the mean-removed record, so none may move. Before the angle records kept out of the record's
    edges (compare.spectra.usable_revolutions), the upsampling filter's ring at the edges, in proportion to the
    end values, moved the wheel TSA's M8A by 41 dB and FM4 by 12 dB on this nearly noise-free record (noise 1e-4).
    Tolerance 0.05 dB (measured 0.013, the pinion TSA's M8A: a moment of order 8 of a nearly noise-free
    difference signal)."""
    from compare.views import analyse

    x, k = gear_record(noise=1e-4)
    ref = prepare_reference(measured(x, k))
    a = analyse(x, FS, ref.speed.track, ref.plan)
    b = analyse(x + 10.0, FS, ref.speed.track, ref.plan)
    assert np.max(np.abs(a.levels - b.levels)) < 0.05
