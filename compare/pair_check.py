"""Does the measurement's gearbox have the tooth counts its sidecar names?

Why
---
Every view of a comparison is placed by the sidecar's pair: the mesh
harmonics at ``z1 fr``, the sidebands of both shafts, the shaft rates of the
synchronous averages. A wrong pair (a preset that is not the rig's, a
transposed table) is not refused by anything else: the speed refinement
(:mod:`compare.speed`) finds the mesh line anyway - it reads the speed that
puts ``z1`` harmonics on it - and the comparison then reads every sideband and
shaft order at the wrong places, so the model "fails" everywhere and the
attribution chases the pair's error with gear effects.

What
----
Two checks, both read from the measurement alone (no level enters):

1. **Is there a mesh line where the comparison reads it?** The harmonic family at
   ``z1`` x the refined speed is scored by how far its harmonics stand out of
   their local floor (:func:`mesh_family_db`), against the same score 1-6 %
   beside it (:func:`mesh_line_db`): a mesh line is a sharp maximum. Below
   :data:`MESH_FAMILY_DB` the pair or the speed is wrong (``questioned``): with a
   tachometer, ``z1`` x the pinion's true rate is no line unless ``z1`` is right;
   without one, the speed search (+/- 5 %) found no mesh line near the sidecar's.
2. **Which gear modulates the mesh?** Every tooth count is scored by its
   sideband comb around the strongest mesh harmonics
   (:func:`models.unknown_rate.tooth_count_scores`). A count within the record's
   resolution of ``z1`` or ``z2`` agrees; the resolution is about ``z / (3 R)``
   counts for a gear turned ``R`` times in the record (the comb of ``z +/- 1``
   misses the third sideband by ``3 / z`` of the spacing, under one bin unless
   ``R > z / 3``). A decisive comb (contrast >= :data:`DECISIVE_DB`, leading both
   sidecar counts by :data:`MARGIN_DB`) at another count is reported
   (``other_family``), not as an error: a speed or torque fluctuation at
   ``fm / z`` makes the same comb (on the hidden-effect rigs at 23 and 37 Hz:
   21 and 13 "teeth"), so the message names both readings.

Measured on 49 simulated rigs described by their own pairs (the hidden-effect
rigs of three drive trains, the independent simulator's eight cases, the eleven
unseen rigs; `experiments/pair_check_scan.py`): no mesh line
questioned (the quietest, a helical pair with tip relief behind 25 dB of noise,
scores 15.2 dB); ``other_family`` on the 11 that carry a fluctuation or
backlash. Re-described with a wrong pair or speed: -0.8 to 3.8 dB where no line
is. On the SpectraQuest recordings the stage is 32 teeth on all 40
file-channels, with 2.0-12.9 dB to the next count (``experiments/real_data_pair.py``).
"""
from __future__ import annotations

import math

import numpy as np

from gearpit.errors import InputError
from models.unknown_rate import log_power, tooth_count_scores

#: comb contrast (dB) above which a tooth count is a clear sideband family of the record
DECISIVE_DB = 6.0
#: how far (dB) the best count must lead both of the sidecar's counts for the pair to be questioned
MARGIN_DB = 3.0
#: sideband orders the comb reads on each side (models.unknown_rate.tooth_count_scores)
N_SIDEBANDS = 3
#: a harmonic family this much (dB) above the families beside it is a mesh line (mesh_line_db)
MESH_FAMILY_DB = 10.0
#: zero padding of the spectra
PAD = 4
#: the family score is this quantile of its harmonics' prominences (mesh_family_db)
QUANTILE = 0.75
#: relative offsets at which the family score is read beside the mesh line (mesh_line_db); unevenly spaced so
#: that they do not fall on one shaft's sidebands together
OFFSETS = (-0.055, -0.034, -0.021, -0.013, 0.013, 0.021, 0.034, 0.055)


def resolution_counts(z: int, revolutions: float) -> int:
    """Tooth counts around ``z`` that a record of ``revolutions`` turns of that gear cannot tell from ``z``."""
    return max(1, math.ceil(z / (N_SIDEBANDS * max(revolutions, 1e-9))))


def check_pair(measurement, speed) -> dict:
    """The measurement against the sidecar's pair: its mesh line and its sideband family (module docstring).

    Parameters
    ----------
    measurement : compare.measurement.Measurement
    speed : compare.speed.SpeedEstimate
        The refined speed (its mesh frequency places the comb).

    Returns
    -------
    dict
        ``mesh_hz`` and ``mesh_family_db`` (check 1), ``speed_method``, ``sidecar`` (``{"pinion": z1, "wheel":
        z2}``), ``z_measured`` (best count; None without a mesh line), ``score_db`` (its comb contrast),
        ``sidecar_score_db`` (the best contrast within each sidecar count's resolution), ``agrees`` (the best count
        is within the resolution of one of the sidecar's), ``other_family`` (check 2 decisive and not agreeing),
        ``questioned`` (check 1 failed). :func:`pair_message` words it.
    """
    pair = measurement.pair
    z1, z2 = int(pair.pinion.teeth), int(pair.wheel.teeth)
    fs = measurement.fs_hz
    x = measurement.signal
    fr_cps = speed.fr_pinion_hz / fs
    logp, n_fft = log_power(np.asarray(x, dtype=float), PAD)
    out = {"mesh_hz": float(z1 * fr_cps * fs), "mesh_family_db": mesh_line_db(logp, n_fft, z1 * fr_cps),
           "speed_method": speed.method, "sidecar": {"pinion": z1, "wheel": z2}}
    fm_cps = z1 * fr_cps
    blank = {"z_measured": None, "score_db": None, "sidecar_score_db": None, "agrees": False, "other_family": False}
    if not math.isfinite(out["mesh_family_db"]):
        # no mesh harmonic below 0.45 fs (a low sampling rate): nothing to check, and nothing questioned
        out.update({**blank, "questioned": False})
        return out
    if out["mesh_family_db"] < MESH_FAMILY_DB:
        # no mesh line where the comparison reads it: the sideband comb would be read around nothing
        out.update({**blank, "questioned": True})
        return out
    family = sideband_family(x, fm_cps, z1, z2)
    out.update({**(blank if family is None else family), "questioned": False})
    return out


def sideband_family(x: np.ndarray, fm_cps: float, z1: int, z2: int) -> dict | None:
    """Check 2 of the module docstring around a mesh line at ``fm_cps`` (cycles per sample): ``z_measured``,
    ``score_db``, ``sidecar_score_db``, ``agrees``, ``other_family`` (:func:`check_pair`); None when no harmonic
    with its sidebands lies below Nyquist or the record is too short to resolve them."""
    n = len(x)
    try:
        scores = tooth_count_scores(x, fm_cps, z_range=(6, max(200, 2 * max(z1, z2))), n_sidebands=N_SIDEBANDS)
    except InputError:
        return None
    best = max(scores, key=scores.get)
    near = {}
    agrees = False
    for name, z in (("pinion", z1), ("wheel", z2)):
        tol = resolution_counts(z, n * fm_cps / z)
        window = [scores[k] for k in range(z - tol, z + tol + 1) if k in scores]
        near[name] = max(window) if window else None
        # a comb spaced k shaft orders (z / k teeth, k an integer) is that shaft's orders too when that shaft's own
        # comb is a clear family: a local fault puts every order of its gear into the record, and the comb of every
        # k-th one then scores as high (a broken wheel tooth of the 29/100 rig: 20 "teeth", 33 dB, against 27.6 dB
        # at 100). Exactly: a comb of 29 for a 60-tooth wheel is no wheel's (the comb of 60 at half a 29-tooth
        # gear's spacing scores about half of it)
        agrees = agrees or abs(best - z) <= tol or (
            near[name] is not None and near[name] >= DECISIVE_DB and best < z and z % best == 0)
    lead = scores[best] - max((v for v in near.values() if v is not None), default=-math.inf)
    other = (not agrees) and scores[best] >= DECISIVE_DB and lead >= MARGIN_DB
    return {"z_measured": int(best), "score_db": float(scores[best]),
            "sidecar_score_db": {k: (None if v is None else float(v)) for k, v in near.items()},
            "agrees": bool(agrees), "other_family": bool(other)}


def mesh_family_db(logp: np.ndarray, n_fft: int, f_cps: float, *, n_harmonics: int = 10, odd: bool = False,
                   quantile: float = QUANTILE) -> float:
    """How far a harmonic family at ``f_cps`` stands out (dB): the :data:`QUANTILE` over its harmonics below 0.45
    cycles per sample (at most ``n_harmonics``) of the peak within +/- ``PAD`` padded bins (one bin of the record)
    over the median of the spectrum within +/- ``f_cps / 4`` (the local floor, sidebands included). A quantile,
    not the mean: a family at a simple fraction of the mesh (7/4 fm) hits a few strong mesh lines and misses the
    rest; not the median: a quiet pair (helical, with tip relief) has half its harmonics under the sensor noise.
    ``odd``: its odd harmonics only (1, 3, 5, ...; ``n_harmonics`` of them): a family at half the mesh frequency hits
    the mesh lines with its even harmonics alone, so it stands out on them, not on its odd ones
    (:func:`compare.speed.spectrum_speed`); ``quantile``: another quantile (the widened speed search asks for the
    median: a family at ``p/q`` of the mesh frequency hits every ``q``-th harmonic, and 3 of 10 lift the 0.75
    quantile)."""
    db = 10.0 / np.log(10.0)
    vals = []
    half = max(PAD, int(0.25 * f_cps * n_fft))
    for m in range(1, 2 * n_harmonics, 2) if odd else range(1, n_harmonics + 1):
        c = int(round(m * f_cps * n_fft))
        if m * f_cps >= 0.45 or c + half >= logp.size:
            break
        vals.append(np.max(logp[c - PAD:c + PAD + 1]) - np.median(logp[max(c - half, 0):c + half + 1]))
    return float(db * np.quantile(vals, quantile)) if vals else -math.inf


def mesh_line_db(logp: np.ndarray, n_fft: int, f_cps: float, *, odd: bool = False,
                 quantile: float = QUANTILE) -> float:
    """How much more a harmonic family at ``f_cps`` stands out than families just beside it (dB):
    :func:`mesh_family_db` at ``f_cps`` minus its median at ``f_cps (1 + d)`` for the offsets :data:`OFFSETS`.
    A mesh line is a sharp maximum of the family score; at a frequency that is no line the score is whatever
    noise, sidebands and stray coincidences give, and about the same a few percent away (self-normalising: no
    level of the record enters). ``odd``, ``quantile``: as :func:`mesh_family_db`'s."""
    kw = dict(odd=odd, quantile=quantile)
    here = mesh_family_db(logp, n_fft, f_cps, **kw)
    beside = [mesh_family_db(logp, n_fft, f_cps * (1.0 + d), **kw) for d in OFFSETS if f_cps * (1.0 + d) < 0.45]
    return float(here - np.median(beside)) if beside else -math.inf


def pair_message(check: dict) -> str | None:
    """What the user is told (None: nothing to tell): no mesh line where the comparison reads it (the pair or the
    speed is wrong), or a sideband family that is no shaft of the pair (the pair is wrong, or it is another
    modulation)."""
    sc = check["sidecar"]
    if check["questioned"]:
        return (f"no mesh line stands out at {check['mesh_hz']:.1f} Hz ({sc['pinion']} teeth x the refined pinion "
                f"speed; its harmonics {check['mesh_family_db']:.1f} dB above the families beside it): the "
                "sidecar's pair or speed is wrong by more than the speed search covers, so every view is read at "
                "the wrong places")
    if not check["other_family"]:
        return None
    ss = check["sidecar_score_db"]

    def _db(v):          # a sidecar count the record cannot resolve has no score
        return "unresolved" if v is None else f"{v:.1f} dB"

    spacing = check["mesh_hz"] / check["z_measured"]
    return (f"the strongest sideband family around the mesh is spaced {spacing:.2f} Hz, mesh / {check['z_measured']} "
            f"(comb contrast {check['score_db']:.1f} dB; the sidecar's {sc['pinion']} and {sc['wheel']} teeth: "
            f"{_db(ss['pinion'])} and {_db(ss['wheel'])}): if that is a shaft, the pair is wrong (a gear of "
            f"{check['z_measured']} teeth); if not, it is another modulation at {spacing:.2f} Hz (a speed or torque "
            "fluctuation, which the attribution tries)")
