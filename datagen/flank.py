"""The flank pixel grid and the pit-depth maps that live on it.

A flank is an image: rows are the profile position ``s`` (involute arc length,
m) from the start of the active profile (row 0) to the tip (last row); columns
are the face position ``w`` (m) from one face edge (column 0) to the other.
Rows are uniform in arc length, so every pixel has the same area and the
severity (pitted area / active flank area) is the fraction of pitted pixels.

A pit map holds, per pitted tooth, the pit depth (m) of every pixel; 0 means
intact. Depth matters to the stiffness (section loss), the boolean mask to the
contact.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gearpit.errors import InputError, require, require_positive

GEARS = ("pinion", "wheel")


@dataclass(frozen=True)
class FlankGrid:
    """Pixel grid of one gear's active flank.

    Parameters
    ----------
    n_profile : int
        Rows, along the profile from the start of active profile (row 0) to the tip.
    n_face : int
        Columns, across the face width.
    profile_length_m : float
        Involute arc length from the start of active profile to the tip (m).
    face_width_m : float
        Face width of this gear (m).
    pitch_s_m : float
        Arc length from the start of active profile to the pitch circle (m);
        where real pitting starts.
    """

    n_profile: int
    n_face: int
    profile_length_m: float
    face_width_m: float
    pitch_s_m: float

    def __post_init__(self):
        for name in ("n_profile", "n_face"):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and 2 <= v <= 20000, f"grid.{name}", v, "an integer in [2, 20000]")
        require_positive("grid.profile_length_m", self.profile_length_m)
        require_positive("grid.face_width_m", self.face_width_m)
        require(0 <= self.pitch_s_m <= self.profile_length_m, "grid.pitch_s_m", self.pitch_s_m,
                f"within the profile [0, {self.profile_length_m}] m")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n_profile, self.n_face)

    @property
    def ds_m(self) -> float:
        """Pixel height along the profile (m)."""
        return self.profile_length_m / self.n_profile

    @property
    def dw_m(self) -> float:
        """Pixel width across the face (m)."""
        return self.face_width_m / self.n_face

    @property
    def pixel_area_m2(self) -> float:
        return self.ds_m * self.dw_m

    @property
    def s_centres_m(self) -> np.ndarray:
        """Profile position of each row centre (m)."""
        return (np.arange(self.n_profile) + 0.5) * self.ds_m

    @property
    def w_centres_m(self) -> np.ndarray:
        """Face position of each column centre (m)."""
        return (np.arange(self.n_face) + 0.5) * self.dw_m


@dataclass(frozen=True, eq=False)
class PitMap:
    """Pit depths on the teeth of one gear.

    Parameters
    ----------
    grid : FlankGrid
        The flank grid every depth map lives on.
    depth_m : dict[int, ndarray]
        Tooth index -> pit depth (m) per pixel, shape ``grid.shape``; 0 = intact.
        Teeth are numbered in the order they come into mesh, tooth 0 first.
    gear : {"pinion", "wheel"}
        Which gear carries the pits.
    """

    grid: FlankGrid
    depth_m: dict[int, np.ndarray] = field(default_factory=dict)
    gear: str = "pinion"

    def __post_init__(self):
        require(self.gear in GEARS, "pits.gear", self.gear, "one of: pinion, wheel")
        clean = {}
        for tooth, d in self.depth_m.items():
            require(isinstance(tooth, (int, np.integer)) and tooth >= 0, "pits.tooth", tooth, "an integer >= 0")
            arr = np.asarray(d, dtype=np.float64)
            if arr.shape != self.grid.shape:
                raise InputError(f"pits.tooth[{tooth}].shape", arr.shape, f"the flank grid shape {self.grid.shape}")
            require(bool(np.all(np.isfinite(arr))) and bool(np.all(arr >= 0)), f"pits.tooth[{tooth}].depth_m",
                    "negative or non-finite values", "finite depths >= 0 m")
            clean[int(tooth)] = arr
        object.__setattr__(self, "depth_m", clean)

    @property
    def pitted_teeth(self) -> list[int]:
        """Teeth with at least one pitted pixel, sorted."""
        return sorted(t for t, d in self.depth_m.items() if np.any(d > 0))

    def mask(self, tooth: int) -> np.ndarray:
        """Boolean pit mask of one tooth (all False for an intact tooth)."""
        d = self.depth_m.get(tooth)
        return np.zeros(self.grid.shape, bool) if d is None else d > 0

    def severity(self, tooth: int) -> float:
        """Pitted area / active flank area of one tooth."""
        return float(self.mask(tooth).mean())

    def severities(self) -> dict[int, float]:
        return {t: self.severity(t) for t in self.pitted_teeth}

    @classmethod
    def healthy(cls, grid: FlankGrid, gear: str = "pinion") -> "PitMap":
        return cls(grid=grid, depth_m={}, gear=gear)
