"""Physical effects that plug into the simulation at fixed contribution points.

- ``base``              the contract: :class:`Effect`, its context and the contribution hooks
- ``registry``          effects by name: :func:`register`, :func:`get`, plugins, :class:`EffectSpec`
- ``noise``             white measurement noise at an SNR (measurement chain)
- ``transmission_path`` bearing force -> housing mode -> housing acceleration (output path)
- ``backlash``          dead-zone mesh law with contact loss (nonlinear mesh law)
- ``profile_error``     profile slope + sinusoidal form deviation from an ISO 1328 grade (tooth deviation)
- ``pitch_error``       cumulative + single-tooth pitch deviation from an ISO 1328 grade (tooth deviation)
- ``tip_relief``        linear / parabolic tip relief (tooth deviation)
- ``eccentricity``      run-out of the pinion or of the wheel (``eccentricity_pinion``/``_wheel``; angle deviation and moving centre)
- ``speed_fluctuation`` sinusoidal input speed fluctuation (operating point)
- ``torque_fluctuation`` sinusoidal load torque ripple (operating point)
- ``tooth_pit``         an elliptical pit on one tooth of the pinion or the wheel (mesh stiffness)
- ``tooth_breakage``    one tooth of the pinion or the wheel broken over part of its face width (mesh stiffness)
- ``hertz_nonlinear``   load-dependent Hertz contact stiffness at the mean load (mesh stiffness)
- ``shaft_encoder_error`` eccentricity of the two shaft encoders on the transmission error ``dte_m`` (measurement chain)
- ``accuracy_grade``    ISO 1328-1 tolerances of a grade (not an effect; used by the error effects)

Importing this package registers the built-in effects.
"""
from datagen.effects import backlash, noise, transmission_path  # noqa: F401  (register built-ins)
from datagen.effects import (eccentricity, hertz_nonlinear, pitch_error, profile_error,  # noqa: F401
                             shaft_encoder_error, speed_fluctuation, tip_relief, tooth_breakage, tooth_pit,
                             torque_fluctuation)
from datagen.effects.base import (Effect, EffectContext, EffectSpec, Fit, MeshState, build_effects, get, load_plugin,
                                  names, register)

__all__ = ["Effect", "EffectContext", "EffectSpec", "Fit", "MeshState", "build_effects", "get", "load_plugin", "names",
           "register"]
