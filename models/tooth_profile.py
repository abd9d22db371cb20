"""How many tooth pitches a pit's deviation covers: the pitted-teeth profile of a record (CNN side inputs).

Physics. A pit removes contact stiffness on one tooth, so while that tooth is in mesh the loaded transmission
error deviates from the pattern that every tooth repeats. In the pinion's time-synchronous average, the
*difference signal* (the mesh harmonics removed, :mod:`models.representations`) low-passed below
:data:`LOWPASS_MESH_ORDERS` mesh orders keeps that deviation as one smooth bump per pitted tooth, about a tooth
pitch wide (the tooth is in contact over the contact ratio, 1.2-1.7 pitches). Counting pitted teeth is then
measuring how much of the revolution the bumps cover, in tooth pitches, against the largest bump. That measure
does not depend on

- the record's scale (everything is divided by the largest bump's height),
- the sign convention of the channel (the profile is oriented on its largest excursion),
- the speed (the average is in the angle domain, the low-pass in mesh orders),
- where the pitted teeth sit (everything is circular and aligned on the largest bump).

A CNN trained on the transmission error below 1200 rpm over-counts pitted teeth above that speed
(experiments/RESULTS.md, section "Sensor"); these values are read the same way at every speed, and given to
it as side inputs they lift its cross-speed teeth accuracy above the 85 % target (same section).

On a housing accelerometer the low orders hold little of the pit (acceleration of a quasi-static deviation,
through a housing path): a logistic regression on these values counts teeth at chance there (25-28 %).

Features (:data:`FEATURE_NAMES`, :data:`N_FEATURES` = 12), with ``s`` the difference signal smoothed over one
pitch (circular moving average), ``m`` its median and ``A = max(s) - m``:

- ``span_20`` ... ``span_80``: tooth pitches over which ``s - m`` exceeds 20, 35, 50, 65, 80 % of ``A``
  (``z`` times the fraction of the revolution). Separated pitted teeth of equal depth give about one pitch each
  at 50 %;
- ``tooth_1`` ... ``tooth_6``: ``s - m`` sampled once per pitch, starting at the largest bump, sorted
  descending, over ``A``. The first is 1, the next is near 1 for each further pitted tooth as deep as the
  deepest and near 0 for a healthy one;
- ``spread``: the standard deviation of ``s`` over ``A``.

References
----------
McFadden, P. D. (1986). Detecting fatigue cracks in gears by amplitude and phase demodulation of the meshing
    vibration. J. Vib. Acoust. 108(2), 165-170 (the synchronous average and its residual / difference signals).
Lebold, M. et al. (2000). Review of vibration analysis methods for gearbox diagnostics and prognostics.
    Proc. 54th MFPT, 623-634 (difference signal: the regular meshing components removed).
"""
from __future__ import annotations

import numpy as np

from gearpit.errors import require
from models.representation_spec import RepresentationSpec
from models.representations import represent

#: low-pass of the difference signal (mesh orders): the cut-off of the sensor protocol's ``tsa_lp_load`` CNN,
#: chosen there on an inner speed split (experiments/sensor_protocol.py); not re-chosen here
LOWPASS_MESH_ORDERS = 1.25
#: the TSA the profile is read from (the classifiers' ``tsa`` representation, low-passed), with both shafts' first
#: order removed from the record first: shaft-encoder disc eccentricity puts lines of 3-28 um there (10-60 arcsec,
#: against a loaded transmission error of a few um), and the wheel's leaks into the pinion's low orders (default
#: dataset, eccentric encoders: teeth
#: 68.5 % without the removal, 95.3 % with it, the same 95.3 % on exact encoders; experiments/RESULTS.md)
PROFILE_SPEC = RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024, lowpass_mesh_orders=LOWPASS_MESH_ORDERS,
                                  remove_shaft_1x=True)
SPAN_LEVELS = (0.20, 0.35, 0.50, 0.65, 0.80)
N_TEETH_LISTED = 6
FEATURE_NAMES = tuple([f"span_{int(round(100 * q))}" for q in SPAN_LEVELS]
                      + [f"tooth_{j + 1}" for j in range(N_TEETH_LISTED)] + ["spread"])
N_FEATURES = len(FEATURE_NAMES)


def profile_of_difference(diff: np.ndarray, z_pinion: int) -> np.ndarray:
    """The :data:`N_FEATURES` features (module docstring) of difference signals ``diff`` (records, samples per
    revolution), one revolution each, for a pinion of ``z_pinion`` teeth: ``(records, N_FEATURES)``."""
    d = np.atleast_2d(np.asarray(diff, dtype=float))
    n = d.shape[1]
    require(isinstance(z_pinion, (int, np.integer)) and 2 <= z_pinion <= n // 4, "z_pinion", z_pinion,
            f"an integer in [2, {n // 4}] (at least 4 samples per tooth pitch)")
    pitch = n / z_pinion
    k = max(1, int(round(pitch)))
    out = np.empty((d.shape[0], N_FEATURES))
    for r, row in enumerate(d):
        u = row * (np.sign(row[np.argmax(np.abs(row))]) or 1.0)
        c = np.concatenate([[0.0], np.cumsum(np.concatenate([u, u[:k]]))])
        s = (c[k:k + n] - c[:n]) / k                       # circular mean over one pitch
        m = np.median(s)
        a = s.max() - m
        if not a > 0:                                      # a flat record: nothing stands out
            out[r] = 0.0
            continue
        spans = [np.count_nonzero(s - m > q * a) * z_pinion / n for q in SPAN_LEVELS]
        i0 = int(np.argmax(s))
        teeth = np.sort(s[(i0 + np.round(np.arange(z_pinion) * pitch).astype(int)) % n] - m)[::-1]
        out[r] = spans + list(teeth[:N_TEETH_LISTED] / a) + [s.std() / a]
    return out


def tooth_profile(signals: np.ndarray, *, fs_hz: float, shaft_hz, z_pinion: int, z_wheel: int) -> np.ndarray:
    """Features ``(records, N_FEATURES)`` of records ``signals`` (records, samples) at pinion shaft frequencies
    ``shaft_hz`` (Hz, one per record or one for all) of a pair of ``z_pinion`` / ``z_wheel`` teeth."""
    rep = represent(signals, PROFILE_SPEC, fs_hz=fs_hz, shaft_hz=shaft_hz, z_pinion=z_pinion, z_wheel=z_wheel)
    return profile_of_difference(rep[:, 1], z_pinion)


__all__ = ["tooth_profile", "profile_of_difference", "FEATURE_NAMES", "N_FEATURES", "PROFILE_SPEC",
           "LOWPASS_MESH_ORDERS"]
