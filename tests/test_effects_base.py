"""The effect contract (datagen.effects.base): registry, parameter bounds, specs, plugins, hook dispatch.

Reference: DESIGN.md "Effects" (seven contribution points; the integrator knows the points, never the
effects). Each test states what would break if the contract were violated.
"""
from __future__ import annotations

import textwrap
from dataclasses import dataclass, field, replace

import numpy as np
import pytest

import datagen.effects as fx
from datagen.effects.base import Effect, EffectSpec, build_effects, load_plugin, register, unregister
from datagen.geometry import spur_pair_example
from datagen.simulate import Case, OperatingPoint, SolverOptions, simulate
from gearpit.errors import InputError

SPUR = spur_pair_example()
BASE = Case(pair=SPUR, operating=OperatingPoint(1500.0, 11.3), duration_s=0.04, fs_hz=20000.0)


def test_registry_lists_builtins_with_units_bounds_and_signature():
    """Every registered effect has a name, a one-line signature and unit + bounds/choices on every field."""
    assert {"noise", "transmission_path", "backlash"} <= set(fx.names())
    for name in fx.names():
        cls = fx.get(name)
        assert cls.name == name and cls.signature and "\n" not in cls.signature
        assert cls.hooks(), name
        for row in cls.parameter_table():
            assert row["unit"] and ("bounds" in row or "choices" in row)


def test_hooks_are_detected_from_overrides():
    """hooks() names exactly the overridden contribution points (the integrator dispatches on it)."""
    assert fx.get("noise").hooks() == {"measurement"}
    assert fx.get("transmission_path").hooks() == {"output_path"}
    assert fx.get("backlash").hooks() == {"mesh_force_batch"}
    assert fx.get("backlash")().is_nonlinear and not fx.get("noise")().is_nonlinear


def test_unknown_names_params_and_out_of_bounds_values_raise():
    """Unknown effect, unknown parameter, value outside bounds, wrong choice: InputError naming the field."""
    with pytest.raises(InputError, match="effects.name"):
        EffectSpec.from_dict({"name": "nosie"})
    with pytest.raises(InputError, match="snr"):
        EffectSpec.from_dict({"name": "noise", "snr": 30})
    with pytest.raises(InputError, match="backlash_m"):
        EffectSpec.from_dict({"name": "backlash", "backlash_m": -1e-6})
    with pytest.raises(InputError, match="channels"):
        fx.get("noise")(channels="some")
    with pytest.raises(InputError, match="at most one nonlinear"):
        build_effects([{"name": "backlash"}, fx.get("backlash")(backlash_m=1e-5)])


def test_spec_from_string_and_toml_dict_build_the_same_effect():
    """CLI form name:key=value and the TOML table give equal parameters (ints accepted for floats)."""
    a = EffectSpec.from_string("noise:snr_db=30,channels=all").build()
    b = EffectSpec.from_dict({"name": "noise", "snr_db": 30, "channels": "all"}).build()
    assert a == b and a.snr_db == 30.0 and isinstance(a.snr_db, float)


def test_register_rejects_fields_without_unit_or_bounds_and_name_clashes():
    """A parameter without unit/bounds or a default, or a second class under a taken name, is refused."""
    with pytest.raises(InputError, match="unit"):
        @register
        @dataclass(frozen=True)
        class NoUnit(Effect):
            name = "no_unit_test"
            signature = "none"
            gain: float = 1.0

    assert "no_unit_test" not in fx.names()
    with pytest.raises(InputError, match="not yet taken"):
        @register
        @dataclass(frozen=True)
        class Clash(Effect):
            name = "noise"
            signature = "none"


def test_noise_same_seed_same_bytes_other_seed_differs():
    """Measurement-chain randomness comes only from the case seed (same seed -> identical bytes)."""
    case = replace(BASE, effects=({"name": "noise", "snr_db": 20.0},), seed=5)
    a, b, c = simulate([case, case, replace(case, seed=6)])
    x = a.channels["acc_pinion_loa_m_s2"]
    assert x.tobytes() == b.channels["acc_pinion_loa_m_s2"].tobytes()
    assert not np.allclose(x, c.channels["acc_pinion_loa_m_s2"])
    clean = simulate([BASE])[0].channels["acc_pinion_loa_m_s2"]
    snr = 20 * np.log10(np.std(clean) / np.std(x - clean))
    assert snr == pytest.approx(20.0, abs=0.5)          # noise rms = signal rms / 10^(20/20)


def test_transmission_path_amplifies_near_housing_resonance():
    """Housing SDOF accelerance (Ewins 2000): at the housing resonance |A/F| = 1/(2 zeta m); the output
    acceleration equals the bearing force filtered by it (checked on the f_m line, 1 %)."""
    fm = SPUR.mesh_frequency_hz(1500.0)
    tp = {"name": "transmission_path", "housing_mass_kg": 2.0, "housing_frequency_hz": 2 * fm,
          "housing_damping_ratio": 0.05}
    s = simulate([replace(BASE, effects=(tp,))])[0]
    from datagen.effects.transmission_path import housing_accelerance

    n = s.n_samples
    F = np.fft.rfft(s.channels["force_bearing_pinion_loa_n"])
    A = np.fft.rfft(s.channels["acc_pinion_loa_m_s2"])
    b1, b2 = round(fm * n / s.fs_hz), round(2 * fm * n / s.fs_hz)
    h = housing_accelerance(np.array([fm, 2 * fm]), 2.0, 2 * fm, 0.05)
    np.testing.assert_allclose(np.abs(A[[b1, b2]]), np.abs(F[[b1, b2]] * h), rtol=0.01)
    assert abs(h[1]) == pytest.approx(1 / (2 * 0.05 * 2.0), rel=1e-9)


def test_user_plugin_registers_and_is_used_without_integrator_edit(tmp_path):
    """A user's file with @register adds an effect (hook 2b, run-out of the wheel) usable by name;
    the simulated housing acceleration then carries wheel shaft-order sidebands (period = one wheel
    revolution), absent without it."""
    plugin = tmp_path / "my_runout.py"
    plugin.write_text(textwrap.dedent('''
        from dataclasses import dataclass, field
        import numpy as np
        from datagen.effects.base import Effect, register

        @register
        @dataclass(frozen=True)
        class TestRunout(Effect):
            name = "test_runout"
            signature = "wheel shaft order 1 sidebands"
            amplitude_m: float = field(default=5e-6, metadata={"unit": "m", "bounds": (0.0, 1e-4)})

            def deviation_period_cycles(self, ctx):
                return ctx.pair.wheel.teeth

            def angle_deviation_m(self, theta_pinion_rad, theta_wheel_rad, ctx):
                return self.amplitude_m * np.sin(theta_wheel_rad)
    '''))
    added = load_plugin(plugin)
    assert added == ["test_runout"]
    try:
        _check_runout_plugin()
    finally:
        unregister("test_runout")         # keep the registry clean for other test modules


def _check_runout_plugin():
    t_wheel = 60 / 1500.0 * SPUR.wheel.teeth / SPUR.pinion.teeth
    case = Case(pair=SPUR, operating=OperatingPoint(1500.0, 11.3), duration_s=2 * t_wheel, fs_hz=5800.0,
                effects=({"name": "test_runout", "amplitude_m": 10e-6},))
    s, h = simulate([case, replace(case, effects=())])
    assert s.metadata["solver"]["period_cycles"] == SPUR.wheel.teeth
    fr2 = SPUR.shaft_frequency_hz("wheel", 1500.0)
    fm = SPUR.mesh_frequency_hz(1500.0)

    def line(x, f):                     # 2 wheel revolutions: f_r2 and f_m + f_r2 are exact DFT bins
        t = np.arange(x.size) / 5800.0
        return abs(np.mean((x - x.mean()) * np.exp(-2j * np.pi * f * t))) * 2

    x, y = s.channels["mesh_force_n"], h.channels["mesh_force_n"]
    assert line(x, fr2) > 1e3 * max(line(y, fr2), 1e-12)
    assert line(x, fm + fr2) > 1e3 * max(line(y, fm + fr2), 1e-12)


def test_generalized_force_hook_reaches_the_right_dof():
    """Hook 3: a constant extra torque on the load shaft (a test-local effect) changes the static mesh force
    by exactly torque * z1/z2 / rb1 (torque balance; 1e-3), and forces the time-stepping path."""
    @register
    @dataclass(frozen=True)
    class ExtraLoad(Effect):
        name = "test_extra_load"
        signature = "static load change only"
        torque_nm: float = field(default=1.0, metadata={"unit": "N m", "bounds": (-100.0, 100.0)})

        def generalized_force(self, t_s, theta_pinion_rad, theta_wheel_rad, ctx):
            f = np.zeros((len(t_s), len(ctx.dof_names)))
            f[:, ctx.dof_index("phi_b")] = -self.torque_nm
            return f

    case = replace(BASE, effects=({"name": "test_extra_load", "torque_nm": 2.0},),
                   solver=SolverOptions(transient_s=0.3))
    try:
        s = simulate([case])[0]
    finally:
        unregister("test_extra_load")
    assert s.metadata["solver"]["method"] == "transient"
    # a constant extra load torque is not balanced by the motor feed-forward: the speed controller
    # supplies it, so the mesh carries it too
    z1, z2 = SPUR.pinion.teeth, SPUR.wheel.teeth
    expected = (11.3 + 2.0 * z1 / z2) / SPUR.base_radius_m("pinion")
    assert np.mean(s.channels["mesh_force_n"]) == pytest.approx(expected, rel=1e-3)


def test_coloured_noise_snr_and_spectral_slope():
    """Noise effect: the requested SNR holds for every colour (0.3 dB) and the PSD slope of the added noise is
    0, -1, -2 decades per decade for white, pink, brown (Welch estimate, 0.25 tolerance)."""
    from scipy.signal import welch

    from datagen.effects import get
    from datagen.effects.base import EffectContext
    from datagen.geometry import spur_pair_example

    ctx = EffectContext(pair=spur_pair_example(), speed_rpm=1000.0, torque_nm=10.0, fs_hz=10000.0, duration_s=2.0)
    x = np.sin(2 * np.pi * 480 * np.arange(20000) / 1e4)
    for colour, slope in (("white", 0.0), ("pink", -1.0), ("brown", -2.0)):
        eff = get("noise")(snr_db=20.0, colour=colour)
        out = eff.measurement({"acc_pinion_loa_m_s2": x}, 1e4, np.random.default_rng(0), ctx)
        n = out["acc_pinion_loa_m_s2"] - x
        assert 20 * np.log10(np.std(x) / np.std(n)) == pytest.approx(20.0, abs=0.3)
        f, p = welch(n, fs=1e4, nperseg=2048)
        band = (f > 20) & (f < 2000)
        fitted = np.polyfit(np.log10(f[band]), np.log10(p[band]), 1)[0]
        assert fitted == pytest.approx(slope, abs=0.25)


def test_fit_declarations_of_the_builtins_resolve_inside_the_field_bounds():
    """Every registered effect's fit_parameters resolve (DESIGN.md: the bounds are what the comparison fits
    within): numeric entries have bounds inside the field's and a log or linear scale, at most one string
    option; phases are never fitted (amplitude spectra do not see them)."""
    from dataclasses import fields as dc_fields

    for name in fx.names():
        cls = fx.get(name)
        fits, choice = cls.fit_declaration()
        meta = {f.name: f.metadata for f in dc_fields(cls)}
        for f in fits:
            lo, hi = meta[f.name]["bounds"]
            assert lo <= f.bounds[0] < f.bounds[1] <= hi and f.scale in ("log", "linear"), (name, f)
            assert meta[f.name]["unit"] != "rad", (name, f)
        assert choice is None or choice[1] == tuple(meta[choice[0]]["choices"])
    fits, choice = fx.get("transmission_path").fit_declaration()
    assert [f.name for f in fits] == ["housing_frequency_hz", "housing_damping_ratio"] and choice is None
    assert fx.get("hertz_nonlinear").fit_declaration() == ((), None)


def test_plugin_fit_declaration_is_read_by_the_comparison_and_bad_ones_are_refused(tmp_path):
    """A plugin declares its fitted parameters like a built-in (Fit with narrower bounds and a scale); the
    comparison's fit space takes them as declared. A declaration naming no field, or bounds outside the
    field's, is refused at registration."""
    from compare.fitspace import fit_space
    from datagen.effects.base import Fit

    plugin = tmp_path / "my_wobble.py"
    plugin.write_text(textwrap.dedent('''
        from dataclasses import dataclass, field
        from datagen.effects.base import Effect, Fit, register

        @register
        @dataclass(frozen=True)
        class TestWobble(Effect):
            name = "test_wobble"
            signature = "sensor gain modulated once per wheel revolution"
            depth: float = field(default=0.1, metadata={"unit": "-", "bounds": (0.0, 0.9)})
            rate: float = field(default=1.0, metadata={"unit": "-", "bounds": (0.0, 10.0)})
            fit_parameters = (Fit("depth", bounds=(0.0, 0.5), scale="linear"),)

            def measurement(self, channels, fs_hz, rng, ctx):
                return channels
    '''))
    assert load_plugin(plugin) == ["test_wobble"]
    try:
        space = fit_space(fx.get("test_wobble"))
        assert [(p.name, p.lo, p.hi, p.log) for p in space.params] == [("depth", 0.0, 0.5, False)]
    finally:
        unregister("test_wobble")
    for bad, match in (((Fit("depht"),), "fit_parameters"), ((Fit("depth", bounds=(0.0, 2.0)),), "bounds")):
        cls = type("TestBad", (Effect,), {"__annotations__": {"depth": float},
                                          "depth": field(default=0.1, metadata={"unit": "-", "bounds": (0.0, 0.9)}),
                                          "name": "test_bad", "signature": "nothing", "fit_parameters": bad,
                                          "measurement": lambda self, ch, fs, rng, ctx: ch})
        with pytest.raises(InputError, match=match):
            register(dataclass(frozen=True)(cls))
    assert "test_bad" not in fx.names()
