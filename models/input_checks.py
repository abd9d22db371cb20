"""Checks that records can be represented (:mod:`models.representations`), before any work: the speed or mesh
frequency where needed, the tooth counts, one segment per record at the slowest speed, the highest order below
Nyquist. Every failure is an :class:`~gearpit.errors.InputError` naming the field, the value and what is allowed.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from gearpit.errors import require, require_positive

if TYPE_CHECKING:
    from models.representation_spec import RepresentationSpec


def check_inputs(spec: RepresentationSpec, n_samples: int, fs_hz: float, shaft_hz=None, mesh_cps=None,
                 *, z_pinion: int | None = None, max_speed_factor: float = 1.0, z_wheel: int | None = None) -> None:
    """Raise :class:`InputError` unless records of ``n_samples`` samples can be represented.

    Checks that the speed (or mesh frequency) is given when needed, that one
    segment fits in the record at the slowest speed (times ``1 / max_speed_factor``
    margin for the speed augmentation) and that the highest order kept lies below
    the Nyquist frequency.
    """
    require_positive("fs_hz", float(fs_hz))
    if spec.kind == "tsa":
        require(z_pinion is not None and int(z_pinion) >= 3, "z_pinion", z_pinion,
                "the pinion tooth count (representation 'tsa' removes the mesh harmonics)")
        require(not spec.remove_shaft_1x or (z_wheel is not None and int(z_wheel) >= 3), "z_wheel", z_wheel,
                "the wheel tooth count (remove_shaft_1x removes the wheel's shaft line)")
    if spec.kind in ("tsa", "order"):
        require(shaft_hz is not None, "speed_rpm", None, f"the pinion speed (representation {spec.kind!r} needs it)")
        fr = np.atleast_1d(np.asarray(shaft_hz, dtype=float))
        require(bool(np.all(np.isfinite(fr) & (fr > 0))), "speed_rpm", "non-positive", "speeds > 0")
        slow = float(fr.min()) / max_speed_factor
        need = spec.segment_length(fs_hz, slow)
        require(need <= n_samples, "n_samples", n_samples,
                f">= {need} samples: {spec.n_revs} revolutions at {slow * 60:.0f} rpm and {fs_hz:g} Hz")
        # (tsa: orders above the Nyquist frequency are absent, i.e. zero)
        fast = float(fr.max()) * max_speed_factor
        require(spec.kind == "tsa" or spec.max_order * fast <= fs_hz / 2, "speed_rpm", round(fast * 60, 1),
                f"<= {fs_hz / 2 / spec.max_order * 60:.0f} rpm so that order {spec.max_order:g} stays below "
                f"Nyquist ({fs_hz / 2:g} Hz)")
    elif spec.kind == "mesh_order":
        require(mesh_cps is not None, "mesh_cycles_per_sample", None, "the mesh frequency (speed and tooth count)")
        c = np.atleast_1d(np.asarray(mesh_cps, dtype=float))
        require(bool(np.all(np.isfinite(c) & (c > 0))), "mesh_cycles_per_sample", "non-positive", "values > 0")
        need = spec.segment_length(fs_hz, None, float(c.min()) / max_speed_factor)
        require(need <= n_samples, "n_samples", n_samples,
                f">= {need} samples ({spec.n_mesh_periods} mesh periods at {float(c.min()):.4f} cycles/sample)")
        top = spec.max_order * float(c.max()) * max_speed_factor
        require(top <= 0.5, "mesh_cycles_per_sample", round(float(c.max()), 5),
                f"<= {0.5 / spec.max_order:.4f} so that mesh order {spec.max_order:g} stays below Nyquist")
    else:
        need = int(round(spec.n_samples * max_speed_factor))
        require(need <= n_samples, "n_samples", n_samples, f">= {need} samples (segment of representation {spec.kind!r})")
