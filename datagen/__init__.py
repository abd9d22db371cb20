"""Synthetic data generation, one module per stage of the pipeline.

- ``geometry``   gear pair description, presets, validation, TOML loading
- ``flank``      the flank pixel grid and the pit-depth maps living on it
- ``pits``       procedural pits (ellipses, rectangles, progressive clusters)
- ``photo``      pit masks extracted from a photo of a flank
- ``compliance`` potential-energy tooth compliance terms (bending, shear, axial, fillet, Hertz)
- ``stiffness``  time-varying mesh stiffness over a revolution, slices, pits
"""
