"""What a fitted drive-train fluctuation does to the shafts: the swing of the pinion speed and of the mesh force.

A fluctuation acts through the operating point (hook 5): a speed fluctuation's ``amplitude_fraction`` is the
swing of the *reference* of the model's speed controller (:mod:`datagen.lumped_model`, a PI loop of ~5 Hz
bandwidth), a torque fluctuation's the swing of the load torque. Neither is what a rig's tachometer, encoder or
torque meter shows: the drive train filters both. Measured on the 23/61-tooth pair of the foreign probe (1500 rpm,
80 N m): the pinion speed swings 1.14, 1.23, 0.72, 0.37, 0.30, 0.16 times the reference at 2, 5, 10, 19, 23,
40 Hz. A foreign record with a 1 % pinion speed swing at 19 Hz had its reference fitted at 2.67 %, i.e. a 0.99 %
swing of the pinion: the fit was right, its parameter is not the quantity a user would compare with the rig.

So every fitted candidate that acts through the operating point gets its *response* (:func:`fluctuation_response`):
the model with that candidate simulated on whole cycles of the fluctuation after a settling time, and the
amplitudes of the pinion speed and of the mesh force at the fluctuation frequency (one DFT bin over whole cycles,
i.e. a lock-in) as fractions of their means. With the comparison's reference it also gets the modulation type of
the sidebands at that frequency in the measurement and in the model (:mod:`compare.modulation`): a load swinging
while the speed holds makes amplitude modulation, a speed swing frequency modulation, and on one accelerometer the
two can match in level while the shafts move differently.
"""
from __future__ import annotations

import math

import numpy as np

from gearpit.errors import require

#: settling time before the analysed cycles (s): the speed loop's time constant is ~0.03 s, the drive train's
#: torsional modes decay within a few tenths
SETTLE_S = 0.5
#: fluctuation cycles analysed at least, and seconds at least
MIN_CYCLES = 10
MIN_SECONDS = 0.5
#: output rate of the response simulation (Hz); at least 8 samples per fluctuation cycle
FS_HZ = 5000.0


def acts_on_operating_point(effect_name: str) -> bool:
    """True for an effect with hook 5 (``operating_point``), a fluctuation frequency (``frequency_hz``) and an
    ``amplitude_fraction`` (a plugin acting on the operating point without them gets no response)."""
    from datagen.effects import get

    cls = get(effect_name)
    fields = getattr(cls, "__dataclass_fields__", {})
    return "operating_point" in cls.hooks() and "frequency_hz" in fields and "amplitude_fraction" in fields


def fluctuation_frequency(effect, speed_rpm: float) -> float:
    """The effect's fluctuation frequency (Hz): ``frequency_hz + order * pinion speed``."""
    from datagen.effects.speed_fluctuation import fluctuation_frequency_hz

    return fluctuation_frequency_hz(float(effect.frequency_hz), float(getattr(effect, "order", 0.0)), speed_rpm)


def line_amplitude(x: np.ndarray, f_hz: float, fs_hz: float) -> float:
    """Amplitude of the sinusoid at ``f_hz`` in ``x`` (whole cycles expected): ``2 |mean(x exp(-2 pi i f t))|``
    with the mean removed first.

    >>> t = np.arange(5000) / 5000.0
    >>> round(line_amplitude(3.0 + 0.2 * np.sin(2 * np.pi * 10 * t + 1.0), 10.0, 5000.0), 12)
    0.2
    """
    from features.spectra import line_amplitudes

    x = np.asarray(x, dtype=float)
    return float(line_amplitudes(x - x.mean(), fs_hz, [f_hz], window="boxcar")[0])


def fluctuation_response(model, pair, effect, *, speed_rpm: float, torque_nm: float) -> dict:
    """The swing of the pinion speed and of the mesh force that ``effect`` (a fluctuation) makes in ``model``.

    Parameters
    ----------
    model : compare.model.ComparisonModel
        The comparison's model (its effects stay in; ``effect`` replaces one of the same name).
    pair : datagen.geometry.GearPair
    effect : Effect
        A fitted effect acting through the operating point (:func:`acts_on_operating_point`).
    speed_rpm, torque_nm : float
        The measurement's operating point.

    Returns
    -------
    dict
        ``frequency_hz``; ``speed_pinion_amplitude_fraction`` and ``mesh_force_amplitude_fraction`` (amplitude at
        the fluctuation frequency over the channel's mean); ``reference_amplitude_fraction`` (the effect's own);
        ``mesh_force_min_fraction``: the mesh force's least value over its mean (below 0: the mesh pulls, the
        teeth would have separated: :func:`contact_state`).
    """
    from datagen.simulate import simulate

    require(acts_on_operating_point(effect.name), "effect", effect.name,
            "an effect with hook 5 (operating_point), a frequency_hz and an amplitude_fraction")
    f = fluctuation_frequency(effect, speed_rpm)
    require(math.isfinite(f) and f > 0, f"effects.{effect.name}.frequency_hz", f, "> 0 Hz")
    cycles = max(MIN_CYCLES, math.ceil(MIN_SECONDS * f))
    duration = cycles / f
    fs = max(FS_HZ, 8.0 * f)
    case = model.case(pair, speed_rpm=speed_rpm, torque_nm=torque_nm, duration_s=duration, fs_hz=fs,
                      extra_effects=(effect,), solver={"method": "transient", "transient_s": SETTLE_S})
    (sig,) = simulate([case], channels=["speed_pinion_rpm", "mesh_force_n"])
    out = {"frequency_hz": f, "reference_amplitude_fraction": float(effect.amplitude_fraction)}
    n = int(round(duration * sig.fs_hz))                     # whole cycles
    speed, force = (np.asarray(sig.channels[c], dtype=float)[:n] for c in ("speed_pinion_rpm", "mesh_force_n"))
    out["speed_pinion_amplitude_fraction"] = line_amplitude(speed, f, sig.fs_hz) / abs(float(speed.mean()))
    out["mesh_force_amplitude_fraction"] = line_amplitude(force, f, sig.fs_hz) / abs(float(force.mean()))
    out["mesh_force_min_fraction"] = float(force.min() / abs(force.mean()))
    out["contact"] = contact_state(out)
    return out


#: a least mesh force within this fraction of the mean of zero is contact lost, not tension (the backlash law's
#: zero force, read through the solver's rounding)
CONTACT_LOSS_TOL = 1e-3


def contact_state(response: dict) -> str:
    """"kept" (the mesh force stays positive over the fluctuation), "lost" (it touches zero: the teeth separate,
    as a model with backlash lets them) or "tension" (it goes below zero: the teeth would have separated, and the
    model, without backlash, let the mesh pull them together instead; the fitted amplitude is then outside what
    a mesh that only pushes can make)."""
    m = response.get("mesh_force_min_fraction")
    if m is None or m > CONTACT_LOSS_TOL:
        return "kept"
    return "lost" if m >= -CONTACT_LOSS_TOL else "tension"


#: shaft orders checked by :func:`shaft_order_of`
MAX_SHAFT_ORDER = 3


def shaft_order_of(f_hz: float, speed_rpm: float, pinion_teeth: int, wheel_teeth: int,
                   resolution_hz: float) -> dict | None:
    """The shaft order ``f_hz`` sits on, if any: ``{"shaft": "pinion" or "wheel", "order": k}`` for the first
    ``k`` in 1..:data:`MAX_SHAFT_ORDER` (pinion first) with ``|f - k f_shaft| <= resolution_hz``, else None.

    A fluctuation locked to a shaft's rotation and a once-per-revolution error of that shaft (an eccentricity,
    a cumulative pitch error) put the same sidebands around the mesh harmonics: on the foreign rig's random-walk
    pitch error (seed 6) a torque fluctuation at the pinion's 16.67 Hz was claimed, 66.5 % against the pinion
    eccentricity's 64.3 %. On an accelerometer the two are told apart only by a channel that sees the shaft's
    speed or the mesh torque.

    >>> shaft_order_of(16.66, 1000.0, 29, 100, 0.5)
    {'shaft': 'pinion', 'order': 1}
    >>> shaft_order_of(37.0, 1000.0, 29, 100, 0.5) is None
    True
    """
    fr = {"pinion": speed_rpm / 60.0, "wheel": speed_rpm / 60.0 * pinion_teeth / wheel_teeth}
    for shaft in ("pinion", "wheel"):
        for k in range(1, MAX_SHAFT_ORDER + 1):
            if abs(f_hz - k * fr[shaft]) <= resolution_hz:
                return {"shaft": shaft, "order": k}
    return None


def revolution_shafts(effect, pair) -> list[str]:
    """The shafts with whose revolution a displacement effect's deviation repeats (hooks 2a-2c): ``"pinion"`` and/or
    ``"wheel"`` when its period in mesh cycles (:meth:`datagen.effects.base.Effect.deviation_period_cycles`) is a
    whole number of that gear's revolutions, i.e. a once-per-revolution error of that shaft (an eccentricity, a
    cumulative pitch error); empty for an effect alike on every tooth or one acting otherwise."""
    from datagen.effects.base import EffectContext

    if not ({"tooth_deviation_m", "angle_deviation_m", "centre_offset_m"} & effect.hooks()):
        return []
    period = int(effect.deviation_period_cycles(EffectContext(pair=pair, speed_rpm=0.0, torque_nm=0.0)))
    teeth = {"pinion": pair.pinion.teeth, "wheel": pair.wheel.teeth}
    return [s for s, z in teeth.items() if period > 1 and period % z == 0]


def mark_shaft_locks(candidates, pair, *, speed_rpm: float, resolution_hz: float) -> None:
    """Set ``shaft_lock`` of each fitted candidate (:func:`compare.candidates.shaft_locked_twin` reads it): a
    fluctuation whose frequency sits on a shaft order within ``resolution_hz`` (:func:`shaft_order_of`) gets
    ``{"kind": "fluctuation", "shaft": ..., "order": k}``, a once-per-revolution error (:func:`revolution_shafts`)
    ``{"kind": "revolution", "shafts": [...]}``; every other candidate keeps ``{}``."""
    for c in candidates:
        if not c.params:
            continue
        effect = c.build_effect()
        if acts_on_operating_point(c.effect):
            at = shaft_order_of(fluctuation_frequency(effect, speed_rpm), speed_rpm, pair.pinion.teeth,
                                pair.wheel.teeth, resolution_hz)
            c.shaft_lock = {"kind": "fluctuation", **at} if at else {}
        else:
            shafts = revolution_shafts(effect, pair)
            c.shaft_lock = {"kind": "revolution", "shafts": shafts} if shafts else {}


def response_text(response: dict, effect: str = "it") -> str:
    """One line on what a fitted fluctuation does to the shafts (CLI, report, messages); with the modulation
    types, a second sentence on them (:func:`compare.modulation.modulation_text`)."""
    from compare.modulation import modulation_text

    mod = response.get("modulation")
    tail = ("; " + modulation_text(mod["measured"], mod["model"], effect, response["frequency_hz"])) if mod else ""
    locked = response.get("shaft_order")
    if locked:
        tail += (f"; {response['frequency_hz']:.4g} Hz is the {locked['shaft']}'s order {locked['order']} within "
                 f"the record's resolution: a once-per-revolution error of that shaft (eccentricity, pitch error) "
                 f"makes the same sidebands, and only a speed or torque channel tells them apart")
    state = contact_state(response)
    if state == "tension":
        tail += (f"; the mesh force then falls to {100 * response['mesh_force_min_fraction']:.3g} % of its mean: the "
                 "teeth would separate, and this model (no backlash) lets the mesh pull instead, so a swing this "
                 "large is outside what the model can make; add backlash, or read the fit as 'stronger sidebands "
                 "than a fluctuation that keeps the teeth in contact makes', not as the rig's swing")
    elif state == "lost":
        tail += "; the mesh force touches zero: the teeth separate in the model over part of each cycle"
    return (f"in the model the pinion speed swings +/-{100 * response['speed_pinion_amplitude_fraction']:.3g} % "
            f"and the mesh force +/-{100 * response['mesh_force_amplitude_fraction']:.3g} % at "
            f"{response['frequency_hz']:.4g} Hz (the fitted amplitude_fraction "
            f"{response['reference_amplitude_fraction']:.4g} is what enters the drive train: the speed "
            f"controller's reference or the load torque)" + tail)


def modulations(reference, model, effect, f_hz: float) -> dict:
    """The modulation type of the sidebands at ``f_hz`` (:func:`compare.modulation.modulation_type`) in the
    measurement of ``reference`` and in ``model`` with ``effect``, simulated as the comparison does."""
    from compare.comparison import simulate_model
    from compare.modulation import modulation_type

    mesh_hz = reference.measurement.pair.pinion.teeth * reference.speed.speed_rpm / 60.0
    (y,) = simulate_model(reference, model, extra_effects_list=((effect,),))
    return {"measured": modulation_type(reference.x, reference.fs_hz, mesh_hz, f_hz),
            "model": modulation_type(y, reference.fs_hz, mesh_hz, f_hz)}


def attach_responses(candidates, model, pair, *, speed_rpm: float, torque_nm: float, limit: int = 2,
                     reference=None) -> int:
    """Set ``response`` of the fitted candidates (status "fitted", reduction > 0) that act through the operating
    point, at most ``limit`` of them in list order; returns how many were set. With the comparison's
    ``reference`` also ``response["modulation"]``: the modulation type of the sidebands at the fluctuation
    frequency in the measurement and in the model with the candidate (:mod:`compare.modulation`)."""

    n = 0
    for c in candidates:
        if n >= limit:
            break
        if c.status != "fitted" or not (c.reduction > 0) or not acts_on_operating_point(c.effect):
            continue
        effect = c.build_effect()
        fitted = model.with_drivetrain(c.nuisance) if c.nuisance else model      # e.g. a sideband refit's inertia
        c.response = fluctuation_response(fitted, pair, effect, speed_rpm=speed_rpm, torque_nm=torque_nm)
        if reference is not None:
            c.response["modulation"] = modulations(reference, fitted, effect, c.response["frequency_hz"])
            c.response["shaft_order"] = shaft_order_of(c.response["frequency_hz"], speed_rpm, pair.pinion.teeth,
                                                       pair.wheel.teeth, reference.fs_hz / reference.x.size)
        n += 1
    return n


__all__ = ["acts_on_operating_point", "attach_responses", "contact_state", "fluctuation_response", "line_amplitude",
           "mark_shaft_locks", "modulations", "response_text", "revolution_shafts", "shaft_order_of"]
