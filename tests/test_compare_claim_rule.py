"""The claim rule of the attribution (compare.candidates): which fitted candidate is claimed, and which are its rivals.

Reference: the issue's "flag disagreements that no registered effect explains instead of forcing an attribution".
The rule is tested on candidate results built by hand from measured cases (the numbers in each docstring), and
its noise threshold against the simulator's truth: the right model (the rig's own drive train) agrees with a
rig within the noise, a hidden effect does not. The end-to-end controls that found the two newer conditions
(a healthy rig at 10 dB SNR, one at 3000 rpm) are slow tests in tests/test_compare_attribution.py.
"""
from __future__ import annotations

import pytest

from compare.comparison import compare
from compare.model import ComparisonModel
from compare.synthetic import HIDDEN_EXAMPLES, NUISANCE, rig_measurement


def test_claim_needs_the_reduction_and_no_view_traded():
    """choose_claim: the best candidate above the claim threshold whose views all stay within
    max_view_rise_db of the baseline's; a candidate that fits one view by spoiling another (the mains-hum
    case: band 7.1 -> 3.1 dB, order 0.7 -> 3.3 dB) is passed over; nothing below the threshold is claimed."""
    from compare.candidates import AttributionSettings, CandidateResult, choose_claim

    base = {"order": 0.66, "band": 7.07, "envelope": 0.68}

    def cand(name, total, views):
        return CandidateResult(name, "", {}, {}, total, 3.19, dict(views), "2 s", 1, baseline_view_error_db=base)

    settings = AttributionSettings()
    trader = cand("transmission_path", 2.19, {"order": 3.26, "band": 3.07, "envelope": 0.40})
    honest = cand("pitch_error", 2.20, {"order": 0.60, "band": 3.30, "envelope": 0.60})
    weak = cand("tip_relief", 3.10, {"order": 0.60, "band": 6.90, "envelope": 0.60})
    assert trader.worst_view_rise_db == pytest.approx(2.60) and honest.worst_view_rise_db <= 0.0
    ranked = sorted([trader, weak], key=lambda c: -c.reduction)
    assert choose_claim(ranked, settings) is None and not any(c.claimed for c in ranked)
    ranked = sorted([cand("transmission_path", 2.19, trader.view_error_db), honest, weak], key=lambda c: -c.reduction)
    assert [c.effect for c in ranked][:2] == ["transmission_path", "pitch_error"]     # the trader ranks first
    assert choose_claim(ranked, settings).effect == "pitch_error" and not ranked[0].claimed
    # the same trade within the allowed rise is claimed
    assert choose_claim([trader], AttributionSettings(max_view_rise_db=3.0)).effect == "transmission_path"
    # a large gain may leave a view a little above a baseline at its noise floor (the calibrated helical rig of
    # experiments/generalisation_check.py: total 6.86 -> 1.52 dB, stats 0.00 -> 1.18 dB): allowed rise
    # max(1, 0.25 x 5.34) = 1.34 dB; the same rise with only the trader's 1 dB gain is refused
    big = {"order": 2.26, "envelope": 10.07, "tsa": 11.35, "stats": 0.0}
    strong = CandidateResult("pitch_error", "", {}, {}, 1.52, 6.86, {"order": 0.67, "envelope": 2.53, "tsa": 1.83,
                                                                     "stats": 1.18}, "2 s", 1, baseline_view_error_db=big)
    assert choose_claim([strong], settings).effect == "pitch_error"
    small_gain = CandidateResult("pitch_error", "", {}, {}, 2.19, 3.19, {"order": 0.5, "band": 3.0, "envelope": 1.86},
                                 "2 s", 1, baseline_view_error_db=base)
    assert small_gain.worst_view_rise_db == pytest.approx(1.18) and choose_claim([small_gain], settings) is None


def test_nothing_is_claimed_against_a_baseline_that_agrees_within_the_noise():
    """compare.candidates, min_excess_to_noise and min_explained_to_noise (1): a candidate that removes 46 % of an
    excess error of 0.03 dB against a noise error of 0.8 dB (a healthy rig at 10 dB SNR after calibration, where a
    housing mode was claimed before the rule) is not claimed, nor is a rival. A baseline 1.5 noise errors above
    the noise is beyond it, but a candidate must also take more than the noise error off: 47 % of 1.2 dB (0.56 dB)
    is not claimed, 60 % of 1.6 dB (0.96 dB) is. The healthy helical rig of experiments/unseen_rigs_check.py
    (band's mesh record, measured): excess 1.21 dB, noise 1.18 dB, a profile error claimed at 58.2 % (0.71 dB off)
    before the second rule; the suite's weakest hidden effect, the Hertz stiffness at 5 N m (1.50 dB, 75.1 %,
    noise 0.64 dB), is claimed. Without a measured noise error neither rule applies."""
    from compare.candidates import AttributionSettings, CandidateResult, choose_claim, rivals_of, within_noise
    from compare.error import VIEWS

    noise = {v: 0.8 for v in VIEWS}

    def cand(name, total, baseline, noise_view_db):
        return CandidateResult(name, "", {}, {}, total, baseline, {v: total for v in VIEWS}, "2 s", 1,
                               baseline_view_error_db={v: baseline for v in VIEWS}, noise_view_db=noise_view_db)

    settings = AttributionSettings()
    quiet = [cand("transmission_path", 0.016, 0.03, noise), cand("profile_error", 0.017, 0.03, noise)]
    assert quiet[0].reduction > 0.45 and within_noise(0.03, 0.8, settings)
    assert choose_claim(quiet, settings) is None and rivals_of(quiet[0], quiet, settings) == []
    loud = cand("transmission_path", 0.64, 1.2, noise)                   # 1.5 N, 47 % off: 0.56 dB < N
    assert not within_noise(1.2, 0.8, settings) and choose_claim([loud], settings) is None
    louder = cand("transmission_path", 0.64, 1.6, noise)                 # 2 N, 60 % off: 0.96 dB > N
    assert choose_claim([louder], settings) is louder
    helical = cand("profile_error", 1.214 * (1 - 0.582), 1.214, {v: 1.182 for v in VIEWS})
    assert not within_noise(1.214, 1.182, settings) and choose_claim([helical], settings) is None
    hertz = cand("hertz_nonlinear", 1.50 * (1 - 0.751), 1.50, {v: 0.64 for v in VIEWS})
    assert choose_claim([hertz], settings) is hertz
    assert choose_claim([cand("transmission_path", 0.016, 0.03, {})], settings).effect == "transmission_path"
    assert not within_noise(0.03, 0.0, settings)


def test_a_time_stepped_claim_must_lower_the_error_of_the_model_as_compared():
    """compare.candidates, model_error_db: the healthy spur rig at 3000 rpm (measured): the time-stepped baseline
    at the attribution's coarse step has an excess error of 1.73 dB where the comparison (periodic path) has
    0.50 dB; a speed fluctuation took the former to 0.75 dB (57 %) and was claimed. It is not any more: 0.75 dB
    is not 30 % below 0.50 dB. A candidate that ends at 0.30 dB (40 % below the comparison) still is; periodic
    candidates (model_error_db NaN) are not checked."""
    from compare.candidates import AttributionSettings, CandidateResult, choose_claim
    from compare.error import VIEWS

    noise = {v: 0.55 for v in VIEWS}

    def cand(total, model_error_db=float("nan")):
        return CandidateResult("speed_fluctuation", "", {}, {}, total, 1.73, {v: total for v in VIEWS}, "1 s", 1,
                               baseline_view_error_db={v: 1.73 for v in VIEWS}, noise_view_db=noise,
                               model_error_db=model_error_db)

    settings = AttributionSettings()
    assert cand(0.75, 0.50).reduction > 0.5 and choose_claim([cand(0.75, 0.50)], settings) is None
    assert choose_claim([cand(0.30, 0.50)], settings) is not None
    assert choose_claim([cand(0.75)], settings) is not None
    assert cand(0.75, 0.50).to_dict()["model_error_db"] == 0.50 and cand(0.75).to_dict()["model_error_db"] is None


def test_the_right_model_agrees_within_the_noise_and_a_hidden_effect_does_not():
    """The null distribution under min_excess_to_noise. Source: the simulator's truth: with the rig's own drive
    train (compare.synthetic.NUISANCE) as the model, the rig differs from it by the noise draw, the sensor gain
    (fitted) and the speed (refined), so its excess error X is noise scatter: measured X / N 0-0.78 on 40 of 42
    draws (four rigs, 10-40 dB SNR; 1.3 and 2.2 once each). Asserted on the rig of the 10 dB false claim (1500
    rpm, 80 N m, 1.5 s, seeds 3-8): X < N on at least 5 of 6 draws (a broken noise correction or a bias of the
    gain fit would put X above N), and the hidden pitch error of the examples at X > 3 N."""
    from compare.candidates import AttributionSettings, within_noise

    model = ComparisonModel().with_drivetrain(NUISANCE)
    settings = AttributionSettings()
    agree = []
    for seed in range(3, 9):
        m = rig_measurement((), seed=seed, snr_db=10.0, speed_rpm=1500.0, torque_nm=80.0, fs_hz=25600.0,
                            duration_s=1.5)
        r = compare(m, model, seed=seed).evaluation.residuals
        agree.append(within_noise(r.excess_total_db, r.noise_total_db, settings))
    assert sum(agree) >= 5, agree
    ex = HIDDEN_EXAMPLES["pitch_error"]
    r = compare(rig_measurement((ex.effect,), duration_s=1.0), model).evaluation.residuals
    assert r.excess_total_db > 3 * r.noise_total_db, (r.excess_total_db, r.noise_total_db)


def test_rivals_are_the_effects_the_views_cannot_tell_from_the_claim():
    """rivals_of: effects that pass the claim rule within rival_reduction (5 %) of the claimed one's reduction
    (the calibrated helical rig of experiments/generalisation_check.py: a hidden speed fluctuation, torque
    fluctuation 75.8 % against speed fluctuation 75.x %). A close candidate that trades views, or one 6 % behind,
    or one not confirmed on the whole record, is no rival; nothing claimed -> no rivals."""
    from compare.candidates import AttributionSettings, CandidateResult, choose_claim, rivals_of

    base = {"order": 10.0, "envelope": 8.0}

    def cand(name, total, views, status="fitted"):
        return CandidateResult(name, "", {}, {}, total, 10.0, dict(views), "2 s", 1, baseline_view_error_db=base,
                               status=status)

    settings = AttributionSettings()
    torque = cand("torque_fluctuation", 2.42, {"order": 2.5, "envelope": 2.3})
    speed = cand("speed_fluctuation", 2.50, {"order": 2.6, "envelope": 2.4})           # 0.8 % behind
    far = cand("backlash", 3.10, {"order": 3.2, "envelope": 3.0})                      # 6.8 % behind
    trader = cand("transmission_path", 2.45, {"order": 0.1, "envelope": 11.0})         # close, but trades views
    stale = cand("hertz_nonlinear", 2.44, {"order": 2.4, "envelope": 2.4}, status="not confirmed on the whole record")
    ranked = sorted([speed, far, trader, stale, torque], key=lambda c: -c.reduction)
    claimed = choose_claim(ranked, settings)
    assert claimed is torque
    assert rivals_of(claimed, ranked, settings) == ["speed_fluctuation"]
    assert rivals_of(claimed, ranked, AttributionSettings(rival_reduction=0.07)) == ["speed_fluctuation", "backlash"]
    assert rivals_of(None, ranked, settings) == []


def test_a_rival_fitted_inside_its_range_is_claimed_before_one_pinned_on_a_bound():
    """choose_claim / interior_rival, on the numbers of the independent simulator (tests/foreign_rig.py, 23/61
    teeth, module 3 mm, 1500 rpm, a pinion eccentricity of 100 um; `gearpit compare` from the bare model): the
    pinion's pitch error fitted at grade 12, the upper bound of its search, with the error still falling towards
    it, took 71.4 % off the error, the pinion eccentricity 71.2 % at 150 um, inside its range. The eccentricity is
    claimed and put first, the pitch error stays its rival. Not moved: a pinned candidate without a rival within
    5 %, a rival that is pinned too, and a parameter on a bound that the error does not depend on."""
    from compare.candidates import AttributionSettings, CandidateResult, choose_claim, rivals_of
    from compare.fitspace import bounds_hit, fit_space
    from datagen.effects import get

    base = {"order": 15.97, "envelope": 22.40}

    def cand(name, total, params, rises=None):
        c = CandidateResult(name, "", dict(params), {}, total, 16.49, {"order": total, "envelope": total},
                            "2 s", 1, baseline_view_error_db=base)
        c.at_bound = bounds_hit(fit_space(get(name)), c.params)
        c.rises_off_bound = dict(rises or {})
        return c

    settings = AttributionSettings()
    pitch = cand("pitch_error", 4.72, {"grade": 12.0, "gears": "pinion"}, {"grade": "upper"})
    ecc = cand("eccentricity_pinion", 4.74, {"amplitude_m": 150e-6})
    torque = cand("torque_fluctuation", 7.17, {"frequency_hz": 25.0, "amplitude_fraction": 0.68})
    assert pitch.at_bound == {"grade": "upper"} and pitch.pinned == ["grade"]
    assert ecc.at_bound == {} and ecc.pinned == []
    ranked = [pitch, ecc, torque]
    claimed = choose_claim(ranked, settings)
    assert claimed is ecc and ranked[0] is ecc and not pitch.claimed
    assert rivals_of(claimed, ranked, settings) == ["pitch_error"]
    # the same pinned fit 6 % ahead of the interior one: no rival, the pinned fit is claimed (and stays first)
    pitch6 = cand("pitch_error", 3.75, {"grade": 12.0, "gears": "pinion"}, {"grade": "upper"})
    ranked = [pitch6, cand("eccentricity_pinion", 4.74, {"amplitude_m": 150e-6})]
    assert choose_claim(ranked, settings) is pitch6 and ranked[0] is pitch6
    # both pinned: the better one is claimed
    pitch_b = cand("pitch_error", 4.72, {"grade": 12.0, "gears": "pinion"}, {"grade": "upper"})
    ecc_b = cand("eccentricity_pinion", 4.74, {"amplitude_m": 200e-6}, {"amplitude_m": "upper"})
    assert ecc_b.pinned == ["amplitude_m"]
    assert choose_claim([pitch_b, ecc_b], settings) is pitch_b
    # on the bound, but the error does not rise off it (or rises off the other bound): not pinned
    for rises in ({}, {"grade": "lower"}):
        loose = cand("pitch_error", 4.72, {"grade": 12.0, "gears": "pinion"}, rises)
        assert loose.at_bound == {"grade": "upper"} and loose.pinned == []
        assert choose_claim([loose, cand("eccentricity_pinion", 4.74, {"amplitude_m": 150e-6})], settings) is loose


def test_rises_off_bound_tells_a_fit_the_bound_stops_from_a_parameter_that_does_not_matter():
    """compare.fitting.rises_off_bound on search trials built by hand (the pitch error's grade, searched on
    [1, 12]): error falling towards grade 12 -> pinned at "upper"; a flat profile (the parameter does not matter),
    or a best trial inside the range -> nothing; a rise smaller than 5 % of what the effect explains -> nothing.
    The measured case: the wheel's pitch error on the foreign simulator (seed 5, wheel eccentricity 50 um) ended
    at grade 12 with an infinite 1-sigma, as a parameter the error does not depend on has."""
    from compare.fitspace import fit_space
    from compare.fitting import rises_off_bound
    from compare.search import Search
    from datagen.effects import get

    def search(errors_by_grade):
        s = Search(get("pitch_error"), fit_space(get("pitch_error")))
        for g, e in errors_by_grade.items():
            t = s.point({"grade": g})
            t.error_db = e
            s.trials.append(t)
        return s

    baseline = 12.0      # raw dB; the effect explains 12 - 6 = 6 dB
    falling = search({3.0: 10.0, 6.0: 8.5, 9.0: 7.2, 11.0: 6.6, 12.0: 6.0})
    assert rises_off_bound(falling, falling.best, baseline) == {"grade": "upper"}
    flat = search({3.0: 6.0, 6.0: 6.0, 9.0: 6.0, 11.0: 6.0, 12.0: 6.0})
    assert rises_off_bound(flat, flat.best, baseline) == {}
    inside = search({3.0: 10.0, 6.0: 8.5, 9.0: 6.0, 11.0: 6.6, 12.0: 7.0})
    assert rises_off_bound(inside, inside.best, baseline) == {}
    small = search({3.0: 6.2, 6.0: 6.2, 11.0: 6.2, 12.0: 6.0})      # 0.2 dB < 5 % of 6 dB
    assert rises_off_bound(small, small.best, baseline) == {}


def test_bounds_hit_reads_the_search_coordinate_of_every_registered_effect():
    """compare.fitspace.bounds_hit: a fitted value at either end of its search (on a log scale the lower end is
    hi / 1000, where the search starts) is on a bound, one a step of the default grid inside is not; for every
    registered effect's fitted parameters."""
    from compare.fitspace import bounds_hit, fit_space, grid
    from datagen.effects import get, names

    checked = 0
    for n in names():
        space = fit_space(get(n))
        for p in space.params:
            lo_u, hi_u = float(p.from_u(0.0)), float(p.from_u(1.0))
            assert bounds_hit(space, {p.name: lo_u}) == {p.name: "lower"}, (n, p.name)
            assert bounds_hit(space, {p.name: hi_u}) == {p.name: "upper"}, (n, p.name)
            inner = grid(p)
            assert bounds_hit(space, {p.name: float(inner[0])}) == {}, (n, p.name)
            assert bounds_hit(space, {p.name: float(inner[-1])}) == {}, (n, p.name)
            checked += 1
        assert bounds_hit(space, {"gears": "pinion"}) == {}
    assert checked >= 10


def test_a_claim_whose_amount_the_record_does_not_bound_escalates():
    """compare.escalation.escalation_reason, on candidates built from the backlash example (30 um, 2 N m; band's
    mesh record, seed 3): as written backlash is claimed at 60 % but its whole-record ladder ends on a plateau,
    [89 um, open] ('unbounded': calibrate and attribute again); the same claim with a closed interval explains the
    mismatch; below the explained reduction it is 'unexplained'; a second claim that is bounded explains it."""
    from compare.candidates import Attribution, CandidateResult
    from compare.escalation import escalation_reason, explains, reason_text

    def cand(name, error_db, interval=None):
        return CandidateResult(name, "", {"backlash_m": 126e-6}, {}, error_db, 4.14, {"order": error_db}, "2 s", 1,
                               claimed=True, interval=dict(interval or {}))

    def att(*cands):
        return Attribution(list(cands), [], 0.0, 0)

    open_ = cand("backlash", 1.65, {"backlash_m": (89e-6, None)})
    assert open_.reduction == pytest.approx(0.60, abs=0.01)
    assert escalation_reason(att(open_)) == "unbounded" and not explains(att(open_))
    closed = cand("backlash", 1.65, {"backlash_m": (22e-6, 45e-6)})
    assert escalation_reason(att(closed)) is None and explains(att(closed))
    weak = cand("backlash", 2.40, {"backlash_m": (22e-6, 45e-6)})
    assert escalation_reason(att(weak)) == "unexplained"
    bounded = cand("pitch_error", 1.80)      # a periodic fit: no ladder, no interval
    assert escalation_reason(att(open_, bounded)) is None
    doc = {"reason": "unbounded", "explained_reduction": 0.5,
           "as_written_best": {"effect": "backlash", "reduction": 0.6, "claimed": True}}
    assert "does not bound its amount" in reason_text(doc)
    assert "no claimed effect explains 50 %" in reason_text({**doc, "reason": "unexplained"})


def test_a_once_per_revolution_error_is_claimed_before_a_fluctuation_fitted_onto_its_shaft_order():
    """choose_claim / shaft_locked_twin, on the numbers of the independent simulator (tests/foreign_rig.py, seed 6,
    spur-gds at 1000 rpm, a random-walk pinion pitch error of F_p = 40 um, whose family is the pinion's
    once-per-revolution errors; 2 s record, 0.5 Hz resolution): a torque fluctuation of 75 % fitted at 16.667 Hz,
    the pinion's rotation, took 66.5 % off the 17.56 dB error, the pinion eccentricity 64.3 % on its 200 um bound
    (pinned), the pitch error 52.5 %. The eccentricity is claimed and put first, the fluctuation stays its rival and
    the claim says why. Not moved: a fluctuation off every shaft order (37 Hz), an error of the other shaft, an
    error more than 5 % behind; a pinned once-per-revolution error is not given up for a fluctuation on its
    shaft's order (interior_rival alone would)."""
    from compare.candidates import Attribution, AttributionSettings, CandidateResult, choose_claim, rivals_of
    from compare.fitspace import bounds_hit, fit_space
    from compare.response import mark_shaft_locks, revolution_shafts
    from datagen.effects import EffectSpec, get
    from datagen.geometry import preset

    pair = preset("spur-gds")
    base = {"order": 17.0, "envelope": 18.0}

    def cand(name, reduction, params, rises=None):
        total = 17.56 * (1.0 - reduction)
        c = CandidateResult(name, "", dict(params), {}, total, 17.56, {"order": total, "envelope": total},
                            "2 s", 1, baseline_view_error_db=base)
        c.at_bound = bounds_hit(fit_space(get(name)), c.params)
        c.rises_off_bound = dict(rises or {})
        return c

    def ranked(*cands):
        out = sorted(cands, key=lambda c: -c.reduction)
        mark_shaft_locks(out, pair, speed_rpm=1000.0, resolution_hz=0.5)
        return out

    def torque(f_hz=16.6666, reduction=0.665):
        return cand("torque_fluctuation", reduction, {"frequency_hz": f_hz, "amplitude_fraction": 0.75})

    def ecc(which="pinion", reduction=0.643):
        return cand(f"eccentricity_{which}", reduction, {"amplitude_m": 200e-6}, {"amplitude_m": "upper"})

    # which shafts a displacement effect repeats with, read off its period (not its name)
    def shafts(name, **params):
        return revolution_shafts(EffectSpec.from_dict({"name": name, **params}).build(), pair)

    assert shafts("eccentricity_pinion") == ["pinion"] and shafts("eccentricity_wheel") == ["wheel"]
    assert shafts("pitch_error", gears="wheel") == ["wheel"] and shafts("pitch_error", gears="both") == ["pinion", "wheel"]
    assert shafts("profile_error") == [] and shafts("tip_relief") == [] and shafts("backlash") == []

    t, e = torque(), ecc()
    pitch = cand("pitch_error", 0.525, {"grade": 9.0, "gears": "pinion"})
    rs = ranked(t, e, pitch)
    assert t.shaft_lock == {"kind": "fluctuation", "shaft": "pinion", "order": 1}
    assert e.shaft_lock == {"kind": "revolution", "shafts": ["pinion"]} and e.pinned == ["amplitude_m"]
    claimed = choose_claim(rs, AttributionSettings())
    assert claimed is e and rs[0] is e and not t.claimed
    assert e.claimed_over == {"effect": "torque_fluctuation", "rule": "shaft_locked"}
    assert rivals_of(claimed, rs, AttributionSettings()) == ["torque_fluctuation"]
    note = Attribution(candidates=rs, unexplained=[], elapsed_s=0.0, n_simulations=0).claim_order
    assert "1 x the pinion's rotation" in note and "torque_fluctuation" in note
    # the fluctuation's second order of the pinion (33.3 Hz, within the resolution) is locked too
    t2, e2 = torque(33.2), ecc()
    assert choose_claim(ranked(t2, e2), AttributionSettings()) is e2 and t2.shaft_lock["order"] == 2
    # not moved: off every shaft order; the other shaft's error; an error 6 % behind
    for rs in (ranked(t37 := torque(37.0), ecc()), ranked(tw := torque(), ecc("wheel")),
               ranked(tf := torque(), ecc(reduction=0.605))):
        first = rs[0]
        assert choose_claim(rs, AttributionSettings()) is first and first.effect == "torque_fluctuation"
        assert first.claimed_over is None
    assert t37.shaft_lock == {} and tw.shaft_lock["shaft"] == "pinion" and tf.shaft_lock["kind"] == "fluctuation"
    # the pinned error ahead of the fluctuation on its shaft's order: it stays claimed (interior_rival alone
    # would have moved the claim to the fluctuation, which fits inside its range)
    e3, t3 = ecc(reduction=0.665), torque(reduction=0.643)
    rs = ranked(e3, t3)
    assert choose_claim(rs, AttributionSettings()) is e3 and e3.claimed_over is None
    # ... while a fluctuation off the shaft orders still takes the claim from the pinned error
    e4, t4 = ecc(reduction=0.665), torque(37.0, reduction=0.643)
    rs = ranked(e4, t4)
    assert choose_claim(rs, AttributionSettings()) is t4 and t4.claimed_over == {"effect": "eccentricity_pinion",
                                                                                   "rule": "interior"}
