"""The compiled loops of datagen.compiled_stepping against the numpy loops they replace (the periodic march's
per-step update: bit-equal, at the end of this file).

Reference: the numpy loop of ``datagen.newmark.run_general`` (checked against Radau, the periodic path and the
drive train's harmonic response in tests/test_dynamics*.py), run on the same cases with
``datagen.time_stepping.COMPILED = False``. Tolerance: 1e-9 of each channel's RMS (the compiled loop sums
the state products in another order and stops Newton per case; measured differences 3e-12).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest

import datagen.time_stepping as ts
from datagen.effects.backlash import Backlash
from datagen.effects.base import Effect, MeshState, register
from datagen.effects.registry import unregister
from datagen.geometry import spur_pair_example
from datagen.simulate import Case, OperatingPoint, SolverOptions, prepare, simulate

SPUR = spur_pair_example()


def _both(cases):
    out = {}
    for flag in (False, True):
        old = ts.COMPILED
        ts.COMPILED = flag
        try:
            out[flag] = simulate(cases)
        finally:
            ts.COMPILED = old
    return out[False], out[True]


def _assert_same(ref, got, rtol=1e-9):
    for a, b in zip(ref, got):
        assert a.metadata["solver"]["method"] == "transient"
        for k, x in a.channels.items():
            scale = np.sqrt(np.mean(np.square(x))) + 1e-300
            assert np.max(np.abs(b.channels[k] - x)) <= rtol * scale, k
        assert (b.metadata["solver"]["newton_unconverged_steps"]
                == a.metadata["solver"]["newton_unconverged_steps"])


def test_linear_law_with_modulations_and_an_eccentricity_equals_the_numpy_loop():
    """Speed fluctuation (operating-point hook), torque fluctuation, wheel eccentricity (mesh read at the
    pinion's actual angle over a record longer than a mesh cycle) in one batch: every channel equal to 1e-9."""
    base = Case(pair=SPUR, operating=OperatingPoint(1000.0, 50.0), duration_s=0.1, fs_hz=20000.0,
                solver=SolverOptions(method="transient", transient_s=0.02))
    cases = [replace(base, effects=({"name": "speed_fluctuation", "frequency_hz": 23.0, "amplitude_fraction": 0.01},)),
             replace(base, effects=({"name": "torque_fluctuation", "frequency_hz": 37.0, "amplitude_fraction": 0.2},)),
             replace(base, effects=({"name": "eccentricity_wheel", "amplitude_m": 50e-6},))]
    ref, got = _both(cases)
    _assert_same(ref, got)
    # the eccentricity's once-per-wheel-revolution modulation is there (not a trivially equal zero signal)
    assert np.std(got[2].channels["mesh_force_n"]) > 0.01 * np.mean(got[2].channels["mesh_force_n"])


def test_backlash_with_contact_loss_beside_a_linear_case_equals_the_numpy_loop():
    """Backlash at light load near the mesh resonance (the teeth separate; Newton per step) batched with the
    same case under the linear law: equal to 1e-9, the same count of unconverged Newton steps."""
    base = Case(pair=SPUR, operating=OperatingPoint(1500.0, 11.3), duration_s=0.04, fs_hz=20000.0)
    fn = prepare(base).model.natural_frequencies_hz[prepare(base).model.mesh_mode_index]
    rpm = 0.9 * fn * 60 / SPUR.pinion.teeth
    # one step for both (unset, the backlash case would take its finer step, Effect.max_omega_dt, and a batch of
    # its own): the two laws share a batch
    light = Case(pair=SPUR, operating=OperatingPoint(rpm, 0.5), duration_s=0.03, fs_hz=50000.0,
                 solver=SolverOptions(omega_dt=0.3, method="transient", transient_s=0.01))
    ref, got = _both([light, replace(light, effects=({"name": "backlash", "backlash_m": 50e-6},))])
    _assert_same(ref, got)
    F, F_lin = got[1].channels["mesh_force_n"], got[0].channels["mesh_force_n"]
    assert np.std(F - F_lin) > 0.1 * np.std(F_lin)       # contact loss happened


def test_the_scalar_backlash_law_is_the_batch_law():
    """Backlash.scalar_mesh_law (compiled, one case) equals Backlash.mesh_force_batch in value and both
    derivatives on random states across the three regimes (touching, inside the clearance, back flank)."""
    rng = np.random.default_rng(5)
    n = 200
    ks = rng.uniform(0, 3e8, (n, 3)) * (rng.random((n, 3)) > 0.2)
    es = rng.normal(0, 5e-6, (n, 3))
    b = rng.uniform(1e-6, 50e-6, n)
    delta = rng.normal(0, 20e-6, n)
    ddot = rng.normal(0, 0.05, n)
    mesh = MeshState(ks.sum(1), np.full(n, 700.0), (ks * es).sum(1), ks, es)
    F, dF, dFd = Backlash.mesh_force_batch({"backlash_m": b}, delta, ddot, mesh)
    from datagen.compiled_stepping import evaluate_law

    law = Backlash.scalar_mesh_law
    got = np.array([evaluate_law(law, np.array([b[i]]), delta[i], ddot[i], mesh.k_n_per_m[i], 700.0,
                                 mesh.error_force_n[i], np.ascontiguousarray(ks[i]), np.ascontiguousarray(es[i]))
                    for i in range(n)])
    np.testing.assert_allclose(got[:, 0], F, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(got[:, 1], dF, rtol=1e-12)
    np.testing.assert_allclose(got[:, 2], dFd, rtol=1e-12)
    assert 0 < np.mean(got[:, 1] == 0) < 1                # some states inside the dead zone, some not


class _SofteningPlugin(Effect):
    """A user's nonlinear mesh law without a compiled form: 10 % softer beyond 5 um of deflection."""

    name = "test_softening_plugin"
    signature = "test only"

    @classmethod
    def mesh_force_batch(cls, params, delta_m, delta_dot_m_s, mesh):
        over = delta_m > 5e-6
        k = np.where(over, 0.9, 1.0) * mesh.k_n_per_m
        f = (k * delta_m + np.where(over, 0.1 * mesh.k_n_per_m * 5e-6, 0.0) + mesh.c_n_s_per_m * delta_dot_m_s
             - mesh.error_force_n)
        return f, k, mesh.c_n_s_per_m


def test_a_law_without_a_compiled_form_runs_the_numpy_loop(monkeypatch):
    """The choice of loop: the linear law and backlash compile; a plugin's law without ``scalar_mesh_law``, or
    two nonlinear laws in one batch, take the numpy loop (and the plugin still simulates)."""
    from datagen.compiled_stepping import linear_law

    assert ts._compiled_law([], 3)[0] is linear_law
    bl = (Backlash, np.array([1]), {"backlash_m": np.array([5e-5])})
    law, row, P = ts._compiled_law([bl], 3)
    assert law is Backlash.scalar_mesh_law and row.tolist() == [-1, 0, -1] and P.tolist() == [[5e-5]]
    plug = (_SofteningPlugin, np.array([0]), {})
    assert ts._compiled_law([plug], 3) is None
    assert ts._compiled_law([bl, plug], 3) is None
    import datagen.compiled_stepping as cs

    def refuse(*a, **k):
        raise AssertionError("the compiled loop ran a law it has no compiled form of")

    monkeypatch.setattr(cs, "run_general", refuse)
    plugin = register(dataclass(frozen=True)(_SofteningPlugin))
    try:
        case = Case(pair=SPUR, operating=OperatingPoint(1000.0, 50.0), duration_s=0.06, fs_hz=20000.0,
                    effects=({"name": plugin.name},), solver=SolverOptions(method="transient", transient_s=0.01))
        lin = replace(case, effects=())
        soft, plain = simulate([case, lin])
    finally:
        unregister(plugin.name)          # keep the registry clean for other test modules
    # the plugin's law acted: the mesh deflection under 50 N m passes 5 um, so the softer mesh deflects more
    # (by ~0.07 um here; 0 if the law were ignored) under the same mean force
    assert np.mean(soft.channels["mesh_force_n"]) == pytest.approx(np.mean(plain.channels["mesh_force_n"]), rel=0.02)
    assert np.mean(soft.channels["dte_m"]) - np.mean(plain.channels["dte_m"]) > 0.02e-6


@pytest.mark.parametrize("helical", [False, True])
def test_compiled_linear_update_gives_the_numpy_march_to_the_bit(monkeypatch, helical):
    """``newmark.run_linear``'s per-step update runs compiled (``compiled_stepping.linear_update``): the same IEEE
    products and differences in the same order as the numpy lines kept as reference (``COMPILED_UPDATE =
    False``), so every channel must be bit-equal - on the periodic path (a pitted, eccentric spur pair with a
    pitch error; a helical pair with a profile error) and on the transient path's run_linear where used. A fused
    multiply-add or another summation order would fail it."""
    from datagen.pits import PitSpec

    from datagen import newmark
    from datagen.geometry import helical_pair_example

    pair = helical_pair_example() if helical else SPUR
    pits = {} if helical else dict(pits=PitSpec(shape="cluster", teeth=(1, 4), severity=(0.15, 0.08)), pit_grid=(32, 40))
    effects = (({"name": "profile_error", "grade": 6.0},) if helical else
               ({"name": "pitch_error", "grade": 7.0}, {"name": "eccentricity_pinion", "amplitude_m": 1.5e-5}))
    case = Case(pair=pair, operating=OperatingPoint(1300.0, 11.3), duration_s=0.1, fs_hz=12800.0,
                effects=effects, **pits)
    compiled = simulate([case])[0]
    monkeypatch.setattr(newmark, "COMPILED_UPDATE", False)
    reference = simulate([case])[0]
    assert compiled.metadata["solver"]["method"] == "periodic"
    for k in reference.channels:
        assert np.array_equal(compiled.channels[k], reference.channels[k]), k
