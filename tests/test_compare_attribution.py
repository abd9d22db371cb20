"""Attribution on 'measurements' with a hidden effect (compare.attribution, compare.calibration, compare.synthetic).

Reference: the issue's acceptance criteria. Each measurement is simulated with one effect the baseline model
lacks, on a rig whose mesh/bearing damping, bearing stiffness, noise (SNR 30 dB; 40 dB for hertz_nonlinear,
compare.synthetic.HIDDEN_EXAMPLES says why) and sensor gain (x3.7) differ
from the comparison model's defaults (compare.synthetic.NUISANCE). For each registered effect (slow tests): it
ranks first and is claimed; adding it with the fitted parameters cuts the total error by at least half; the
checked parameter is within the tolerance of compare.synthetic.HIDDEN_EXAMPLES. Controls: no hidden effect ->
nothing claimed; a disturbance outside the registry (rolling-bearing defect, mains hum) -> flagged unexplained,
no gear effect claimed. The default (fast) tests use a reduced candidate list; the slow ones the whole registry.
These run the comparison as it is by default ("auto": the model as written first; when no effect explains the
mismatch, the nuisances are calibrated and the attribution repeated, compare.escalation; the controls explain
nothing, so they check the calibrated pass too).

The nuisance calibration's own tests are in tests/test_compare_calibration.py.
"""
from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from compare.calibration import calibrated_compare
from compare.escalation import compare_and_attribute
from compare.comparison import compare, prepare_reference
from compare.model import ComparisonModel
from compare.synthetic import HIDDEN_EXAMPLES, NUISANCE, check_fit, rig_measurement, run_hidden_case

FAST_CANDIDATES = ["pitch_error", "eccentricity_pinion", "profile_error", "tip_relief"]


def _attribute(m, candidates=None, model=None, calibrate=None):
    """The user's loop as gearpit compare runs it by default: compare the model as written, attribute, and when
    that explains nothing calibrate the nuisances and attribute again (compare.escalation, "auto")."""
    model = model or ComparisonModel()
    ref = prepare_reference(m)
    staged = compare_and_attribute(m, model, reference=ref, calibrate=calibrate, candidates=candidates)
    _attribute.staged = staged
    return ref, staged.comparison, staged.attribution


def _calibration_tried() -> bool:
    """Whether the last :func:`_attribute` calibrated: its pass is reported (escalated), or it raised the error
    and was not used (compare.escalation)."""
    staged = _attribute.staged
    return staged.escalated or "calibration_rejected" in staged.summary()


#: peak acceleration of the bearing defect's impacts (m/s^2). 60 until the mesh record resolved the high mesh
#: harmonics (box edges, positions chosen by the band): the gear's own content near 3.9 kHz (8 fm) rose, and the
#: defect's strongest line off the orders fell to 5.7 dB over the model, under the 6 dB unexplained flag (its
#: line on 8 fm - 1 fr_pinion, 54 x 71.3 Hz, stayed flagged); at 90 it is flagged at 8.8 dB, at 120 at 11.2 dB
AMP = 120.0


def bearing_defect(t):
    """Outer-race defect: impacts at 71.3 Hz (4.28 x fr_pinion at 1000 rpm; no shaft order) ringing a 3.9 kHz
    mode (damping ratio 0.03), as the sensor sees them."""
    f0, fd, z = 71.3, 3900.0, 0.03
    tau = np.mod(t, 1 / f0)
    return AMP * np.exp(-z * 2 * np.pi * fd * tau) * np.sin(2 * np.pi * fd * tau)


def mains_hum(t):
    """60 Hz hum and its third harmonic (3.6 and 10.8 x fr_pinion: no shaft order)."""
    return 8.0 * np.sin(2 * np.pi * 60.0 * t) + 3.0 * np.sin(2 * np.pi * 180.0 * t + 0.4)


def test_no_hidden_effect_claims_nothing():
    """Only nuisance differences: no candidate lowers the error by the claim threshold (30 %)."""
    _, c, a = _attribute(rig_measurement(duration_s=1.0), FAST_CANDIDATES)
    assert not a.claimed, [(x.effect, x.reduction) for x in a.candidates]
    assert c.calibration is not None      # nothing explained as written: the calibrated pass is the one reported


@pytest.mark.parametrize("disturbance", [bearing_defect, pytest.param(mains_hum, marks=pytest.mark.slow)])
def test_disturbance_outside_the_registry_is_unexplained(disturbance):
    """A bearing defect / mains hum: its lines are among the disagreements, flagged unexplained, and no gear
    effect is claimed for them. (Mains hum with the reduced candidate list is slow, to keep the default suite
    under 10 minutes: the slow suite also runs both with the whole registry, test_controls_with_the_whole_registry.)"""
    _, c, a = _attribute(rig_measurement(duration_s=1.0, extra=disturbance), FAST_CANDIDATES)
    assert not a.claimed, [(x.effect, x.reduction) for x in a.candidates]
    assert _calibration_tried()      # nothing explained as written; calibrated, used or not (it may raise the error)
    texts = [u["text"] for u in a.unexplained]
    assert any("not a shaft order" in t or "band" in t for t in texts), texts


#: effects whose whole signature is about the size of what the nuisances and the noise do to the error (name ->
#: reason; marked xfail): they rank first and are claimed, but the model with them keeps more than half of the
#: baseline's error (experiments/halving_floor.py measures that floor). None at present. tip_relief was here while
#: its example had no other gear error (a relief alone: baseline 0.69-0.94 dB, the rig's own model 0.09-0.55 dB,
#: the relief at the default drive train up to 0.71 of the baseline); with a grade-7 pitch error known to rig and
#: model its signature is 5.4-5.6 dB (compare.synthetic says why). hertz_nonlinear was here until its example moved
#: to the light load (5 N m) and the 40 dB sensor chain; eccentricity_wheel until the eccentric centre moved the
#: mesh (hook 2c).
NUISANCE_LIMITED: dict = {}

#: effects that are claimed first and halve the error but whose amount the default loop does not recover (name ->
#: reason; only the fit check xfails). None at present. backlash was here at stop 35: on the band's mesh record the
#: 30 um example's whole-record ladder preferred free flight at the model's default drive train (126 um and up:
#: 1.86 dB against 2.32-2.55 dB at 22-45 um), reported as [89 um, open], on noise seeds 3, 4 and 5. The valley
#: at 27-32 um lay between the former ladder's factor-2 steps; the dense ladder (compare.chaos) fits 31.6 um as
#: written on all three seeds (error ratio 0.37-0.38; 2026-11-28).
FIT_LIMITED: dict = {}

#: pairs of effects whose signatures in these views coincide (name -> its twin). Source: the simulator's truth and
#: compare.candidates.rivals_of. A speed fluctuation at the motor and a torque fluctuation at the load at the same
#: frequency both excite the drive train's torsion, and the strongest mesh harmonic carries the same amplitude-to-
#: phase modulation ratio for both (-24 dB at 23 Hz on spur-gds, measured by demodulation); once both fits were
#: refined (compare.search.round_fine) and measured on the whole record, each hidden one was fitted by its twin
#: 0.6-2.4 % *better* than by itself on this rig (a helical rig: 0.04 %). For these the test asserts what the
#: tool promises instead of "ranks first": the hidden effect is claimed, or it is a rival of the claimed twin
#: (within 5 % of its reduction, and the report says the views cannot tell them apart); its own fit is within
#: the tolerance; adding the claimed effect halves the error.
TWINS = {"speed_fluctuation": "torque_fluctuation", "torque_fluctuation": "speed_fluctuation"}


def _is_top_or_rival(name, a) -> bool:
    top = a.candidates[0]
    if top.effect == name:
        return True
    return TWINS.get(name) == top.effect and top.claimed and name in a.rivals


@functools.lru_cache(maxsize=None)
def _hidden_run(name):
    """The user's loop (compare.synthetic.run_hidden_case): compare, attribute, add the claimed effect with its
    fitted parameters, compare again."""
    return run_hidden_case(name)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(HIDDEN_EXAMPLES))
def test_hidden_effect_ranks_first(name):
    """Whole registry as candidates, nuisances on: the hidden effect has the largest error reduction (for the
    TWINS: or it is a rival of its claimed twin)."""
    ex, c0, a, c1 = _hidden_run(name)
    assert _is_top_or_rival(name, a), ([(x.effect, round(x.reduction, 3)) for x in a.candidates[:4]], a.rivals)


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.xfail(reason=NUISANCE_LIMITED[n], strict=False))
                                  if n in NUISANCE_LIMITED else n for n in sorted(HIDDEN_EXAMPLES)])
def test_hidden_effect_is_claimed_halves_the_error_and_is_fitted(name):
    """The hidden effect is claimed; the model with it (fitted parameters) has at most half the baseline's total
    error; the checked parameter is within the tolerance of compare.synthetic.HIDDEN_EXAMPLES (for the TWINS: the
    hidden effect is claimed or a rival of its claimed twin, and its own fit is checked)."""
    ex, c0, a, c1 = _hidden_run(name)
    top = a.candidates[0]
    assert top.claimed and _is_top_or_rival(name, a), ([(x.effect, round(x.reduction, 3)) for x in a.candidates[:4]],
                                                       a.rivals)
    assert c1.error_db["total"] <= 0.5 * c0.error_db["total"], (c1.error_db, c0.error_db)
    own = next(c for c in a.candidates if c.effect == name)
    ok, text = check_fit(ex, own.params)
    if not ok and name in FIT_LIMITED:
        pytest.xfail(f"{FIT_LIMITED[name]} ({text})")
    assert ok, text


@pytest.mark.slow
@pytest.mark.parametrize("seed", [4, 5])
def test_backlash_is_fitted_on_other_noise_seeds(seed):
    """The backlash example (30 um) on two more noise draws of the rig: claimed first, the error at least halved,
    the amount within the example's tolerance (factor 2). Both failed with the factor-2 ladder (126 um reported);
    seed 5 also needs the chaotic candidate's looser gate to the whole record (its window fit, 178 um, took 29.4 %:
    under the claim threshold; compare.attribution._confirm_on_record)."""
    ex, c0, a, c1 = run_hidden_case("backlash", seed=seed)
    top = a.candidates[0]
    assert top.effect == "backlash" and top.claimed, [(x.effect, round(x.reduction, 3)) for x in a.candidates[:4]]
    assert c1.error_db["total"] <= 0.5 * c0.error_db["total"], (c1.error_db, c0.error_db)
    ok, text = check_fit(ex, top.params)
    assert ok, text


#: the backlash example's chaotic regime where the amount is not identified (compare.synthetic.HIDDEN_EXAMPLES says
#: why): 50 um at the example's operating point, where the back flanks are struck so rarely that every backlash
#: from 20-35 um up fits as well. Measured 2026-11-27 over five realisations of the rig (50 um x (1 + k 1e-13)):
#: fitted 75, 174, 70, 126 and 75 um (within the factor 2 on three), intervals [19, 150], [22, -], [35, -],
#: [22, -] and [19, 150] um ('-': no bound), error ratios 0.40-0.49
BACKLASH_UNBOUNDED = 50e-6


@pytest.mark.slow
def test_backlash_that_is_rarely_closed_gets_an_interval_holding_the_truth():
    """compare.chaos: at 50 um the rattle record is chaotic and its amount poorly bounded; the tool must say so
    rather than report a sharp fit. Backlash is claimed first, its record is flagged chaotic (a realisation
    scatter > 0), and its reported interval contains the truth (an open side counts as unbounded)."""
    ex = HIDDEN_EXAMPLES["backlash"]
    ex, c0, a, c1 = run_hidden_case("backlash", seed=3,
                                    example=dataclasses.replace(ex, effect={**ex.effect, "backlash_m": BACKLASH_UNBOUNDED}))
    top = a.candidates[0]
    assert top.effect == "backlash" and top.claimed, [(x.effect, round(x.reduction, 3)) for x in a.candidates[:4]]
    assert top.realisation_scatter_db and top.realisation_scatter_db > 0
    lo, hi = top.interval["backlash_m"]
    assert (lo is None or lo <= BACKLASH_UNBOUNDED) and (hi is None or hi >= BACKLASH_UNBOUNDED), (lo, hi)


@pytest.mark.slow
@pytest.mark.parametrize("disturbance", [None, bearing_defect, mains_hum])
def test_controls_with_the_whole_registry(disturbance):
    """The controls above with every registered effect as a candidate (2 s records)."""
    _, c, a = _attribute(rig_measurement(extra=disturbance))
    assert not a.claimed, [(x.effect, x.reduction) for x in a.candidates]
    assert c.calibration is not None if disturbance is None else _calibration_tried()
    if disturbance is not None:
        assert a.unexplained


@pytest.mark.slow
def test_default_loop_finds_a_pitch_error_on_a_rig_whose_drive_train_is_far_off():
    """Generalisation (compare.escalation; source: the simulator's truth): the helical rig of
    compare.synthetic.OTHER_RIGS (another pair, speed and gain; mesh damping, bearing stiffness and damping 2-3
    times off the model's defaults; 5 dB more noise; noise seed 11) hides a grade-8 pitch error. As written the
    model explains 29 % of the error (measured, --no-calibrate), so the default "auto" loop calibrates the drive
    train and attributes again: pitch_error is claimed, the model with it keeps at most half of the calibrated
    baseline's error and its grade is within 0.5.

    On the band's mesh record (stop 34) the grade was not recovered until the claim was refitted jointly with
    the nuisances (compare.joint_refit): the escalated calibration, made without the pitch error, lands at a
    bearing damping of 0.136 (the rig's 0.03; mesh damping 0.042 for 0.03, bearing stiffness 3.9e8 for 3.0e8),
    and at those nuisances grade 5 fits best (2.60 dB). The joint refit over the whole nuisance box moves them
    to 0.088 / 3.0e8 / 0.029 and the grade to 7.7 (measured: 7.15 -> 0.32 dB). Fails without it (grade 5)."""
    from compare.synthetic import OTHER_RIGS

    rig, less_db = OTHER_RIGS["helical"]
    ex = HIDDEN_EXAMPLES["pitch_error"]
    ex, c0, a, c1 = run_hidden_case("pitch_error", seed=11, rig={**rig, "snr_db": ex.snr_db - less_db})
    assert c0.calibration is not None          # escalated: the model as written explained nothing
    top = a.candidates[0]
    assert top.effect == "pitch_error" and top.claimed, [(x.effect, round(x.reduction, 3)) for x in a.candidates[:3]]
    assert c1.error_db["total"] <= 0.5 * c0.error_db["total"], (c1.error_db["total"], c0.error_db["total"])
    ok, text = check_fit(ex, top.params)
    assert ok, text
    assert top.joint_refit is not None and top.joint_refit["kept"], top.joint_refit


def test_worker_processes_give_the_attribution_of_one_process():
    """Source: compare.attribution._fit_in_workers (each periodic effect searched with its own baseline in a
    worker, the nuisance refits too) against the same attribution in one process (all periodic effects in one
    batch, refits in turn). A calibrated 1 s rig with a hidden pitch error, four periodic candidates, so the
    refit runs: the same ranking and claim; reductions within 0.005 and parameters within 2 % (the batch sets
    the solver's steps per mesh cycle, so a baseline's error can differ by ~1e-4 dB between the two); the
    refitted nuisances within 2 %. Would fail if a worker lost a candidate, its refit, or its baseline."""
    from compare.attribution import attribute
    from compare.synthetic import hidden_effect_measurement

    m, ex = hidden_effect_measurement("pitch_error", duration_s=1.0)
    ref = prepare_reference(m)
    c = calibrated_compare(m, ex.model(), reference=ref, calibrate_nuisances=True)
    kw = dict(candidates=FAST_CANDIDATES, disagreements=c.disagreements, calibration=c.calibration)
    one = attribute(ref, c.model, c.evaluation.residuals.residual_db, parallel=False, **kw)
    pool = attribute(ref, c.model, c.evaluation.residuals.residual_db, parallel=True, **kw)
    assert "nuisance_refit" in one.group_seconds and "nuisance_refit" in pool.group_seconds
    assert [x.effect for x in pool.candidates] == [x.effect for x in one.candidates]
    assert [x.effect for x in pool.claimed] == [x.effect for x in one.claimed] == ["pitch_error"]
    for x, y in zip(pool.candidates, one.candidates):
        assert abs(x.reduction - y.reduction) <= 0.005, (x.effect, x.reduction, y.reduction)
        assert x.params.keys() == y.params.keys()
        for k, v in x.params.items():
            assert (v == y.params[k]) if isinstance(v, str) else np.isclose(v, y.params[k], rtol=0.02, atol=1e-12), \
                (x.effect, k, v, y.params[k])
        for k, v in x.nuisance.items():
            assert np.isclose(v, y.nuisance[k], rtol=0.02), (x.effect, k, v, y.nuisance[k])


def test_sigma_is_the_least_squares_spread():
    """The 1-sigma formulas against Monte Carlo. Source: linear least squares: N equally weighted residuals
    r_i = e_i + (u - u0) a_i + (v - v0) b_i with e_i ~ N(0, s^2) have estimates whose spread over noise draws
    is the one the chi-square (N E^2 / E_min^2) rising by 1 gives. Checked: compare.search.line_sigma_u (one
    parameter) and compare.search.surrogate_sigma_u (two, through the quadratic surrogate of E^2) each give
    the standard deviation of the estimates over 400 draws within 12 % (sampling error of a standard
    deviation from 400 draws: 3.5 %)."""
    from compare.search import fit_quadratic, line_sigma_u, surrogate_sigma_u

    rng = np.random.default_rng(7)
    n, s = 60, 0.4
    a, b = rng.normal(size=n), rng.normal(size=n) + 0.5 * rng.normal(size=n)
    X = np.column_stack([a, b])
    est_v, line_sig, quad_sig = [], [], []
    grid = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    pts = np.array([(du, dv) for du in (-0.2, 0.0, 0.2) for dv in (-0.2, 0.0, 0.2)])
    for _ in range(400):
        e = s * rng.normal(size=n)
        (uh, vh), *_ = np.linalg.lstsq(X, -e, rcond=None)    # estimate of (u - u0, v - v0)
        est_v.append(vh)

        def err(du, dv):
            return float(np.sqrt(np.mean((e + (uh + du) * a + (vh + dv) * b) ** 2)))

        e_min = err(0.0, 0.0)
        # one parameter (v held at its estimate): the conditional sigma, 1 / sqrt(sum a^2) * s
        line_sig.append(line_sigma_u(grid, [err(d, 0.0) for d in grid], e_min, n))
        _, H, _ = fit_quadratic(pts, np.array([err(du, dv) ** 2 for du, dv in pts]), [(-1, 1), (-1, 1)])
        quad_sig.append(surrogate_sigma_u(H, 1, e_min, n))
    # the conditional spread of u (v known) is s / sqrt(sum a^2); the marginal spread of v is std(est_v)
    cond_u = s / np.sqrt(np.sum(a * a))
    assert abs(np.mean(line_sig) / cond_u - 1) < 0.12, (np.mean(line_sig), cond_u)
    assert abs(np.mean(quad_sig) / np.std(est_v) - 1) < 0.12, (np.mean(quad_sig), np.std(est_v))


@pytest.mark.slow
def test_a_healthy_rig_at_3000_rpm_claims_nothing():
    """The false claim model_error_db removes, end to end (spur-gds, 3000 rpm, 100 N m, 1 s, nuisances off the
    defaults): a speed fluctuation at 85 Hz used to be claimed against the coarse time-stepped baseline. The two
    fluctuations are the candidates (the time-stepped path); nothing is claimed. And the time-stepped baseline
    now agrees with the periodic comparison: both simulate the same linear model, and since the time-stepped
    path reads the mesh record as its mean over each step (datagen.mesh_excitation.MeshRecords.window_all_at)
    it no longer carries the step-beat lines that put it 1.49 dB against the comparison's 0.45 dB here (the
    disagreement the rule guarded against; the fluctuations then took 75 and 64 % of it, now 26 and 4 %).
    Tolerance 0.3 dB: the noise error of such a record is ~0.9 dB, its scatter a few tenths."""
    m = rig_measurement((), speed_rpm=3000.0, torque_nm=100.0, fs_hz=20000.0, duration_s=1.0)
    _, c, a = _attribute(m, candidates=["speed_fluctuation", "torque_fluctuation"], calibrate=False)
    assert not a.claimed, [(x.effect, x.reduction, x.error_db, x.model_error_db) for x in a.candidates]
    best = a.candidates[0]
    assert best.baseline_error_db <= c.evaluation.residuals.excess_total_db + 0.3, (
        best.baseline_error_db, c.evaluation.residuals.excess_total_db)


@pytest.mark.slow
def test_a_healthy_rig_at_low_snr_claims_nothing_after_calibration():
    """The false claim min_excess_to_noise removes, end to end: a healthy rig (nuisances off the model's
    defaults, compare.synthetic.NUISANCE) recorded at 10 dB SNR; the default loop escalates, the calibration
    takes the excess error to ~0.03 dB against a noise error of ~0.8 dB, and a housing mode used to be claimed
    for halving that. Now nothing is claimed."""
    m = rig_measurement((), snr_db=10.0, speed_rpm=1500.0, torque_nm=80.0, fs_hz=25600.0, duration_s=1.5)
    _, c, a = _attribute(m, candidates=["transmission_path", "profile_error", "tip_relief"])
    assert not a.claimed, [(x.effect, x.reduction) for x in a.candidates]
    assert c.evaluation.residuals.excess_total_db < c.evaluation.residuals.noise_total_db


def test_the_rigs_own_model_scores_at_the_noise_floor():
    """The floor under the halving test (experiments/halving_floor.py). Source: the simulator's truth: the rig's
    own model (its hidden effect *and* its drive train, compare.synthetic.NUISANCE) differs from the rig only by
    the noise draw, so its excess error is noise scatter. Measured on 2 s rigs, seeds 3-7: 0.07-0.65 dB against a
    9.1-9.3 dB baseline (pitch_error, grade 8); on the 1 s rig here, seeds 3-5: 0.13-0.37 dB against 8.7-8.8 dB,
    with a noise error of 0.92 dB (its raw error is about that, so a broken noise correction fails the first
    check). Asserted: at most 0.5 dB and at most 0.15 of the baseline's; the model with the effect at the default
    drive train between the two (the nuisances cost something); the noise error 0.3-1.2 dB at 30 dB SNR."""
    from datagen.effects import build_effects

    ex = HIDDEN_EXAMPLES["pitch_error"]
    m = rig_measurement((ex.effect,), duration_s=1.0)
    ref = prepare_reference(m)
    base = ex.model()
    with_effect = base.with_effect(build_effects((ex.effect,))[0])
    errors = {key: compare(m, model, reference=ref) for key, model in
              (("base", base), ("effect", with_effect), ("truth", with_effect.with_drivetrain(NUISANCE)))}
    e = {key: c.error_db["total"] for key, c in errors.items()}
    assert e["truth"] <= min(0.5, 0.15 * e["base"]), e
    assert e["truth"] <= e["effect"] + 0.05 < e["base"], e
    assert 0.3 <= errors["truth"].noise_error_db["total"] <= 1.2, errors["truth"].noise_error_db


def test_reliability_weights_lower_the_floor_under_a_small_signature(monkeypatch):
    """compare.error step 5 (off by default; switched on here at the recommended s0 = 0.5 dB). Source: the simulator's truth: on a tip-relief rig (10 um, 50 N m, 2 s, 30 dB, no other gear error)
    the rig's own model (relief *and* drive train) differs from the rig only by the noise draw, the baseline
    with the rig's drive train only by the relief. Without the reliability weights (every residual of a view
    weighted alike) ~150 sideband locations that hold only noise weigh as much as the dozen mesh harmonics the
    relief moves. Measured on seeds 3-5, the rig's own model's share of the baseline's error with / without the
    weights: 0.15 / 0.29, 0.20 / 0.45, 0.19 / 0.50 (since the mesh record resolves the high mesh harmonics,
    box edges and positions chosen by the band, the baseline's error with the weights is 1.30-1.33 dB; 0.45-0.56
    with box edges on 64 positions; on the former 64 point-sampled positions the shares were 0.30-0.33 /
    0.62-0.70). Asserted: at most 0.4 on each seed
    with the weights, and at most 0.7 of the share without them."""
    import compare.error as cerr
    from datagen.effects import build_effects

    # the relief alone, on a pair without the pitch error of the hidden example (there the relief's signature is
    # ~5 dB and stands clear of the floor; this test is about a signature of the floor's size)
    ex = dataclasses.replace(HIDDEN_EXAMPLES["tip_relief"], known=())
    base = ex.model().with_drivetrain(NUISANCE)
    truth = ex.model().with_effect(build_effects((ex.effect,))[0]).with_drivetrain(NUISANCE)
    for seed in (3, 4, 5):
        m = rig_measurement((ex.effect,), torque_nm=ex.torque_nm, seed=seed)
        ref = prepare_reference(m)
        share = {}
        for s0 in (cerr.RECOMMENDED_TOLERANCE_DB, None):
            monkeypatch.setattr(cerr, "MODEL_TOLERANCE_DB", s0)
            e_base = compare(m, base, reference=ref).error_db["total"]
            share[s0] = compare(m, truth, reference=ref).error_db["total"] / e_base
        with_weights, without = share[cerr.RECOMMENDED_TOLERANCE_DB], share[None]
        assert with_weights <= 0.4 and with_weights <= 0.7 * without, (seed, with_weights, without)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["helical_wheel_pit_1200rpm", "spur_broken_tooth_600rpm"])
def test_a_local_tooth_fault_on_another_rig_is_claimed(case):
    """experiments/unseen_rigs_check.py's local tooth faults (a pit over 30 % of a wheel tooth's flank on the helical
    pair at 1200 rpm, 25 dB; a pinion tooth broken over 25 % of its width on the spur pair at 600 rpm, 20 N m, 3 s
    at 10 kHz): the default loop claims the hidden effect (or names it a rival of the claim), on the right gear,
    with its amount within 0.1 of the truth (stop 57: the pit's severity 0.21 for 0.3 - a helical wheel flank on
    the default 64 x 64 grid -, the break's width 0.23 for 0.25)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
    from unseen_rigs_check import CASES, run_case

    row = run_case(case)
    assert row["pass"], row
    truth = CASES[case][0]["effects"][0]
    best = row["best"]
    assert best["effect"] == truth["name"], row
    assert best["params"]["gear"] == truth.get("gear", "pinion"), row
    key = "severity" if truth["name"] == "tooth_pit" else "width_fraction"
    assert abs(best["params"][key] - truth[key]) <= 0.1, row
