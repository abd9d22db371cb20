"""Feature-table columns read against a healthy reference of the same machine (the baselines' ``reference``).

What a reliability engineer does with condition indicators is trend them: an indicator means little alone (a
healthy gear's own tooth-to-tooth spacing errors raise FM4 as a pit does), its change since the machine was
known healthy means much more (Randall 2011, chapter 5; Lebold et al. 2000). With ``reference = true`` in a
baseline's feature configuration (:func:`models.baselines.feature_config_for`) the feature table of
:mod:`features.table` gets, beside the record's own columns:

* ``delta:<column>``: the record's value less its reference's, for every column of the table;
* the indicators of the **TSA residual** (:func:`models.tsa.residual_difference`: the record's synchronous
  average less its reference's, turned to the best-correlating angle, then the difference signal's filter:
  no shaft orders 0-2, no mesh harmonics or their first sidebands):

  ==========================  ==============================================================================
  ``residual:rms_over_own``   log10 of the residual's RMS over the reference's own difference-signal RMS
  ``residual:rms_over_ref``   log10 of the residual's RMS over the reference record's RMS
  ``residual:fm4``            the residual's kurtosis (FM4 of the residual; 3 for Gaussian noise)
  ``residual:crest``          its peak over its RMS
  ``residual:<profile>``      the pitted-teeth profile of the residual (:mod:`models.tooth_profile`, 12 values)
  ==========================  ==============================================================================

Both level columns are ratios of two quantities measured through the same sensor path, so a sensor gain
cancels in them, which an absolute RMS in m/s^2 does not (``models/operating.py``). The TSA is that of
:data:`RESIDUAL_SPEC` (8 revolutions, 1024 samples per revolution, no further filter): records need 8 pinion
revolutions (a clear error names the field otherwise).

References
----------
.. [1] Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley, chapter 5 (fault detection).
.. [2] Lebold, M., McClintic, K., Campbell, R., Byington, C., Maynard, K. (2000). Review of vibration analysis
   methods for gearbox diagnostics and prognostics. Proc. 54th MFPT, 623-634.
"""
from __future__ import annotations

import numpy as np

from features.statistics import crest_factor, kurtosis, rms
from gearpit.errors import require
from models.representation_spec import RepresentationSpec
from models.tooth_profile import FEATURE_NAMES as PROFILE_NAMES, profile_of_difference
from models.tsa import residual_difference, tsa_difference

RESIDUAL_SPEC = RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024)
RESIDUAL_NAMES = (["residual:rms_over_own", "residual:rms_over_ref", "residual:fm4", "residual:crest"]
                  + [f"residual:{n}" for n in PROFILE_NAMES])
TINY = 1e-300


def residual_indicators(data) -> np.ndarray:
    """The residual columns (module docstring) of every record of ``data`` (a :class:`models.data.SignalSet`
    with ``reference``): ``(n_records, len(RESIDUAL_NAMES))``."""
    require(data.reference is not None, "reference", None, "a healthy reference of every record (the baseline "
            "was configured with reference = true)")
    fr = data.shaft_hz()
    require(fr is not None, "speed_rpm", None, "the pinion speed of every record (the TSA needs it)")
    zp, zw = int(data.pair.z_pinion), int(data.pair.z_wheel)
    d = residual_difference(data.signals, data.reference, RESIDUAL_SPEC, fs_hz=data.fs_hz, shaft_hz=fr,
                            z_pinion=zp, z_wheel=zw)
    own = tsa_difference(data.reference, RESIDUAL_SPEC, fs_hz=data.fs_hz, shaft_hz=fr, z_pinion=zp, z_wheel=zw)
    r, r_own = rms(d), rms(own)
    r_ref = np.asarray(data.reference, dtype=float).std(axis=1)
    cols = np.column_stack([np.log10(np.maximum(r, TINY) / np.maximum(r_own, TINY)),
                            np.log10(np.maximum(r, TINY) / np.maximum(r_ref, TINY)), kurtosis(d), crest_factor(d)])
    return np.hstack([cols, profile_of_difference(d, zp)])


def with_reference_columns(data, x: np.ndarray, x_ref: np.ndarray, names: list[str]) -> tuple[np.ndarray, list[str]]:
    """The record's table ``x``, its change since the reference ``x - x_ref`` and the residual columns."""
    require(x_ref.shape == x.shape, "reference features", x_ref.shape, f"the records' shape {x.shape}")
    return (np.hstack([x, x - x_ref, residual_indicators(data)]),
            list(names) + [f"delta:{n}" for n in names] + list(RESIDUAL_NAMES))
