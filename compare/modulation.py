"""Amplitude or frequency modulation: what the sidebands ``k f_m +/- f_s`` of a fluctuation say about the shafts.

A load that swings while the speed holds modulates the mesh tones' *amplitude*; a speed that swings modulates
their *phase* (frequency). On one accelerometer both put sidebands at ``k f_m +/- f_s``, and their levels can
match (a speed swing's sidebands grow with the harmonic ``k``, a load swing's do not, but a housing path reshapes
both): the comparison's views, which compare levels, cannot tell them apart (the speed/torque twins of
docs/compare_validation.md). Their *phases* can. With the carrier ``C``, upper ``U`` and lower ``L`` sideband of
harmonic ``k`` (complex amplitudes at the three frequencies),

    Q_k = U L / C^2

is free of the carrier's and the modulation's phases: ``(1 + m cos(w_s t)) cos(w_c t)`` gives ``U = L = m C / 2``,
``Q = m^2 / 4 > 0``; ``cos(w_c t + beta sin(w_s t))`` gives ``U = -L = J_1(beta) C / J_0(beta)``, ``Q < 0``
(Randall 2011, section 3.6.2; McFadden & Smith 1985). A linear path whose gain and phase change little across
``2 f_s`` keeps the sign. So the sign of ``Re Q_k`` over the harmonics whose sidebands stand out is the
modulation type: measured on the foreign rig of ``tests/foreign_rig.py``, its torque fluctuation (20 % at 37 Hz, the
speed held) gives ``cos(arg Q) = +0.98..+1.00`` at 8 of 10 harmonics, its speed fluctuation (1 % at 23 Hz)
``-0.99..-1.00`` at 8 of 10; gearpit's torque and speed fluctuations both give ``-0.8..-1.0`` (in its drive train
a load swing at 37 Hz also swings the speed, and that frequency modulation outweighs the amplitude modulation).

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley (amplitude and phase modulation of gear
    mesh tones, sideband phase relations).
McFadden, P. D., Smith, J. D. (1985). Proc. Inst. Mech. Eng. C 199(1), 65-70.
"""
from __future__ import annotations

import numpy as np

from features.spectra import line_phasors

#: a harmonic is read when both sidebands reach this fraction of its carrier
MIN_SIDEBAND_RATIO = 0.02
#: a harmonic is read when its carrier reaches this fraction of the strongest carrier among those read for
#: (a missing harmonic's carrier and sidebands are both leakage, with any ratio)
MIN_CARRIER_FRACTION = 1e-3
#: ``cos(arg Q)`` beyond which a harmonic counts as amplitude- (> +) or frequency- (< -) modulated, and the
#: median (the balance) beyond which a record does
COS_THRESHOLD = 0.5
#: mesh harmonics read at most
MAX_HARMONIC = 10


def line(x: np.ndarray, fs_hz: float, f_hz: float) -> complex:
    """Complex amplitude of the line at ``f_hz`` (:func:`features.spectra.line_phasors`, Hann window: a pure
    ``A cos(2 pi f t + p)`` gives ``A exp(i p)``)."""
    return complex(line_phasors(x, fs_hz, [f_hz])[0])


def sideband_lines(x, fs_hz: float, mesh_hz: float, f_s_hz: float, *, max_harmonic: int = MAX_HARMONIC) -> dict:
    """Harmonic ``k`` (1-based) -> the complex amplitudes ``(C, U, L)`` of ``k f_m``, ``k f_m + f_s`` and
    ``k f_m - f_s`` in ``x`` (mean removed), for the harmonics whose three lines lie in ``(0, fs/2)``."""
    x = np.asarray(x, dtype=float)
    x = x - x.mean()
    ks = [k for k in range(1, max_harmonic + 1) if k * mesh_hz + f_s_hz < 0.5 * fs_hz and k * mesh_hz - f_s_hz > 0]
    freqs = [f for k in ks for f in (k * mesh_hz, k * mesh_hz + f_s_hz, k * mesh_hz - f_s_hz)]
    z = line_phasors(x, fs_hz, freqs) if freqs else np.zeros(0, dtype=complex)
    return {k: tuple(z[3 * i:3 * i + 3]) for i, k in enumerate(ks)}


def read_harmonics(lines: dict) -> list:
    """The harmonics of :func:`sideband_lines` whose sidebands stand out: both at least
    :data:`MIN_SIDEBAND_RATIO` of the carrier, the carrier at least :data:`MIN_CARRIER_FRACTION` of the strongest
    (a missing harmonic's carrier and sidebands are both leakage, with any ratio)."""
    strongest = max((abs(v[0]) for v in lines.values()), default=0.0)
    return [k for k, (c, u, lo) in sorted(lines.items())
            if abs(c) > 0 and abs(c) >= MIN_CARRIER_FRACTION * strongest
            and min(abs(u), abs(lo)) >= MIN_SIDEBAND_RATIO * abs(c)]


def modulation_type(x, fs_hz: float, mesh_hz: float, f_s_hz: float, *, max_harmonic: int = MAX_HARMONIC) -> dict:
    """Read the modulation of the mesh harmonics at ``f_s_hz`` in ``x`` (module docstring).

    Returns
    -------
    dict
        ``amplitude`` and ``frequency``: harmonics read as amplitude / frequency modulation; ``read``: harmonics
        whose sidebands stand out (>= :data:`MIN_SIDEBAND_RATIO` of the carrier, the carrier >=
        :data:`MIN_CARRIER_FRACTION` of the strongest, carrier and sidebands below the Nyquist frequency);
        ``balance``: the median of ``cos(arg Q_k)`` over the read harmonics (+1: pure amplitude, -1: pure
        frequency modulation; a median, not a mean weighted by ``|Q_k|``: on the foreign torque record two
        harmonics near a resonance, with the largest sidebands and the opposite sign, outweighed the other eight);
        ``type``: "amplitude" for a balance above +:data:`COS_THRESHOLD`, "frequency" below its negative, "mixed"
        between, "none" when fewer than two harmonics are read; ``cos_arg_q``: per harmonic ``k`` (1-based) the
        value, None where not read.
    """
    lines = sideband_lines(x, fs_hz, mesh_hz, f_s_hz, max_harmonic=max_harmonic)
    read_ks = set(read_harmonics(lines))
    cos_q, am, fm, read = [], 0, 0, 0
    for k in range(1, max_harmonic + 1):
        if k not in read_ks:
            cos_q.append(None)
            continue
        c, u, lo = lines[k]
        q = u * lo / c ** 2
        v = float(q.real / abs(q))
        cos_q.append(v)
        read += 1
        am += v > COS_THRESHOLD
        fm += v < -COS_THRESHOLD
    balance = float(np.median([v for v in cos_q if v is not None])) if read else 0.0
    kind = ("none" if read < 2 else "amplitude" if balance > COS_THRESHOLD else
            "frequency" if balance < -COS_THRESHOLD else "mixed")
    return {"type": kind, "balance": float(balance), "amplitude": int(am), "frequency": int(fm), "read": int(read),
            "cos_arg_q": cos_q}


def modulation_text(measured: dict, model: dict, effect: str, f_s_hz: float) -> str:
    """What the measured and the model's sidebands at ``+/- f_s`` say; adds the diagnosis when they differ."""
    def say(d):
        return (f"{d['type']} modulation ({d[d['type']]} of {d['read']} mesh harmonics, balance "
                f"{d.get('balance', 0.0):+.2f})" if d["type"] in ("amplitude", "frequency") else
                f"{d['type']} ({d['read']} mesh harmonics read, balance {d.get('balance', 0.0):+.2f})")

    text = (f"sidebands at +/-{f_s_hz:.4g} Hz: measured {say(measured)}, the model with {effect} {say(model)}")
    if {measured["type"], model["type"]} == {"amplitude", "frequency"}:
        text += (": in the rig the " + ("load swings while the speed holds" if measured["type"] == "amplitude" else
                                        "speed swings") + ", in the model the "
                 + ("speed swings" if model["type"] == "frequency" else "load swings while the speed holds")
                 + "; the fit matches the sidebands' levels, not the shafts' motion (the drive train differs)")
    return text


__all__ = ["line", "modulation_text", "modulation_type", "read_harmonics", "sideband_lines"]
