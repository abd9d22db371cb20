"""The record every measurement-file reader returns (:mod:`compare.formats`, :mod:`compare.array_files`): what a
file holds, before :func:`compare.measurement.load_measurement` validates it."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class RawRecord:
    """What a file holds, before validation.

    Attributes
    ----------
    names : tuple of str
        Channel names (columns of ``data``).
    data : ndarray (n_samples, n_channels)
    fs_hz : float or None
        Sampling rate found in the file (time column, WAV header, ``fs`` variable).
    hints : dict
        Operating-point defaults read from the file name or layout
        (``speed_rpm``, ``torque_nm``, ``fault``, ``tacho``, ``sensor``, ``fs_hz``).
    no_index : str
        Why a 0-based channel index cannot be read in the file's order (a MAT v7.3 file that does not store the
        order of its variables); "" where it can: an index counts ``columns`` in the file's order.
    columns : tuple of str
        The file's columns as written, a time column the reader took out of ``names`` included: what a 0-based
        channel index counts (empty: ``names``).
    """

    names: tuple
    data: np.ndarray
    fs_hz: float | None = None
    hints: dict = field(default_factory=dict)
    no_index: str = ""
    columns: tuple = ()
