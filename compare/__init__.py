"""Model versus measurement: one error, many views, and which effect is missing.

- ``formats``       readers: CSV/TXT, NPY, NPZ, WAV, MAT (v7.3 via h5py), MCC5-THU, PHM 2023, SEU layouts
- ``measurement``   sidecar (JSON/TOML), loading and validation -> :class:`Measurement`
- ``speed``         speed refined from the tachometer or the mesh harmonics; the shaft angle track
- ``views``         order, band, envelope, TSA and statistics views: levels (dB) at named locations
- ``error``         sensor gain fit, noise-floor matching, residuals, the scalar error per view and in total
- ``model``         the comparison model (TOML the user edits): drive train, effects, plugins -> simulation cases
- ``comparison``    one comparison end to end (measurement + model -> :class:`Comparison`)
- ``disagreements`` the largest disagreements, ranked, in physical terms
- ``attribution``   fit every missing registered effect, rank by error reduction, flag the unexplained
- ``ledger``        append-only history of comparisons next to the model
- ``report``        self-contained HTML report and the JSON document (schema in ``schema``)
- ``plots``         figures (matplotlib, Agg) - the only module that draws
"""
