"""The simulator's solution paths (datagen.simulate, datagen.dynamics, datagen.newmark): periodic vs transient,
batching, the mesh angle, the Newton mesh law, the mesh record and the chunked decimation - each against an
independent reference named per test (split from tests/test_dynamics.py)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from datagen import newmark
from datagen.geometry import helical_pair_example
from datagen.simulate import Case, OperatingPoint, SolverOptions, simulate
from dynamics_support import SPUR, TORQUE, _lsq_amplitudes


def test_periodic_and_transient_paths_agree():
    """The two solution paths (shooting vs start-up transient discarded) give the same steady state:
    mesh-force and housing-acceleration harmonics 1-5 of f_m within 1 % of the strongest of them
    (helical pair, 1500 rpm).

    Reference: each other; the transient path decays its start-up by 60 dB (datagen.dynamics).
    """
    pair = helical_pair_example()
    rpm = 1500.0
    fm = pair.mesh_frequency_hz(rpm)
    fs = 20000.0
    base = Case(pair=pair, operating=OperatingPoint(rpm, TORQUE), duration_s=0.1, fs_hz=fs)
    per, tra = simulate([base, replace(base, solver=SolverOptions(method="transient"))])
    assert per.metadata["solver"]["method"] == "periodic" and tra.metadata["solver"]["method"] == "transient"
    for ch in ("mesh_force_n", "acc_pinion_loa_m_s2"):
        a = _lsq_amplitudes(per.channels[ch], fs, fm * np.arange(1, 6))
        b = _lsq_amplitudes(tra.channels[ch], fs, fm * np.arange(1, 6))
        np.testing.assert_allclose(b, a, rtol=0, atol=0.01 * a.max(), err_msg=ch)


def _sideband_amplitudes(x, fs, rpm, teeth):
    """Amplitudes of the mesh harmonics 1-3 and their +/-1, +/-2 pinion-order sidebands (least squares)."""
    fr = rpm / 60.0
    freqs = [h * teeth * fr + s * fr for h in (1, 2, 3) for s in (-2, -1, 0, 1, 2)]
    return _lsq_amplitudes(x, fs, freqs)


@pytest.mark.parametrize("mesh_angle", ["dynamic", "nominal"])
def test_paths_agree_on_eccentricity_sidebands(mesh_angle):
    """A 100 um pinion eccentricity (a once-per-revolution transmission error the gears follow by turning ~1e-2
    of a mesh cycle): the periodic path (shooting; with ``mesh_angle="dynamic"`` a fixed-point iteration on the
    pinion's angle) and the transient path (time-stepping, the mesh read at the predicted angle of each step)
    give the same mesh-force and housing-acceleration lines: mesh harmonics 1-3 and their +/-1, +/-2 pinion-order
    sidebands within 2 % of each line (and 1e-3 of the strongest line) - before the iteration the periodic path read the mesh at the nominal
    rotation while the transient path read it at the actual angle, and the +/-1 sidebands differed by 10-45 %.
    The two angle conventions themselves differ there by more than 10 % (the iteration matters).

    Reference: each other (two independent solution paths of the same equations).
    """
    rpm, fs = 1000.0, 20000.0
    ecc = ({"name": "eccentricity_pinion", "amplitude_m": 100e-6},)
    base = Case(pair=SPUR, operating=OperatingPoint(rpm, TORQUE), duration_s=0.6, fs_hz=fs, effects=ecc,
                solver=SolverOptions(method="periodic", mesh_angle=mesh_angle))
    per, tra = simulate([base, replace(base, solver=SolverOptions(method="transient", mesh_angle=mesh_angle))])
    assert per.metadata["solver"]["method"] == "periodic" and tra.metadata["solver"]["method"] == "transient"
    for ch in ("mesh_force_n", "acc_pinion_loa_m_s2"):
        a = _sideband_amplitudes(per.channels[ch], fs, rpm, SPUR.pinion.teeth)
        b = _sideband_amplitudes(tra.channels[ch], fs, rpm, SPUR.pinion.teeth)
        np.testing.assert_allclose(b, a, rtol=0.02, atol=1e-3 * a.max(), err_msg=ch)
    assert per.metadata["solver"]["periodicity_error"] < 1e-7           # the multiple shooting closed the period
    if mesh_angle == "nominal":
        assert per.metadata["solver"]["angle_passes"] == 1
    if mesh_angle == "dynamic":
        assert per.metadata["solver"]["angle_passes"] >= 2
        other = simulate([replace(base, solver=SolverOptions(method="periodic", mesh_angle="nominal"))])[0]
        a = _sideband_amplitudes(per.channels["mesh_force_n"], fs, rpm, SPUR.pinion.teeth)
        b = _sideband_amplitudes(other.channels["mesh_force_n"], fs, rpm, SPUR.pinion.teeth)
        assert np.max(np.abs(a - b) / a) > 0.1


def test_unknown_mesh_angle_is_refused():
    """A clear error naming the field, the value and the allowed values."""
    with pytest.raises(ValueError, match=r"solver\.mesh_angle.*sideways.*dynamic, nominal"):
        SolverOptions(mesh_angle="sideways")


def test_batching_does_not_change_results():
    """simulate([a, b]) equals simulate([a]), simulate([b]) (rtol 1e-9): cases are independent in a batch."""
    from datagen.pits import PitSpec

    a = Case(pair=SPUR, operating=OperatingPoint(1500.0, TORQUE), duration_s=0.05, fs_hz=20000.0)
    b = replace(a, pits=PitSpec(shape="ellipse", teeth=(3,), severity=(0.2,)), pit_grid=(32, 32))
    both = simulate([a, b])
    for one, case in zip(both, (a, b)):
        alone = simulate([case])[0]
        for k in one.channels:
            np.testing.assert_allclose(one.channels[k], alone.channels[k], rtol=1e-9,
                                       atol=1e-9 * np.abs(alone.channels[k]).max(), err_msg=k)


@pytest.mark.parametrize("helical", [False, True])
def test_cycles_differing_in_error_force_only_share_their_homogeneous_map(monkeypatch, helical):
    """A pitch error on the pinion makes every mesh cycle of a revolution distinct in its error force, while the
    stiffness differs only on the pitted tooth's cycles (spur: one pitted tooth) or nowhere (helical, healthy).
    The periodic path marches the homogeneous one-cycle map once per distinct stiffness and one particular
    column per further error force (datagen.shooting._cycle_maps). Reference: the same path with every distinct
    cycle's map marched in full (SHARE_PHI False, the former method): every channel within 1e-9 of its largest
    value; and the full maps are marched for the distinct stiffnesses only (fails if the sharing is lost)."""
    from datagen import shooting
    from datagen.pits import PitSpec

    pair = helical_pair_example() if helical else SPUR
    pits = {} if helical else dict(pits=PitSpec(shape="ellipse", teeth=(3,), severity=(0.2,)), pit_grid=(32, 32))
    case = Case(pair=pair, operating=OperatingPoint(1500.0, TORQUE), duration_s=0.1, fs_hz=20000.0,
                effects=({"name": "pitch_error", "grade": 8.0, "gears": "pinion"},),
                solver=SolverOptions(method="periodic"), **pits)
    full_rows = []
    march = shooting._march_columns

    def counted(*args, units):
        if units:
            full_rows.append(len(args[7]))
        return march(*args, units=units)
    monkeypatch.setattr(shooting, "_march_columns", counted)
    shared = simulate([case])[0]
    n_shared = full_rows.pop()
    monkeypatch.setattr(shooting, "SHARE_PHI", False)
    alone = simulate([case])[0]
    n_full = full_rows.pop()
    assert n_full == pair.pinion.teeth and n_shared < n_full, (n_shared, n_full)
    assert n_shared == 1 if helical else 2 <= n_shared <= 5, n_shared
    for k in alone.channels:
        np.testing.assert_allclose(shared.channels[k], alone.channels[k], rtol=0,
                                   atol=1e-9 * np.abs(alone.channels[k]).max(), err_msg=k)


def test_pitted_tooth_shows_once_per_revolution():
    """A pitted pinion tooth puts energy on the pinion shaft orders between the mesh harmonics (spur paper,
    Figs 21-22: sidebands at fr around the mesh lines). Fraction of the housing-acceleration energy on
    shaft-order lines that are not mesh harmonics: healthy < 1e-8 (the record repeats every mesh cycle;
    the rest is the output interpolation floor), pitted (20 % of one flank) > 1e-3.
    Exact lines: 0.2 s = 5 pinion revolutions, rectangular window.
    """
    from datagen.pits import PitSpec

    fs, rpm = 20000.0, 1500.0
    healthy = Case(pair=SPUR, operating=OperatingPoint(rpm, TORQUE), duration_s=0.2, fs_hz=fs)
    pitted = replace(healthy, pits=PitSpec(shape="ellipse", teeth=(0,), severity=(0.2,)), pit_grid=(32, 32))
    h, p = simulate([healthy, pitted])

    def sideband_fraction(x):
        spec = np.abs(np.fft.rfft(x - x.mean())) ** 2
        order = np.arange(spec.size) / 5                    # bins of 5 Hz = 1/5 pinion order
        on_order = np.isclose(order, np.round(order))
        mesh = on_order & (np.round(order) % SPUR.pinion.teeth == 0)
        return spec[on_order & ~mesh].sum() / spec[mesh].sum()

    assert sideband_fraction(h.channels["acc_pinion_loa_m_s2"]) < 1e-8
    assert sideband_fraction(p.channels["acc_pinion_loa_m_s2"]) > 1e-3
    assert h.metadata["solver"]["period_cycles"] == 1
    assert p.metadata["solver"]["distinct_cycles"] >= 2


def test_newton_mesh_law_matches_a_bracketing_root_finder():
    """``newmark.solve_mesh_law`` (Newton, vectorised over cases; its last F moved along the tangent instead of
    evaluated again) against scipy's brentq per case (reference: an independent bracketing solver), for a
    dead-zone law with kinks (backlash's elastic force; its damping here acts in and out of contact, since with
    damping switched off in the clearance the law jumps at the flank and a case can have no root at all) and a
    smooth stiffening one. Tolerance: delta to 1e-10 relative, and the returned F equal to the law evaluated at
    the returned delta to 1e-9 relative."""
    from scipy.optimize import brentq

    rng = np.random.default_rng(5)
    C, dt, sigma = 64, 1e-5, 2e-9 * (1 + rng.random(64))
    k, c, b = 3e8 * (1 + rng.random(C)), 500.0 * rng.random(C), 40e-6 * rng.random(C)
    h = 1e-2 * rng.standard_normal(C)

    def dead_zone(d, dd):
        front, back = d > 0, d < -b
        touch = (front | back).astype(float)
        return k * (np.where(front, d, 0.0) + np.where(back, d + b, 0.0)) + c * dd, k * touch, c

    def stiffening(d, dd):
        return k * d * (1 + (d / 20e-6) ** 2) + c * dd, k * (1 + 3 * (d / 20e-6) ** 2), c

    for law in (dead_zone, stiffening):
        delta_lin = 60e-6 * rng.standard_normal(C)
        delta, F, bad = newmark.solve_mesh_law(delta_lin, h, sigma, dt, law)
        assert bad == 0
        for j in range(C):
            def g(x, j=j):
                one = np.zeros(C)
                one[j] = x
                return x + sigma[j] * law(one, (2.0 / dt) * one - h)[0][j] - delta_lin[j]
            ref = brentq(g, -1e-3, 1e-3, xtol=1e-16, rtol=1e-14)
            assert delta[j] == pytest.approx(ref, rel=1e-10, abs=1e-16)
        F_at = law(delta, (2.0 / dt) * delta - h)[0]
        np.testing.assert_allclose(F, F_at, rtol=1e-9, atol=1e-9 * np.abs(F_at).max())


def test_an_angle_that_does_not_settle_keeps_the_nominal_solution(monkeypatch):
    """When the angle passes run out before the angle settles (seen on grade-8 pitch errors), the case keeps the
    first pass - the consistent solution at the nominal rotation, equal to ``mesh_angle="nominal"`` (rtol 1e-9)
    - and its metadata says ``angle_converged: False``. Forced here by allowing one pass on an eccentric pinion."""
    from datagen import shooting

    ecc = ({"name": "eccentricity_pinion", "amplitude_m": 100e-6},)
    base = Case(pair=SPUR, operating=OperatingPoint(1000.0, TORQUE), duration_s=0.2, fs_hz=20000.0, effects=ecc,
                solver=SolverOptions(method="periodic"))
    nominal = simulate([replace(base, solver=SolverOptions(method="periodic", mesh_angle="nominal"))])[0]
    monkeypatch.setattr(shooting, "MAX_ANGLE_PASSES", 1)
    cut = simulate([base])[0]
    assert cut.metadata["solver"]["angle_converged"] is False
    np.testing.assert_allclose(cut.channels["mesh_force_n"], nominal.channels["mesh_force_n"], rtol=1e-9,
                               atol=1e-9 * np.abs(nominal.channels["mesh_force_n"]).max())


def test_the_default_band_chosen_box_record_converges_where_the_former_record_does_not():
    """The mesh record's resolution (datagen.stiffness.contact_fraction, datagen.case_options.auto_positions_per_cycle).
    Source: convergence to a fine record (2048 box positions, omega_max dt 0.03, periodic path), healthy spur-gds
    at 600 rpm, 50 N m, 12.8 kHz, pinion-bearing acceleration, RMS of the difference. Measured: the former default
    record (64 point-sampled positions) 63 %, 64 box positions 36 %, the band's choice (512 box positions, the
    default since stop 34) 0.6 %. Asserted: the default record within 3 %, the former more than 30 % off."""
    from datagen.case_options import StiffnessOptions

    def acc(stiffness, omega_dt=0.3):
        case = Case(pair=SPUR, operating=OperatingPoint(600.0, 50.0), duration_s=0.2, fs_hz=12800.0,
                    solver=SolverOptions(omega_dt=omega_dt, method="periodic"), stiffness=stiffness)
        return np.asarray(simulate([case])[0].channels["acc_pinion_loa_m_s2"])

    ref = acc(StiffnessOptions(positions_per_cycle=2048, edges="box"), omega_dt=0.03)

    def err(x):
        return float(np.sqrt(np.mean((x - ref) ** 2) / np.mean(ref ** 2)))

    assert err(acc(StiffnessOptions())) <= 0.03
    assert err(acc(StiffnessOptions(positions_per_cycle=64, edges="point"))) > 0.30


@pytest.mark.parametrize("R", [2, 7, 12])
def test_chunked_decimation_equals_scipy_upfirdn_on_the_whole_stream(R, monkeypatch):
    """datagen.decimation.FirDecimator against an independent reference, scipy.signal.upfirdn over the whole
    stream at once (delay-compensated: output k is the filtered value at fine sample delay + k R): fed in uneven
    chunks, with the columns taken in blocks of a few (a small working-memory budget), equal to 1e-12 of the
    largest output."""
    import scipy.signal

    from datagen import decimation

    monkeypatch.setattr(decimation, "DECIMATION_BLOCK_BYTES", 8 * 3 * (200 + 53) * 53)   # ~3 columns a block
    rng = np.random.default_rng(5)
    x = rng.standard_normal((40 * R + 2 * decimation.HALF_TAPS_OUT * R + 3 * R + 1, 2, 5))
    d = decimation.FirDecimator(R)
    cuts = np.sort(rng.choice(np.arange(1, x.shape[0]), 6, replace=False))
    got = np.concatenate([d.push(part) for part in np.split(x, cuts)])
    full = scipy.signal.upfirdn(decimation.antialias_fir(R), x, up=1, down=R, axis=0)
    want = full[2 * decimation.HALF_TAPS_OUT: 2 * decimation.HALF_TAPS_OUT + got.shape[0]]
    assert got.shape[0] == (x.shape[0] - 1 - 2 * d.delay) // R + 1 and got.shape[1:] == (2, 5)
    assert np.max(np.abs(got - want)) < 1e-12 * np.max(np.abs(want))


def test_distinct_cycles_counts_the_different_cycles_of_a_record():
    """MeshRecord.distinct_cycles against np.unique over the normalised rows (the definition; rounding to 1e-10,
    -0.0 equal to 0.0): random records with repeated cycles, signed zeros and an all-zero error force."""
    from types import SimpleNamespace

    from datagen.mesh_excitation import MeshRecord

    rng = np.random.default_rng(0)
    for trial in range(100):
        P, ppc = int(rng.integers(1, 30)), 8
        base = rng.standard_normal((int(rng.integers(1, P + 1)), 2 * ppc))
        rows = base[rng.integers(0, base.shape[0], P)]
        if trial % 3 == 0:
            rows[np.abs(rows) < 0.5] = 0.0
            rows[::2] *= -1.0
        if trial % 5 == 0:
            rows[:, ppc:] = 0.0
        k, e = rows[:, :ppc], rows[:, ppc:]
        rec = SimpleNamespace(period_cycles=P, positions_per_cycle=ppc, k=k.ravel(), error_force=e.ravel())
        norm = np.hstack([k / np.abs(k).max(), e / max(np.abs(e).max(), 1e-300)])
        expected = np.unique(np.round(norm, 10), axis=0).shape[0]
        assert MeshRecord.distinct_cycles(rec) == expected
    # two cycles equal but for the sign of a zero: one cycle, as np.unique counts it
    k = np.ones((2, 8))
    e = np.zeros((2, 8))
    e[1] = -0.0
    rec = SimpleNamespace(period_cycles=2, positions_per_cycle=8, k=k.ravel(), error_force=e.ravel())
    assert MeshRecord.distinct_cycles(rec) == 1
