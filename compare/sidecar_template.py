"""A sidecar to fill in, written beside a measurement that has none.

A recording from another rig arrives without the operating point gearpit needs (:mod:`compare.sidecar`).
Rather than only refusing it, :func:`write_template` reads the file (its layout, channel names and any rate it
states) and writes ``<file>.toml.template`` beside it: every key the comparison needs, the file's own channel
names in place (listed beside ``sensor``), the required values left at 0 or empty (``pair = ""``, ``sensor = ""``),
never a valid value, so that an unfilled template is refused by name. It is never
read as a sidecar until the user saves it as ``<stem>.toml``.
"""
from __future__ import annotations

from pathlib import Path

from gearpit.atomic import atomic_path

TEMPLATE_SUFFIX = ".toml.template"


def write_template(measurement_path: str | Path) -> Path | None:
    """Write the template beside ``measurement_path``; None when the file cannot be read (its own error then
    says why) or a template is there already."""
    from compare.formats import read_record
    from datagen.geometry import PRESETS
    from gearpit.errors import GearpitError

    p = Path(measurement_path)
    out = p.with_name(p.name + TEMPLATE_SUFFIX)
    if out.exists():
        return None
    try:
        rec = read_record(p)
    except (GearpitError, OSError, ValueError):
        return None
    names = list(rec.names)
    # a pulse channel by its name: tach/key/pulse first, "rpm" only after (gearpit simulate writes both
    # tacho_pinion and speed_pinion_rpm, a speed signal, not pulses)
    tacho = next((n for words in (("tach", "key", "pulse"), ("rpm",)) for n in names
                  if any(w in n.lower() for w in words)), None)
    sensor = next((n for n in names if n != tacho), names[0])
    fs = rec.fs_hz if rec.fs_hz is not None else rec.hints.get("fs_hz")
    lines = [f"# sidecar of {p.name}, written by gearpit because none was found beside it: fill it in and save it",
             f"# as {p.stem}.toml (README, \"Model versus measurement\"). Channels in the file: {', '.join(names)}.",
             (f"# fs_hz = {fs:g}            # the file gives it" if fs is not None else
              "fs_hz = 0.0              # sampling rate (Hz): required, the file does not give it"),
             f"speed_rpm = {float(rec.hints.get('speed_rpm', 0.0)):g}          # nominal pinion (input) speed (rpm): "
             "required; refined from the tacho or the spectrum",
             f"torque_nm = {float(rec.hints.get('torque_nm', 0.0)):g}          # pinion torque (N m): required",
             f'pair = ""     # required: a preset ({", ".join(PRESETS)}) or a [pair] table',
             f'sensor = ""   # required: the vibration channel, one of {", ".join(names)} (perhaps "{sensor}")',
             '# sensor_quantity = "acceleration"   # or "velocity", "displacement"',
             '# sensor_unit = "m/s^2"   # the unit of the sensor\'s numbers: m/s^2, mm/s^2, g; m/s, mm/s, in/s; m, mm, '
             'um; or V, mV, counts, fullscale with sensor_sensitivity (file units per sensor_sensitivity_unit)',
             (f'tacho = "{tacho}"' if tacho else '# tacho = "..."') + "   # a once-per-revolution channel, if any; "
             "tacho_pulses_per_rev = 1, tacho_shaft = \"pinion\"",
             '# fault = "unknown"']
    with atomic_path(out) as tmp:
        tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return out


__all__ = ["TEMPLATE_SUFFIX", "write_template"]
