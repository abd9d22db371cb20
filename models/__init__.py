"""Classifiers of gear-pitting records, one module per job.

- ``data``            :class:`SignalSet` (records, fs, gear pair, labels) and :class:`PairInfo`
- ``sources``         signal sets from a generated dataset or from measurement files (+ labels.csv), with
                      each measurement's speed measured (tachometer or mesh harmonics)
- ``order_tracking``  a measurement's varying speed followed and the record resampled to constant speed
- ``unknown_rate``    records whose sampling rate is unknown (the SpectraQuest CSVs): mesh-frequency estimate,
                      tooth count from the sidebands
- ``toy``             a small labelled toy signal set for tests, benchmarks and examples
- ``representations`` network inputs: raw segment, envelope spectrum, TSA, order and mesh-order spectra
- ``representation_spec`` which representation and its size (:class:`RepresentationSpec`, checked when built)
- ``tsa``             the TSA and its difference signal (comb of shaft orders, filters, direct DFT of kept orders)
- ``segments``        per-record normalisation and segment starts, shared by ``representations`` and ``tsa``
- ``input_checks``    whether records can be represented (speed, tooth counts, segment length, Nyquist)
- ``order_filters``   the TSA's order low-pass, a zero-phase order high-pass, removal of both shafts' first order
                      (and its closed form on a spectrum), the DFT at a few bins
- ``operating``       side inputs: known speed and load, the record's level (with or without the shaft lines),
                      the level of the TSA's difference signal, the pitted-teeth profile
- ``tooth_profile``   how many tooth pitches the TSA's deviation covers (pitted-teeth count, speed- and scale-free)
- ``augment``         training-time augmentation (crop/phase, gain, noise, speed error, polarity)
- ``cnn``             the multi-task 1-D CNN (severity class, severity fraction, pitted-teeth class)
- ``train``           :class:`TrainConfig` and :func:`train_cnn` (split, loss, early stopping, seeds)
- ``classifier``      :class:`CNNClassifier`: a trained network with its spec; prediction
- ``baselines``       feature-table baselines (logistic regression, random forest, gradient boosting),
                      exported to plain arrays
- ``novelty``         how unlike the training records a signal is (Mahalanobis distance of the features a model
                      reads, scaled by held-out records) and whether a batch is, as a whole
- ``spec``            :class:`ModelSpec` (input spec, classes, ranges, config), input checks, :class:`Predictions`
- ``io``              save / load without pickle (state_dict + JSON, npz + JSON)
- ``evaluate``        accuracy, macro-F1, confusion matrices, severity MAE, breakdowns; JSON and Markdown
- ``plots``           figures of an evaluation (the only module that draws)
"""
