"""gearpit: synthetic tooth-pitting vibration data, features, classifiers, model-vs-measurement.

The pipeline lives in sibling top-level packages, one per stage:

- ``datagen``  geometry -> pit masks -> mesh stiffness -> dynamics -> effects -> datasets
- ``features`` signal processing and feature tables
- ``models``   CNN, baselines, training, evaluation

This package holds only what every stage shares: the error hierarchy, the
file-boundary helpers and the command line (``gearpit ...``).
"""
__version__ = "0.1.0"
