"""The unit of a measurement's sensor channel (sidecar ``sensor_unit``), and its factor to SI.

gearpit computes in SI (m/s^2, m/s, m); a measurement file's numbers are in whatever unit its logger wrote.
The sidecar names that unit and the record is brought to SI once, where the file is read
(:func:`compare.measurement.measurement_from_arrays`), before anything else sees it:

* a physical unit of the sidecar's ``sensor_quantity`` (:data:`PHYSICAL_UNITS`): acceleration ``"m/s^2"``,
  ``"mm/s^2"``, ``"g"`` (standard gravity, 9.80665 m/s^2); velocity ``"m/s"``, ``"mm/s"``, ``"in/s"``;
  displacement ``"m"``, ``"mm"``, ``"um"``;
* a signal unit (:data:`SIGNAL_UNITS`): ``"V"`` or ``"mV"`` (the sensor's output voltage), ``"counts"`` (ADC
  integers) or ``"fullscale"`` (fractions of the converter's full scale; gearpit reads an integer WAV file so,
  scaled to [-1, 1): :func:`compare.array_files.read_wav`), with ``sensor_sensitivity``, how many of the file's
  units one ``sensor_sensitivity_unit`` (a physical unit of the quantity) gives: an accelerometer of
  100 mV/g recorded in mV is ``sensor_sensitivity = 100``, ``sensor_sensitivity_unit = "g"``; recorded in V,
  ``0.1``; through a converter whose full scale is 5 V, as ``fullscale``, ``0.02`` (full scale = 50 g).

No unit declared: the numbers are taken as they are (as in SI), which a comparison does not need (it fits the
sensor gain) and a classifier that reads absolute levels does (:func:`models.spec.absolute_level_inputs`).

Examples
--------
>>> unit_factor("g", "acceleration")
9.80665
>>> round(unit_factor("mV", "acceleration", sensitivity=100.0, sensitivity_unit="g"), 8)   # 100 mV/g
0.0980665
"""
from __future__ import annotations

import math

from gearpit.errors import require

#: sensor quantity -> {physical unit: its value in SI (m/s^2, m/s, m)}
PHYSICAL_UNITS = {
    "acceleration": {"m/s^2": 1.0, "mm/s^2": 1e-3, "g": 9.80665},
    "velocity": {"m/s": 1.0, "mm/s": 1e-3, "in/s": 0.0254},
    "displacement": {"m": 1.0, "mm": 1e-3, "um": 1e-6},
}
#: the SI unit of each sensor quantity
SI_UNITS = {q: next(u for u, f in units.items() if f == 1.0) for q, units in PHYSICAL_UNITS.items()}
#: units of the sensor's signal rather than of its quantity: they need ``sensor_sensitivity``
SIGNAL_UNITS = ("V", "mV", "counts", "fullscale")


def allowed_units() -> str:
    """Every ``sensor_unit`` value, grouped by quantity, for error messages."""
    groups = [f"{', '.join(units)} ({q})" for q, units in PHYSICAL_UNITS.items()]
    return "; ".join(groups) + f"; {', '.join(SIGNAL_UNITS)} (with sensor_sensitivity and sensor_sensitivity_unit)"


def check_sensor_unit(unit, sensitivity, sensitivity_unit, quantity: str, where: str = "sidecar") -> None:
    """Validate the sidecar's ``sensor_unit``, ``sensor_sensitivity`` and ``sensor_sensitivity_unit`` (module
    docstring) against its ``sensor_quantity``; raises :class:`gearpit.errors.InputError` naming the field, the
    value and what is allowed."""
    own = PHYSICAL_UNITS[quantity]
    if unit is None:
        require(sensitivity is None and sensitivity_unit is None,
                f"{where}.sensor_sensitivity" if sensitivity is not None else f"{where}.sensor_sensitivity_unit",
                sensitivity if sensitivity is not None else sensitivity_unit,
                f"absent unless sensor_unit is one of {', '.join(SIGNAL_UNITS)} (set sensor_unit)")
        return
    every = {u for units in PHYSICAL_UNITS.values() for u in units} | set(SIGNAL_UNITS)
    require(isinstance(unit, str) and unit in every, f"{where}.sensor_unit", unit, "one of: " + allowed_units())
    if unit not in SIGNAL_UNITS:
        other = next(q for q, units in PHYSICAL_UNITS.items() if unit in units)
        require(unit in own, f"{where}.sensor_unit", unit,
                f"a unit of {quantity} (sensor_quantity = \"{quantity}\"): {', '.join(own)}; {unit} is a unit of "
                f"{other}: if the sensor measures {other}, set sensor_quantity = \"{other}\"")
        require(sensitivity is None and sensitivity_unit is None,
                f"{where}.sensor_sensitivity" if sensitivity is not None else f"{where}.sensor_sensitivity_unit",
                sensitivity if sensitivity is not None else sensitivity_unit,
                f"absent: the numbers are already in {unit} (a sensitivity goes with sensor_unit "
                f"{', '.join(SIGNAL_UNITS)})")
        return
    ok = isinstance(sensitivity, (int, float)) and not isinstance(sensitivity, bool) and math.isfinite(sensitivity) \
        and sensitivity > 0
    require(ok, f"{where}.sensor_sensitivity", sensitivity,
            f"a finite number > 0 with sensor_unit = \"{unit}\": the file's {unit} per one sensor_sensitivity_unit "
            "(e.g. 100 for 100 mV/g with sensor_unit = \"mV\" and sensor_sensitivity_unit = \"g\")")
    require(sensitivity_unit in own, f"{where}.sensor_sensitivity_unit", sensitivity_unit,
            f"a unit of {quantity} (sensor_quantity = \"{quantity}\"): {', '.join(own)}")


def unit_factor(unit: str, quantity: str, *, sensitivity: float | None = None,
                sensitivity_unit: str | None = None) -> float:
    """The factor that brings the file's numbers in ``unit`` to the SI unit of ``quantity``
    (:data:`SI_UNITS`): a physical unit's value in SI, or for a signal unit the SI value of
    ``1 / sensitivity`` ``sensitivity_unit`` (checked first: :func:`check_sensor_unit`)."""
    check_sensor_unit(unit, sensitivity, sensitivity_unit, quantity)
    if unit in SIGNAL_UNITS:
        return PHYSICAL_UNITS[quantity][sensitivity_unit] / float(sensitivity)
    return PHYSICAL_UNITS[quantity][unit]


def describe_unit(unit: str, quantity: str, *, sensitivity: float | None = None,
                  sensitivity_unit: str | None = None) -> str:
    """One line for messages: ``"g (x 9.80665 to m/s^2)"``, ``"mV at 100 mV/g (x 0.0980665 to m/s^2)"``."""
    f = unit_factor(unit, quantity, sensitivity=sensitivity, sensitivity_unit=sensitivity_unit)
    at = f" at {sensitivity:g} {unit}/{sensitivity_unit}" if unit in SIGNAL_UNITS else ""
    return f"{unit}{at} (x {f:.6g} to {SI_UNITS[quantity]})"


__all__ = ["PHYSICAL_UNITS", "SIGNAL_UNITS", "SI_UNITS", "allowed_units", "check_sensor_unit", "describe_unit",
           "unit_factor"]
