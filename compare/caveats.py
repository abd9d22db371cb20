"""What a claim does and does not show: caveats the CLI, the report and the JSON attach to a claimed effect.

- an effect that acts alike on every tooth (``mesh_harmonics_only``: profile error, tip relief, Hertz stiffness)
  changes only the mesh harmonics' levels, where two models of one healthy pair already differ;
- a local tooth fault (:data:`LOCAL_FAULT_EFFECTS`) is fitted in one fixed shape, so its size is that shape's:
  ``experiments/pit_shape_check.py`` measured, on the suite's rig, pits given as maps of other shapes read as the
  effect's ellipse (a cluster of 0.20 at 0.165 +/- 0.007, a strip across the face of 0.20 as a tooth broken over
  0.8 of its width), and the 1-sigma of the fit is statistical only (the truth lay 3-6 sigma away even for
  ellipses, the fit staying on the search's 1/12 ladder).
"""
from __future__ import annotations

from datagen.effects import get

#: effects that put a fault of one fixed shape on one tooth: their fitted size is that shape's
LOCAL_FAULT_EFFECTS = ("tooth_pit", "tooth_breakage")


def mesh_shape_caveat(effect: str) -> str:
    """What a claim of an effect that changes only the mesh harmonics' levels does and does not show."""
    return (f"{effect} acts alike on every tooth and changes only the levels of the mesh harmonics; two models of "
            "the same healthy pair already differ there (another stiffness model, another transfer path: on the "
            "independent simulator of tests/foreign_rig.py a healthy pair claimed a profile error), so read this "
            "claim as 'the model's mesh excitation or its path is off' and check the fitted value against what is "
            "known of the gear before taking it as the gear's own")


def local_fault_caveat(effect: str) -> str:
    """What the fitted size of a claimed local tooth fault means (module docstring)."""
    shape = ("an ellipse on the pitch line" if effect == "tooth_pit" else
             "a band of the face width out of contact over the whole profile")
    text = (f"{effect}'s size is that of its own shape ({shape}) whose vibration is closest to the measurement, "
            "and its 1 sigma is statistical only: a fault of another shape reads otherwise (on the suite's rig a "
            "pit cluster of 0.20 read 0.165 +/- 0.007, a strip across the face of 0.20 a tooth broken over 0.8 of "
            "its width: experiments/pit_shape_check.py); take it as the fault's equivalent size")
    if effect == "tooth_pit":
        text += ", and put a mapped or photographed flank into the model's [pits] table to compare it as it is"
    return text


def claim_caveats(attribution) -> list[str]:
    """The caveats of ``attribution``'s claimed effect (empty when nothing is claimed)."""
    if attribution is None or not attribution.claimed:
        return []
    effect = attribution.claimed[0].effect
    out = []
    if get(effect).mesh_harmonics_only:
        out.append(mesh_shape_caveat(effect))
    if effect in LOCAL_FAULT_EFFECTS:
        out.append(local_fault_caveat(effect))
    return out


__all__ = ["LOCAL_FAULT_EFFECTS", "claim_caveats", "local_fault_caveat", "mesh_shape_caveat"]
