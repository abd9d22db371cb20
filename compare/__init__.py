"""Model versus measurement: one error, many views, and which effect is missing.

- ``formats``       readers: CSV/TXT, NPY, NPZ, WAV, MAT (v7.3 via h5py), MCC5-THU, PHM 2023, SEU layouts
- ``array_files``   the NPY, NPZ, WAV and MAT readers (structs flattened, the file's own sampling rate)
- ``raw_record``    what every reader returns, before validation
- ``sidecar``       the sidecar (JSON/TOML): what a file cannot say (operating point, pair, channels); found beside it
- ``measurement``   loading and validation of a file with its sidecar -> :class:`Measurement`
- ``speed``         speed refined from the tachometer or the mesh harmonics; the shaft angle track
- ``speed_track``   a record whose speed drifts: what is slow enough to follow, and following it (pulses, mesh phase)
- ``spectra``       order-domain records (pinion and wheel angle), power and envelope spectra, noise floors
- ``plan``          the named physical locations of a comparison, fixed once from the measurement
- ``views``         order, band, envelope, TSA and statistics views: levels (dB) at the plan's locations
- ``error``         sensor gain fit, noise floors, residuals, the scalar error per view and in total (raw, noise, excess)
- ``model``         the comparison model (TOML the user edits): drive train, effects, plugins -> simulation cases
- ``comparison``    one comparison end to end (measurement + model -> :class:`Comparison`), noise matching
- ``calibration``   the drive-train nuisances (damping, bearing stiffness) fitted to the measurement first
- ``calibration_points`` the calibration's scan points: a batch of drive-train values scored, vertex, 1-sigma
- ``disagreements`` the largest disagreements, ranked, in physical terms; an unclaimed local fault's TSA signature
- ``fitspace``      an effect's declared fit parameters as search coordinates; starting points
- ``search``        the batched search rounds and the quadratic surrogate
- ``fitting``       one group of candidate effects fitted in batched rounds; each one's best fit and 1-sigma
- ``candidates``    a fitted candidate, the attribution's result, and the claim and rival rules
- ``attribution``   fit every missing registered effect, rank by error reduction, claim, flag the unexplained
- ``nuisance_refit`` a calibrated attribution's leading candidates refitted with the nuisances (short scans)
- ``joint_refit``   a calibrated pass's claimed effect refitted with the nuisances over their whole box (its
                    leader, re-examined so, when it claims nothing)
- ``chaos``         a chaotic model (backlash rattle): several realisations, whole-record ladders, intervals
- ``refit``         the effects already in the model fitted again, each against the model without it
- ``channels``      further measured channels (encoders' transmission error, ...) settle rivals the sensor cannot
- ``escalation``    the "auto" calibration mode: as written first, calibrated when nothing explains the mismatch
- ``ledger``        append-only history of comparisons next to the model
- ``report``        the JSON document and the self-contained HTML report (schema in ``schema``)
- ``plots``         figures (matplotlib, Agg) - the only module that draws
- ``workflow``      the user's loop in one call (used by ``gearpit compare`` and the walkthrough)
- ``synthetic``     simulated 'measurements' with a hidden effect and nuisances (tests, walkthrough, benchmark)
"""
