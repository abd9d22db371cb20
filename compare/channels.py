"""Further measured channels: they settle effects that the sensor alone cannot tell apart.

The attribution fits every candidate effect to the sensor channel. Two effects can then explain it equally well
(:func:`compare.candidates.rivals_of`: both pass the claim rule within ``rival_reduction`` of each other): a
speed fluctuation at the motor and a torque fluctuation at the load, below the drive train's torsion modes, move
the pinion alike and differ only in the dynamic mesh torque, which a housing accelerometer hardly sees
(``tests/test_dynamics_simulate.py::test_motor_side_and_load_side_fluctuations_differ_only_in_the_mesh_torque``).
A channel that sees the mesh torque does: the transmission error of two shaft encoders (``dte_m``), or the mesh
force.

When the measurement names further channels (sidecar ``secondary = {column = "simulated channel"}``) and the
attribution left rivals, the claimed effect and its rivals, each with the parameters fitted to the sensor (and the
drive train it was fitted at), are simulated once more with the baseline, in one batch and with the model's own
solver settings (as the comparison after adding the effect simulates them), and each further channel
is compared like the sensor (its own plan of locations, its own fitted gain, noise matched to its own floor,
:func:`compare.comparison.evaluate`) at the speed refined on the sensor. The parameters are not refitted: these
channels are independent evidence, not something the fit could bend to.

Decision, with the rival rule's own margin: on the further channels (the RMS of their excess errors) each
candidate's reduction of the baseline's error is measured; the one with the largest reduction is claimed, and the
others stay its rivals only if they come within ``rival_reduction`` of it there too. When none of them lowers
the further channels' error, those channels do not see the difference and the tie stands. Without further
channels, or without rivals, nothing changes.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from compare.comparison import NOISE_DRAWS, Reference, evaluate, prepare_reference, simulate_model
from gearpit.errors import GearpitError


@dataclass
class Resolution:
    """What the further channels said about the claimed effect and its rivals."""

    channels: dict                       # measured column -> simulated channel
    baseline_error_db: dict              # column -> the baseline's excess error on it (dB)
    error_db: dict                       # effect -> column -> excess error (dB)
    reduction: dict                      # effect -> reduction on the further channels (RMS over them)
    claimed: str | None                  # the effect claimed after the further channels
    before: str                          # the effect claimed on the sensor alone
    rivals: list = field(default_factory=list)
    note: str = ""

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def _rms(values) -> float:
    v = list(values)
    return float(np.sqrt(np.mean(np.square(v)))) if v else 0.0


def secondary_reference(ref: Reference, column: str) -> Reference:
    """The reference of a further channel: the measurement with ``column`` as its sensor, at the speed refined on
    the sensor (the same record, so the same speed)."""
    m = dataclasses.replace(ref.measurement, sensor=column)
    duration = len(ref.x) / ref.fs_hz if len(ref.x) < m.n_samples else None
    return prepare_reference(m, speed=ref.speed, duration_s=duration)


def resolve_rivals(ref: Reference, model, attribution, settings, *, seed: int = 0) -> Resolution | None:
    """Settle the claimed effect of ``attribution`` against its rivals on the measurement's further channels
    (module docstring); reorders ``attribution.candidates`` (the new claim first), moves the claim and replaces
    ``attribution.rivals``. None (and nothing changed) without rivals or further channels."""

    secondary = dict(ref.measurement.secondary or {})
    claimed = next((c for c in attribution.candidates if c.claimed), None)
    if claimed is None or not attribution.rivals or not secondary:
        return None
    group = [claimed] + [c for c in attribution.candidates if c.effect in attribution.rivals]
    models = [model]
    for c in group:
        m = model.with_effect(c.build_effect())
        models.append(m.with_drivetrain(c.nuisance) if c.nuisance else m)
    sims = list(secondary.values())
    try:       # with the models' own solvers: as the comparison after adding the effect will simulate them
        out = simulate_model(ref, model, models=models, seed=seed, channels=tuple(dict.fromkeys(sims)))
    except (GearpitError, FloatingPointError, MemoryError, np.linalg.LinAlgError) as exc:
        return Resolution(secondary, {}, {}, {}, claimed.effect, claimed.effect, list(attribution.rivals),
                          note=f"not settled: the simulation of the further channels failed ({exc})")
    base, errors = {}, {c.effect: {} for c in group}
    for col, sim in secondary.items():
        r = secondary_reference(ref, col)
        b = evaluate(r, out[0][sim], r.fs_hz, seed=seed, noise_draws=NOISE_DRAWS).residuals
        base[col] = b.excess_total_db
        for c, o in zip(group, out[1:]):
            errors[c.effect][col] = evaluate(r, o[sim], r.fs_hz, seed=seed,
                                             noise_view_db=b.noise_view_db).residuals.excess_total_db
    b_all = _rms(base.values())
    reduction = {e: (1.0 - _rms(v.values()) / b_all) if b_all > 0 else 0.0 for e, v in errors.items()}
    best = max(reduction, key=lambda e: reduction[e])
    if reduction[best] <= 0:
        return Resolution(secondary, base, errors, reduction, claimed.effect, claimed.effect, list(attribution.rivals),
                          note="none of them lowers the further channels' error: they do not see the difference, "
                               "and the tie stands")
    rivals = [e for e in reduction if e != best and reduction[best] - reduction[e] <= settings.rival_reduction]
    return Resolution(secondary, base, errors, reduction, best, claimed.effect, rivals)


def apply_resolution(attribution, resolution: Resolution) -> None:
    """Move the claim of ``attribution`` to ``resolution.claimed`` (first in the list; the others keep their order)
    and set its rivals."""
    for c in attribution.candidates:
        c.claimed = c.effect == resolution.claimed
        if not c.claimed:          # the further channels decided; a rule's order of the sensor alone is moot
            c.claimed_over = None
    attribution.candidates.sort(key=lambda c: not c.claimed)       # stable: the rest stay ranked by reduction
    attribution.rivals = list(resolution.rivals)
    attribution.resolution = resolution.to_dict()


def resolution_message(res: dict) -> str:
    """One line on what the further channels said (compare.channels.Resolution as a dict)."""
    errs = "; ".join(f"{e} " + ", ".join(f"{col} {v:.2f} dB" for col, v in cols.items())
                     for e, cols in res["error_db"].items())
    base = ", ".join(f"{col} {v:.2f} dB" for col, v in res["baseline_error_db"].items())
    others = [e for e in res["error_db"] if e != res["before"]] or list(res["rivals"])
    head = (f"further channels ({', '.join(f'{k} as {v}' for k, v in res['channels'].items())}): "
            f"the sensor could not tell {res['before']} from {', '.join(others)}")
    if res.get("note"):
        return f"{head}; {res['note']}"
    return (f"{head}; on them the error is {errs} (the model without them: {base}), so {res['claimed']} is claimed"
            + (f", {', '.join(res['rivals'])} still within 5 %" if res["rivals"] else ""))
