"""Synthetic data generation, one module per stage of the pipeline.

- ``geometry``   gear pair description, presets, validation
- ``pair_file``  a gear pair from its TOML / JSON form (mm, deg, GPa at the boundary)
- ``design_checks``  undercut, rim, pointed tip, interference, contact ratio of a pair (run when it is built)
- ``flank``      the flank pixel grid and the pit-depth maps living on it
- ``pits``       pit maps from a spec: shape family, teeth, severity, seed (TOML ``[pits]``)
- ``pitshapes``  drawing pits: ellipses, rectangles, depth profiles, sized to a severity
- ``pitcluster`` progressive pitting: small pits near the pitch line that grow and merge
- ``pitio``      pit maps as PNG (16-bit depth in um, or painted masks) and NPZ
- ``photo``      pit masks extracted from a photo of a flank
- ``photo_input`` reading a flank photo, checking it can be one (proportions, a lit surface)
- ``photo_lighting`` the photo's illumination, divided out before pits are sought
- ``compliance`` potential-energy tooth compliance terms (bending, shear, axial, fillet, Hertz), pair compliance table
- ``stiffness``  time-varying mesh stiffness over a revolution, slices, pits
- ``pit_stiffness``  how a pit map changes the compliances of the slices it touches (pit models, section loss)
- ``centre_offset``  the pair at moving centres (eccentricity, hook 2c), on subdivided grid steps
- ``centre_banded``  a staggered (helical) pair's slices summed by contact bands at each record point (hook 2c)
- ``compiled_centre``, ``compiled_records``  the hook-2c records' kernels compiled (numba); the numpy rules are their reference
- ``lumped_model``     DOFs, mass / stiffness / damping matrices of the drive train (spur 6 DOF, helical 8)
- ``mesh_excitation``  stiffness + effect deviations -> the periodic mesh record a simulation reads
- ``newmark``          batched average-acceleration Newmark with the rank-one mesh term (+ Newton)
- ``shooting``         periodic steady state of linear constant-speed cases
- ``time_stepping``    start-up transient + kept record for nonlinear / non-stationary cases
- ``compiled_stepping``  the time-stepping loop compiled (numba); the numpy loop of ``newmark`` is its reference
- ``dynamics``         picks the path and batches cases
- ``batch_solve``      a simulation call's cases prepared (pits -> stiffness -> hooks 1-2 -> lumped model) and
  solved within a memory budget for their mesh records
- ``output_channels``, ``decimation``  channels, anti-alias filtering and decimation to fs
- ``simulate``   THE orchestrator: Case -> Signals (CLI, datasets, comparison and tests call it)
- ``effects/``   the effect contract and the physical effects (registry)
- ``sweep``, ``class_grid``, ``draws``, ``sampling``  dataset sweep configs, their class grid and per-sample
  draws from (seed, index)
- ``dataset``, ``generate``, ``torch_dataset``  dataset storage, parallel / Dask generation, torch reader
"""
