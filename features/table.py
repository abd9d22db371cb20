"""The feature vector of one record, the feature table of many, and the
scikit-learn transformer around them.

Columns are named ``name[unit]``: ``raw_*`` time-domain statistics of the record,
``tsa_pinion_*`` / ``tsa_wheel_*`` gear condition indicators on each shaft's
synchronous average, ``spec_*`` mesh harmonics, sidebands and shaft orders,
``env_*`` envelope-spectrum shaft orders, ``imf_*`` statistics and energy index of
the selected IMF. ``1`` is the unit of a dimensionless feature; ``signal`` in the
module-level unit tables is replaced by :attr:`FeatureConfig.signal_unit`.

Every record is processed independently; record ``i`` of a batch uses the seed
``SeedSequence([config.seed, i])`` for EEMD/CEEMDAN noise unless ``seeds`` are
given, so the table is the same for any ``n_jobs``.
"""
from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, fields
from typing import Literal

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin

from features import envelope as env
from features import hht, indicators, spectra, statistics, tsa
from gearpit.errors import InputError, require, require_positive

SpeedSource = Literal["nominal", "tacho", "mesh_phase"]
SPEED_SOURCES: tuple[str, ...] = ("nominal", "tacho", "mesh_phase")
HHT_METHODS: tuple[str, ...] = hht.METHODS + ("none",)
ENVELOPE_BANDS: tuple[str, ...] = ("full", "auto")


@dataclass(frozen=True)
class FeatureConfig:
    """What to compute and how; operating speeds are per record, not here.

    Attributes
    ----------
    fs_hz : float
        Sampling rate (Hz).
    z_pinion, z_wheel : int
        Tooth counts; mesh frequency ``fm = z_pinion * fr_pinion``.
    signal_unit : str
        Unit of the records, used in column names.
    speed_source : {"nominal", "tacho", "mesh_phase"}
        Where the shaft angle for the TSA comes from: the given pinion speed as
        constant, a tachometer channel on the pinion (``pulses_per_rev``), or the
        phase of the mesh tone seeded by the given speed.
    pulses_per_rev : int
        Tachometer pulses per pinion revolution.
    window : str
        Spectral window, one of :data:`features.spectra.WINDOWS`.
    n_mesh_harmonics, n_sidebands, n_shaft_orders : int
        Mesh harmonics, sidebands per side and shaft, and shaft orders read from
        the spectrum (shaft orders also from the envelope spectrum).
    envelope_band : "full", "auto" or (lo, hi)
        Envelope of the whole record, of the band of maximum spectral kurtosis
        above the ``n_mesh_harmonics``-th mesh harmonic (or above ``fs/4`` if
        that is lower), or of a fixed band (Hz).
    tsa_shaft_orders, tsa_sideband_orders : int
        Regular components of the TSA split (:func:`features.tsa.split_tsa`).
    hht_method : {"emd", "eemd", "ceemdan", "none"}
        Decomposition for the HHT features; "none" skips them.
    hht_trials : int
        Ensemble size of EEMD / CEEMDAN.
    hht_noise_std_ratio : float
        Added-noise std over the record's std (EEMD / CEEMDAN).
    imf_criterion : {"mesh_band_energy", "envelope_kurtosis", "fixed"}
        How the analysed IMF is chosen (:func:`features.hht.select_imf`).
    imf_number : int
        1-based IMF number for ``imf_criterion="fixed"`` (the spur paper's 6).
    hilbert_bins : int
        Frequency bins of the Hilbert spectrum behind ``E(t)``.
    seed : int
        Root seed of the EEMD / CEEMDAN noise.
    """

    fs_hz: float
    z_pinion: int
    z_wheel: int
    signal_unit: str = "m/s^2"
    speed_source: SpeedSource = "nominal"
    pulses_per_rev: int = 1
    window: spectra.Window = "hann"
    n_mesh_harmonics: int = 3
    n_sidebands: int = 3
    n_shaft_orders: int = 3
    envelope_band: str | tuple[float, float] = "full"
    tsa_shaft_orders: int = 2
    tsa_sideband_orders: int = 1
    hht_method: str = "emd"
    hht_trials: int = 100
    hht_noise_std_ratio: float = 0.2
    imf_criterion: hht.Criterion = "mesh_band_energy"
    imf_number: int = 6
    hilbert_bins: int = 64
    seed: int = 0

    def __post_init__(self):
        require_positive("fs_hz", self.fs_hz)
        for name in ("z_pinion", "z_wheel"):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and v >= 5, name, v, "an integer >= 5")
        require(isinstance(self.signal_unit, str) and "[" not in self.signal_unit and "]" not in self.signal_unit,
                "signal_unit", self.signal_unit, "a unit string without brackets")
        require(self.speed_source in SPEED_SOURCES, "speed_source", self.speed_source,
                "one of: " + ", ".join(SPEED_SOURCES))
        spectra.check_window(self.window)
        for name in ("pulses_per_rev", "n_shaft_orders", "hht_trials", "imf_number", "hilbert_bins"):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and v >= 1, name, v, "an integer >= 1")
        for name in ("n_mesh_harmonics", "n_sidebands", "tsa_shaft_orders", "tsa_sideband_orders"):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and v >= 0, name, v, "an integer >= 0")
        require(self.n_mesh_harmonics >= 1, "n_mesh_harmonics", self.n_mesh_harmonics, "an integer >= 1")
        band = self.envelope_band
        if isinstance(band, list):
            band = tuple(band)
            object.__setattr__(self, "envelope_band", band)
        ok = band in ENVELOPE_BANDS if isinstance(band, str) else (
            isinstance(band, tuple) and len(band) == 2 and 0 <= float(band[0]) < float(band[1]) <= self.fs_hz / 2)
        require(ok, "envelope_band", band, f"'full', 'auto' or (lo, hi) with 0 <= lo < hi <= {self.fs_hz / 2} Hz")
        require(self.hht_method in HHT_METHODS, "hht_method", self.hht_method, "one of: " + ", ".join(HHT_METHODS))
        require_positive("hht_noise_std_ratio", self.hht_noise_std_ratio)
        require(self.imf_criterion in hht.CRITERIA, "imf_criterion", self.imf_criterion,
                "one of: " + ", ".join(hht.CRITERIA))
        require(isinstance(self.seed, (int, np.integer)) and 0 <= self.seed < 2**32, "seed", self.seed,
                "an integer in [0, 2**32)")

    @classmethod
    def from_dict(cls, values: dict) -> "FeatureConfig":
        """Build from a mapping (e.g. a TOML table); unknown keys are errors."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise InputError("features." + unknown[0], values[unknown[0]], "one of: " + ", ".join(sorted(known)))
        return cls(**values)

    def to_dict(self) -> dict:
        return asdict(self)


def feature_units(config: FeatureConfig) -> dict[str, str]:
    """Feature name -> unit, in column order, for records processed with ``config``."""
    su = config.signal_unit

    def unit(u: str) -> str:
        return {"signal": su, "signal^2": f"({su})^2"}.get(u, u)

    out: dict[str, str] = {}
    for k, u in statistics.STATISTIC_UNITS.items():
        out[f"raw_{k}"] = unit(u)
    for shaft in ("pinion", "wheel"):
        for k, u in indicators.INDICATOR_UNITS.items():
            out[f"tsa_{shaft}_{k}"] = unit(u)
    lines = spectra.mesh_line_frequencies(fm_hz=1.0, fr_pinion_hz=1.0, fr_wheel_hz=1.0,
                                          n_harmonics=config.n_mesh_harmonics, n_sidebands=config.n_sidebands,
                                          n_shaft_orders=config.n_shaft_orders)
    for k in lines:
        out[f"spec_{k}"] = su
    out["spec_pinion_sideband_ratio"] = "1"
    out["spec_wheel_sideband_ratio"] = "1"
    for shaft in ("pinion", "wheel"):
        for k in range(1, config.n_shaft_orders + 1):
            out[f"env_{shaft}_order{k}"] = su
    if config.envelope_band == "auto":
        out["env_band_centre"] = "Hz"
        out["env_band_spectral_kurtosis"] = "1"
    if config.hht_method != "none":
        out.update({"imf_number": "1", "imf_rms": su, "imf_kurtosis": "1", "imf_crest_factor": "1",
                    "imf_energy_mean": unit("signal^2"), "imf_energy_std": unit("signal^2"),
                    "imf_energy_max": unit("signal^2"), "imf_frequency_mean": "Hz"})
    return out


def column_names(config: FeatureConfig) -> list[str]:
    """``name[unit]`` column names of the feature table."""
    return [f"{k}[{u}]" for k, u in feature_units(config).items()]


def _pinion_track(x: np.ndarray, config: FeatureConfig, fr_pinion_hz: float | None,
                  tacho: np.ndarray | None) -> tsa.AngleTrack:
    if config.speed_source == "tacho":
        require(tacho is not None, "tacho", None, "a tachometer channel (speed_source='tacho')")
        t = np.asarray(tacho, dtype=float)
        require(t.shape == x.shape, "tacho", t.shape, f"the shape of the record {x.shape}")
        return tsa.angle_track_from_tacho(t, config.fs_hz, pulses_per_rev=config.pulses_per_rev)
    require(fr_pinion_hz is not None, "fr_pinion_hz", None, "the pinion shaft frequency (Hz)")
    require_positive("fr_pinion_hz", float(fr_pinion_hz))
    if config.speed_source == "mesh_phase":
        return tsa.angle_track_from_mesh_phase(x, config.fs_hz, mesh_order=int(config.z_pinion),
                                               shaft_hz_nominal=float(fr_pinion_hz))
    return tsa.angle_track_constant_speed(x.size, config.fs_hz, float(fr_pinion_hz))


def signal_features(x: np.ndarray, config: FeatureConfig, *, fr_pinion_hz: float | None = None,
                    tacho: np.ndarray | None = None, seed: int = 0) -> dict[str, float]:
    """The feature vector of one record (keys as in :func:`feature_units`).

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Vibration record sampled at ``config.fs_hz``.
    config : FeatureConfig
    fr_pinion_hz : float, optional
        Pinion shaft frequency (Hz); required unless ``speed_source="tacho"``.
        The wheel turns at ``fr_pinion_hz * z_pinion / z_wheel``.
    tacho : array_like, optional
        Tachometer channel on the pinion, same shape as ``x``.
    seed : int
        Seed of the EEMD / CEEMDAN noise for this record.

    A record whose decomposition has no IMF (a constant or dead channel) gets NaN ``imf_*`` features and a
    :class:`NoImfWarning`, not an error.
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 64, "x", a.shape, "a 1-D record of >= 64 samples")
    require(bool(np.all(np.isfinite(a))), "x", "non-finite values", "finite samples only")
    fs = config.fs_hz
    ratio = config.z_pinion / config.z_wheel
    track_p = _pinion_track(a, config, fr_pinion_hz, tacho)
    fr_p = float((track_p.angle_rad[-1] - track_p.angle_rad[0]) / (2 * np.pi * (track_p.time_s[-1] - track_p.time_s[0])))
    fr_w = fr_p * ratio
    fm = config.z_pinion * fr_p
    top = config.n_mesh_harmonics * fm + config.n_sidebands * max(fr_p, fr_w)
    require(top < fs / 2, "fr_pinion_hz", round(fr_p, 6),
            f"a speed keeping mesh harmonic {config.n_mesh_harmonics} and its sidebands below {fs / 2} Hz")
    track_w = tsa.AngleTrack(track_p.time_s, track_p.angle_rad * ratio)
    # the averages skip the upsampling filter's edge effect at both ends (tsa.angular_resample's skip_edges)
    edge_n = tsa.TimeInterpolant.UPSAMPLING_HALF_TAPS
    span = track_w.time_s[-1] - track_w.time_s[0]
    usable = (np.subtract(*tsa.usable_angle_span(track_w, edge_n / fs)[::-1]) / (2 * np.pi)
              if span > 2 * edge_n / fs else 0.0)
    require(usable >= 1 - 1e-9, "x", f"{a.size} samples",
            f"a record holding >= 1 wheel revolution plus {edge_n} samples at each end "
            f"({fs / fr_w + 2 * edge_n:.0f} samples at this speed)")

    out: dict[str, float] = {f"raw_{k}": float(v) for k, v in statistics.time_domain_statistics(a).items()}

    # the mean off first: the resampling's upsampling filter rings at the record's ends in proportion to its end
    # values; the averages skip those ends (skip_edges, the default), the mean off keeps the ring small anyway
    a0 = a - a.mean()
    for shaft, track, fr, z in (("pinion", track_p, fr_p, config.z_pinion), ("wheel", track_w, fr_w, config.z_wheel)):
        avg = tsa.synchronous_average(a0, fs, track, samples_per_rev=tsa.default_samples_per_rev(fs, fr))
        ci = indicators.gear_condition_indicators(avg.average, int(z), n_shaft_orders=config.tsa_shaft_orders,
                                                  n_sideband_orders=config.tsa_sideband_orders)
        out.update({f"tsa_{shaft}_{k}": v for k, v in ci.items()})

    # spectra and envelope of the mean-removed record too: through the window, a mean (an accelerometer's bias, a
    # transmission error's static part) leaks into the shaft-order lines a few bins from DC, and it would be a
    # carrier of the envelope
    lines = spectra.mesh_sideband_amplitudes(a0, fs, fm_hz=fm, fr_pinion_hz=fr_p, fr_wheel_hz=fr_w,
                                             n_harmonics=config.n_mesh_harmonics, n_sidebands=config.n_sidebands,
                                             n_shaft_orders=config.n_shaft_orders, window=config.window)
    out.update({f"spec_{k}": v for k, v in lines.items()})

    band = config.envelope_band
    found = None
    if band == "full":
        band = None
    elif band == "auto":
        min_hz = min(config.n_mesh_harmonics * fm, 0.25 * fs)  # above the mesh harmonics if room
        found = env.find_resonance_band(a0, fs, min_hz=min_hz)
        band = found.band_hz
    out.update(env.envelope_order_amplitudes(a0, fs, fr_pinion_hz=fr_p, fr_wheel_hz=fr_w,
                                             n_orders=config.n_shaft_orders, band_hz=band, window=config.window))
    if found is not None:
        out["env_band_centre"] = found.centre_hz
        out["env_band_spectral_kurtosis"] = found.spectral_kurtosis

    if config.hht_method != "none":
        out.update(_hht_features(a, config, fm, seed))
        if not np.isfinite(out["imf_number"]):
            warnings.warn("the record has no IMF (constant, or fewer than three extrema): its imf_* features are NaN",
                          NoImfWarning, stacklevel=2)
    return out


#: the HHT features of a record without IMFs
HHT_FEATURES: tuple[str, ...] = ("imf_number", "imf_rms", "imf_kurtosis", "imf_crest_factor", "imf_energy_mean",
                                 "imf_energy_std", "imf_energy_max", "imf_frequency_mean")


class NoImfWarning(UserWarning):
    """A record's decomposition has no IMF (a constant or dead record): its HHT features are NaN."""


def _hht_features(a: np.ndarray, config: FeatureConfig, fm: float, seed: int) -> dict[str, float]:
    """The ``imf_*`` features of one record; NaN when its decomposition has no IMF (a constant record, or one with
    fewer than three extrema)."""
    dec = hht.decompose(a, method=config.hht_method, trials=config.hht_trials,
                        noise_std_ratio=config.hht_noise_std_ratio, seed=int(seed))
    if dec.n_imfs == 0:
        return {k: float("nan") for k in HHT_FEATURES}
    fs = config.fs_hz
    sel = hht.select_imf(dec.imfs, fs, criterion=config.imf_criterion, fm_hz=fm, imf_number=config.imf_number)
    imf = dec.imfs[sel.index]
    energy = hht.energy_index(hht.hilbert_spectrum(imf, fs, n_freq_bins=config.hilbert_bins))
    _, freq = hht.instantaneous_amplitude_frequency(imf, fs)
    return {
        "imf_number": float(sel.index + 1),
        "imf_rms": float(statistics.rms(imf)),
        "imf_kurtosis": float(statistics.kurtosis(imf)),
        "imf_crest_factor": float(statistics.crest_factor(imf)),
        "imf_energy_mean": float(energy.mean()),
        "imf_energy_std": float(energy.std()),
        "imf_energy_max": float(energy.max()),
        "imf_frequency_mean": float(np.sum(freq * energy) / np.sum(energy)) if energy.sum() > 0 else float("nan"),
    }


def record_seeds(root_seed: int, n: int) -> np.ndarray:
    """Per-record seeds ``SeedSequence([root_seed, i]).generate_state(1)[0]`` for ``i < n``."""
    return np.array([np.random.SeedSequence([int(root_seed), i]).generate_state(1)[0] for i in range(n)],
                    dtype=np.uint64)


def _per_record(value, n: int, field: str) -> list:
    if value is None:
        return [None] * n
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return [float(arr)] * n
    require(arr.shape[0] == n, field, arr.shape, f"a scalar or {n} values (one per record)")
    return [arr[i] if arr.ndim > 1 else float(arr[i]) for i in range(n)]


def _features_quietly(x, config: FeatureConfig, fr_pinion_hz, tacho, seed: int) -> dict[str, float]:
    """:func:`signal_features` without its :class:`NoImfWarning` (the batch warns once, naming its records)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoImfWarning)
        return signal_features(x, config, fr_pinion_hz=fr_pinion_hz, tacho=tacho, seed=seed)


def extract_features(signals: np.ndarray, config: FeatureConfig, *, fr_pinion_hz=None, tachos=None, seeds=None,
                     n_jobs: int = 1, record_names=None) -> pd.DataFrame:
    """Feature table: one row per record, columns ``name[unit]`` (:func:`column_names`).

    Parameters
    ----------
    signals : array_like, shape (n_records, n_samples)
        Records sampled at ``config.fs_hz`` (float32 accepted; computed in float64).
    config : FeatureConfig
    fr_pinion_hz : float or array_like of shape (n_records,), optional
        Pinion shaft frequency (Hz), one for all or one per record.
    tachos : array_like, shape (n_records, n_samples), optional
        Tachometer channels (``speed_source="tacho"``).
    seeds : array_like of int, optional
        Per-record EEMD/CEEMDAN seeds; default :func:`record_seeds` of ``config.seed``.
    n_jobs : int
        Worker processes (joblib); the result does not depend on it.
    record_names : sequence, optional
        How the warnings name the records (e.g. the dataset's sample indices); default their positions.

    Records without IMFs (a constant or dead channel) get NaN ``imf_*`` features; one :class:`NoImfWarning`
    names them all.
    """
    x = np.asarray(signals)
    require(x.ndim == 2 and x.shape[0] >= 1, "signals", x.shape, "a 2-D array (records, samples)")
    require(isinstance(n_jobs, (int, np.integer)) and (n_jobs >= 1 or n_jobs == -1), "n_jobs", n_jobs,
            "an integer >= 1, or -1 for all cores")
    n = x.shape[0]
    frs = _per_record(fr_pinion_hz, n, "fr_pinion_hz")
    tac = [None] * n if tachos is None else _per_record(np.asarray(tachos, dtype=float), n, "tachos")
    sd = record_seeds(config.seed, n) if seeds is None else np.asarray(seeds, dtype=np.uint64)
    require(sd.shape == (n,), "seeds", sd.shape, f"{n} seeds (one per record)")
    # validate cheap per-record inputs before any work
    for i in range(n):
        if config.speed_source != "tacho":
            require(frs[i] is not None and np.isfinite(frs[i]) and frs[i] > 0, f"fr_pinion_hz[{i}]", frs[i],
                    "a finite pinion shaft frequency > 0 (Hz)")
    names = list(range(n)) if record_names is None else list(record_names)
    require(len(names) == n, "record_names", len(names), f"{n} names (one per record)")
    tasks = [(x[i], frs[i], tac[i], int(sd[i])) for i in range(n)]
    if n_jobs == 1 or n == 1:
        rows = [_features_quietly(xi, config, fi, ti, si) for xi, fi, ti, si in tasks]
    else:
        from joblib import Parallel, delayed

        rows = Parallel(n_jobs=n_jobs)(delayed(_features_quietly)(xi, config, fi, ti, si) for xi, fi, ti, si in tasks)
    if config.hht_method != "none":
        empty = [str(names[i]) for i, row in enumerate(rows) if not np.isfinite(row["imf_number"])]
        if empty:
            warnings.warn(f"{len(empty)} record(s) without IMF (constant, or fewer than three extrema; imf_* "
                          f"features NaN): {', '.join(empty[:20])}{' ...' if len(empty) > 20 else ''}",
                          NoImfWarning, stacklevel=2)
    units = feature_units(config)
    data = np.array([[row[k] for k in units] for row in rows], dtype=float)
    return pd.DataFrame(data, columns=[f"{k}[{u}]" for k, u in units.items()])


class FeatureExtractor(TransformerMixin, BaseEstimator):
    """scikit-learn transformer: records ``(n_records, n_samples)`` -> feature matrix.

    ``fit`` only validates and records the output names; ``transform`` is
    stateless (:func:`extract_features`). With ``set_output(transform="pandas")``
    the output is a DataFrame with ``name[unit]`` columns.

    Parameters
    ----------
    config : FeatureConfig
        What to compute (sampling rate, tooth counts, options).
    fr_pinion_hz : float or array_like, optional
        Pinion shaft frequency (Hz) used when ``transform`` is not given one.
    n_jobs : int
        Worker processes.

    Examples
    --------
    >>> from features.synthetic import gear_signal_example
    >>> s = gear_signal_example(duration_s=0.5)
    >>> fx = FeatureExtractor(FeatureConfig(fs_hz=s.fs_hz, z_pinion=28, z_wheel=37, hht_method="none"),
    ...                       fr_pinion_hz=s.fr_pinion_hz)
    >>> fx.fit_transform(s.x[None, :]).shape[0]
    1
    """

    def __init__(self, config: FeatureConfig | None = None, *, fr_pinion_hz=None, n_jobs: int = 1):
        self.config = config
        self.fr_pinion_hz = fr_pinion_hz
        self.n_jobs = n_jobs

    def _config(self) -> FeatureConfig:
        require(isinstance(self.config, FeatureConfig), "config", self.config, "a features.table.FeatureConfig")
        return self.config

    def fit(self, X, y=None):
        """Validate the configuration and record ``n_features_in_`` and ``feature_names_out_``."""
        cfg = self._config()
        x = np.asarray(X)
        require(x.ndim == 2, "X", x.shape, "a 2-D array (records, samples)")
        self.n_features_in_ = int(x.shape[1])
        self.feature_names_out_ = np.asarray(column_names(cfg), dtype=object)
        return self

    def transform(self, X, *, fr_pinion_hz=None, tacho=None):
        """Feature matrix of ``X`` (records as rows); per-call speeds/tachos override the stored ones."""
        cfg = self._config()
        fr = self.fr_pinion_hz if fr_pinion_hz is None else fr_pinion_hz
        table = extract_features(X, cfg, fr_pinion_hz=fr, tachos=tacho, n_jobs=self.n_jobs)
        return table.to_numpy()

    def get_feature_names_out(self, input_features=None):
        """``name[unit]`` of every output column."""
        return np.asarray(column_names(self._config()), dtype=object)
