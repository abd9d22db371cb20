"""Signal features for gear-pitting diagnosis, one module per job.

- ``statistics``  time-domain statistics (RMS, peak, crest, kurtosis, shape/impulse/clearance factors)
- ``tsa``         shaft angle tracks (speed, tacho, mesh phase), angular resampling, time-synchronous
                  average, regular / residual / difference signals
- ``indicators``  gear condition indicators FM0, FM4, NA4, NB4, M6A, M8A, energy ratio, sideband
                  level factor, sideband index
- ``spectra``     window-corrected amplitude spectrum, mesh harmonics and shaft-order sidebands
- ``envelope``    band-limited envelope, envelope spectrum, spectral-kurtosis band finder
- ``hht``         EMD / EEMD / CEEMDAN, IMF selection, instantaneous amplitude and frequency,
                  Hilbert spectrum, energy index E(t)
- ``table``       the per-signal feature vector, the feature table and the scikit-learn transformer
- ``ranking``     rank features by class separation, monotonicity and robustness
- ``plots``       figures (matplotlib, Agg) - the only module that draws
- ``synthetic``   a gear-like synthetic record for tests, benchmarks and examples
"""
