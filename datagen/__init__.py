"""Synthetic data generation, one module per stage of the pipeline.

- ``geometry``   gear pair description, presets, validation, TOML loading
- ``flank``      the flank pixel grid and the pit-depth maps living on it
- ``pits``       pit maps from a spec: shape family, teeth, severity, seed (TOML ``[pits]``)
- ``pitshapes``  drawing pits: ellipses, rectangles, progressive clusters, depth profiles
- ``pitio``      pit maps as PNG (16-bit depth in um, or painted masks) and NPZ
- ``photo``      pit masks extracted from a photo of a flank
- ``compliance`` potential-energy tooth compliance terms (bending, shear, axial, fillet, Hertz)
- ``stiffness``  time-varying mesh stiffness over a revolution, slices, pits
"""
