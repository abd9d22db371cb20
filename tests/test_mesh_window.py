"""The step-window read of the mesh record and the bracketed fallback of the Newton solve of a mesh law.

Sources: the window mean against a dense midpoint-rule average of the point read (``MeshRecords.all_at``) over
the same window (tolerance 1e-5 relative: the midpoint rule's error on a piecewise-linear record with 4000
points per window); the fallback against the definition of a solution of a law that jumps (the residual's
one-sided limits bracket zero, the returned force lies between the law's limits).
"""
import numpy as np

from datagen import newmark
from datagen.geometry import preset
from datagen.lumped_model import DriveTrain
from datagen.mesh_excitation import MeshRecords
from datagen.simulate import Case, OperatingPoint, prepare


def _records():
    cases = [Case(preset("helical-dct"), OperatingPoint(1500.0, 2.0), duration_s=0.1, fs_hz=20000.0, seed=3,
                  drivetrain=DriveTrain(), effects=({"name": "profile_error", "grade": 9.0}, {"name": "backlash", "backlash_m": 30e-6})),
             Case(preset("spur-gds"), OperatingPoint(1000.0, 50.0), duration_s=0.1, fs_hz=20000.0, seed=3,
                  effects=({"name": "pitch_error", "grade": 8.0}, {"name": "backlash", "backlash_m": 30e-6}))]
    return MeshRecords([prepare(c).record for c in cases])


def test_the_window_mean_is_the_average_of_the_point_read_over_the_window():
    rec = _records()
    rng = np.random.default_rng(0)
    for _ in range(5):
        x = rng.uniform(0.0, 40.0, 2)                     # mesh cycles, past whole record periods too
        w = rng.uniform(0.0005, 0.01, 2)                  # 0.3-5 positions of a 512-position cycle
        k, e, ks, es = rec.window_all_at(x, w)
        assert ks.shape[1] >= 2                          # the pairs' slots are kept (a nonlinear law)
        u = (np.arange(4000) + 0.5) / 4000 - 0.5
        pts = [rec.all_at(x + ui * w) for ui in u]
        k_ref = np.mean([p[0] for p in pts], axis=0)
        e_ref = np.mean([p[1] for p in pts], axis=0)
        ks_ref = np.mean([p[2] for p in pts], axis=0)
        ef_ref = np.mean([p[2] * p[3] for p in pts], axis=0)
        np.testing.assert_allclose(k, k_ref, rtol=1e-5)
        np.testing.assert_allclose(e, e_ref, rtol=1e-5, atol=1e-5 * np.abs(e_ref).max())
        np.testing.assert_allclose(ks, ks_ref, rtol=1e-5, atol=1e-5 * ks_ref.max())
        np.testing.assert_allclose(ks * es, ef_ref, rtol=1e-5, atol=1e-5 * np.abs(ef_ref).max() + 1e-12)
        k2, e2 = rec.window_at(x, w)
        np.testing.assert_array_equal(k2, k)
        np.testing.assert_array_equal(e2, e)


def test_a_zero_window_is_the_point_read():
    rec = _records()
    x = np.array([3.217, 11.5])
    k, e, ks, es = rec.window_all_at(x, np.zeros(2))
    k0, e0, ks0, es0 = rec.all_at(x)
    np.testing.assert_array_equal(k, k0)
    np.testing.assert_array_equal(ks, ks0)


def test_the_fallback_solves_a_law_whose_force_jumps_over_the_root():
    """F = k delta + J (delta > 0), k delta (delta <= 0): with sigma J > delta_lin > 0 the residual
    delta + sigma F - delta_lin jumps from below zero to above it at delta = 0, so there is no root and Newton
    cycles; the fallback returns delta = 0 and F = delta_lin / sigma, between the law's one-sided limits 0 and J."""
    k, J, sigma, dt = 1.0, 10.0, 1.0, 1e-3
    delta_lin = np.array([2.0, 20.0])                      # case 2 has the ordinary root delta = 5

    def law(d, d_dot):
        return k * d + np.where(d > 0, J, 0.0), np.full_like(d, k), np.zeros_like(d)

    delta, F, bad = newmark.solve_mesh_law(delta_lin, np.zeros(2), np.full(2, sigma), dt, law)
    assert bad == 0
    assert abs(delta[0]) <= 1e-9 and 0.0 <= F[0] <= J
    np.testing.assert_allclose(delta[0] + sigma * F[0], delta_lin[0], rtol=1e-12)
    np.testing.assert_allclose([delta[1], F[1]], [5.0, 15.0], rtol=1e-12)
