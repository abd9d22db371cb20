"""Figures of mesh stiffness (no computation here beyond unit conversion)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_stiffness(curves: dict, path, *, title: str = "") -> None:
    """Total mesh stiffness over the pinion angle for several labelled MeshStiffness results."""
    fig, ax = plt.subplots(figsize=(9, 3.6))
    for label, ms in curves.items():
        ax.plot(np.degrees(ms.angle_rad), ms.k_n_per_m / 1e6, lw=0.9, label=label)
    ax.set_xlabel("pinion angle (deg)")
    ax.set_ylabel("mesh stiffness (N/um)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_pixel_map(stiffness_map: np.ndarray, grid, path, *, title: str = "") -> None:
    """The spur paper's pixel stiffness map of one flank (rows: profile, columns: face)."""
    fig, ax = plt.subplots(figsize=(7, 3))
    extent = [0, grid.face_width_m * 1e3, 0, grid.profile_length_m * 1e3]
    im = ax.imshow(stiffness_map / 1e6, origin="lower", aspect="auto", extent=extent, cmap="viridis")
    ax.set_xlabel("face position (mm)")
    ax.set_ylabel("profile position from SAP (mm)")
    ax.set_title(title)
    fig.colorbar(im, ax=ax, label="pixel stiffness (N/um)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
