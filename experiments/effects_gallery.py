"""Effects gallery: every registered effect on the spur preset, with and without, and its measured signature.

Case: spur-gds (29/100 teeth), 1500 rpm (f_m = 725 Hz, fr_pinion = 25 Hz, fr_wheel = 7.25 Hz), 20 N m,
10 kHz, 1 s kept after a 0.5 s start-up. All cases are time-stepped in one batch (so that the healthy
reference and every effect share the solver path; a wheel-borne error on 29/100 teeth would need the
4 s hunting period for the periodic solver). For each effect: a figure (amplitude spectrum in dB and
envelope spectrum of the pinion bearing-housing acceleration, healthy vs with the effect) in
``experiments/out/effects/<label>.png`` and a printed table of the dB change at the lines its
signature names (lines: Blackman-Harris window, main lobe +/-4 Hz in 1 s, so the +/-7.25 Hz wheel
sidebands are resolved; bands: rms from a Hann spectrum). The last column gives the line re the f_m
line of the same signal: changes of lines below about -80 dB re f_m are the solver's numerical floor
(a comb of pinion orders that both solver paths leave in the healthy record), not the effect.
Effects registered by plugins are run with their defaults and the generic lines.

Usage: python experiments/effects_gallery.py [--out experiments/out/effects] [--duration 1.0]
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import datagen.effects as fx
from datagen.effects.tip_relief import design_relief_m
from datagen.geometry import spur_pair_example
from datagen.simulate import Case, OperatingPoint, SolverOptions, StiffnessOptions, simulate
from datagen.stiffness import mesh_stiffness
from effects_gallery_plot import plot_effect_spectra  # sibling module (the script directory is on sys.path)
from features.envelope import envelope_spectrum
from features.spectra import amplitude_spectrum, line_amplitudes

PAIR = spur_pair_example()
RPM, TORQUE, FS = 1500.0, 20.0, 10000.0
FR1 = RPM / 60.0
FM = PAIR.mesh_frequency_hz(RPM)
FR2 = PAIR.shaft_frequency_hz("wheel", RPM)
F_FLUCT = 12.5
ACC = "acc_pinion_loa_m_s2"
PPC = 32


def gallery_effects() -> dict[str, tuple[dict, ...]]:
    """Label -> effects of that case (parameters chosen to show the signature; SI)."""
    c_a = design_relief_m(mesh_stiffness(PAIR, positions_per_cycle=PPC), TORQUE)
    chosen = {
        "profile_error": {"name": "profile_error", "grade": 6.0, "cycles": 2.0},
        "pitch_error_pinion": {"name": "pitch_error", "grade": 6.0, "gears": "pinion", "single_tooth_factor": 2.0},
        "pitch_error_wheel": {"name": "pitch_error", "grade": 6.0, "gears": "wheel"},
        "tip_relief": {"name": "tip_relief", "amount_m": c_a, "length_fraction": 1.0, "shape": "linear"},
        "eccentricity_pinion": {"name": "eccentricity_pinion", "amplitude_m": 10e-6},
        "eccentricity_wheel": {"name": "eccentricity_wheel", "amplitude_m": 10e-6},
        "speed_fluctuation": {"name": "speed_fluctuation", "amplitude_fraction": 0.01, "frequency_hz": F_FLUCT},
        "torque_fluctuation": {"name": "torque_fluctuation", "amplitude_fraction": 0.2, "frequency_hz": F_FLUCT},
        "hertz_nonlinear": {"name": "hertz_nonlinear"},
        "backlash": {"name": "backlash", "backlash_m": 100e-6},
        "noise": {"name": "noise", "snr_db": 20.0},
        "transmission_path": {"name": "transmission_path"},
    }
    shown = {d["name"] for d in chosen.values()}
    for name in fx.names():                       # plugins and anything added later: defaults
        if name not in shown:
            chosen[name] = {"name": name}
    return {label: (d,) for label, d in chosen.items()}


def signature_lines(label: str) -> dict[str, float | tuple[float, float]]:
    """Named lines (Hz) or bands ((lo, hi) Hz) that the effect's signature speaks of."""
    mesh = {"fm": FM, "2fm": 2 * FM, "3fm": 3 * FM}
    side1 = {"fm-fr1": FM - FR1, "fm+fr1": FM + FR1}
    side2 = {"fm-fr2": FM - FR2, "fm+fr2": FM + FR2}
    fluct = {"f": F_FLUCT, "fm-f": FM - F_FLUCT, "fm+f": FM + F_FLUCT, "2fm-f": 2 * FM - F_FLUCT}
    table = {
        "profile_error": {**mesh, **side1, **side2},
        "pitch_error_pinion": {"fr1": FR1, "2fr1": 2 * FR1, "3fr1": 3 * FR1, **side1},
        "pitch_error_wheel": {"fr2": FR2, "2fr2": 2 * FR2, **side2, **side1},
        "tip_relief": mesh,
        "eccentricity_pinion": {"fr1": FR1, **side1, **side2},
        "eccentricity_wheel": {"fr2": FR2, **side2, **side1},
        "speed_fluctuation": {"fm": FM, **fluct},
        "torque_fluctuation": {"fm": FM, **fluct},
        "hertz_nonlinear": mesh,
        "backlash": {"fm/2": FM / 2, **mesh, "band 3.7-4 kHz": (3700.0, 4000.0)},
        "noise": {"fm": FM, "band 3.7-4 kHz": (3700.0, 4000.0), "band 50-500 Hz": (50.0, 500.0)},
        "transmission_path": {**mesh, "band 2.5-3.5 kHz": (2500.0, 3500.0)},
    }
    return table.get(label, {**mesh, **side1, **side2, "fr1": FR1, "fr2": FR2})


def measure(x: np.ndarray, named: dict) -> dict[str, float]:
    """Amplitude of each named line (Blackman-Harris, -92 dB sidelobes, no scalloping) or rms of each band (Hann)."""
    x = x - x.mean()
    f, a = amplitude_spectrum(x, FS, window="hann")
    out = {}
    for name, where in named.items():
        if isinstance(where, tuple):
            keep = (f >= where[0]) & (f <= where[1])
            out[name] = float(np.sqrt(np.sum(a[keep] ** 2) / 2 / 1.5))   # Hann ENBW 1.5 bins
        else:
            out[name] = float(line_amplitudes(x, FS, [where], window="blackmanharris")[0])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("experiments/out/effects"))
    ap.add_argument("--duration", type=float, default=1.0, help="kept record (s)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    effects = gallery_effects()
    solver = SolverOptions(method="transient", transient_s=0.5)

    def case(e):
        return Case(pair=PAIR, operating=OperatingPoint(RPM, TORQUE), duration_s=args.duration, fs_hz=FS, effects=e,
                    stiffness=StiffnessOptions(positions_per_cycle=PPC), solver=solver)

    labels = ["healthy", *effects]
    runs = dict(zip(labels, simulate([case(())] + [case(e) for e in effects.values()])))
    healthy = runs["healthy"]
    band = (0.5 * FM, min(3.5 * FM, 0.4 * FS))
    print(f"spur-gds {RPM:g} rpm, {TORQUE:g} N m: fm {FM:g} Hz, fr1 {FR1:g} Hz, fr2 {FR2:.4g} Hz; channel {ACC}")
    print(f"{'effect':22s} {'line':16s} {'healthy':>11s} {'with':>11s} {'change dB':>10s} {'with re fm dB':>14s}")
    for label in effects:
        run = runs[label]
        named = signature_lines(label)
        h, w = measure(healthy.channels[ACC], named), measure(run.channels[ACC], named)
        fm_with = measure(run.channels[ACC], {"fm": FM})["fm"]
        name = effects[label][0]["name"]
        print(f"{label:22s} signature: {fx.get(name).signature}")
        for line in named:
            change = 20 * math.log10(w[line] / h[line]) if h[line] > 0 and w[line] > 0 else float("nan")
            rel = 20 * math.log10(w[line] / fm_with) if w[line] > 0 else float("nan")
            print(f"{'':22s} {line:16s} {h[line]:11.3e} {w[line]:11.3e} {change:10.1f} {rel:14.1f}")
        if name == "hertz_nonlinear":
            k0, k1 = (r.metadata["mean_mesh_stiffness_n_per_m"] for r in (healthy, run))
            f0, f1 = (r.metadata["solver"]["natural_frequencies_hz"][-1] for r in (healthy, run))
            print(f"{'':22s} mean mesh stiffness {k0 / 1e6:.1f} -> {k1 / 1e6:.1f} N/um ({100 * (k1 / k0 - 1):+.1f} %), "
                  f"mesh mode {f0:.0f} -> {f1:.0f} Hz")
        lines = {k: v for k, v in named.items() if not isinstance(v, tuple)}
        plot_effect_spectra(
            args.out / f"{label}.png", title=f"{label}: {fx.get(name).signature}",
            spectrum={"healthy": amplitude_spectrum(healthy.channels[ACC] - healthy.channels[ACC].mean(), FS),
                      label: amplitude_spectrum(run.channels[ACC] - run.channels[ACC].mean(), FS)},
            envelope={"healthy": envelope_spectrum(healthy.channels[ACC], FS, band_hz=band),
                      label: envelope_spectrum(run.channels[ACC], FS, band_hz=band)},
            lines=lines, f_max_hz=0.4 * FS, env_max_hz=120.0, unit="m/s2")
    print(f"figures: {args.out}/<effect>.png")


if __name__ == "__main__":
    main()
