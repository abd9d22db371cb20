"""A slice of the face sees the pitted share of the face columns it covers (datagen.pit_stiffness.slice_pieces).

Invariant: a spur pair's slices share their contact positions and are uncoupled, so the pitted stiffness is the
same whatever the slice count; only the rounding of the sums may differ (rtol 1e-9). Before the fix a slice took
the pit state of the one column under its centre: a 20 % ellipse on spur-gds (60 x 200 grid) gave a minimum of
1.216e8 N/m with 200 slices, 9.7e7 with 5 and 0 with 1 (the pit covered the single slice's centre).
"""
from __future__ import annotations

import numpy as np
import pytest

from datagen.geometry import preset
from datagen.pit_stiffness import slice_pieces
from datagen.pits import make_pit_map
from datagen.stiffness import mesh_stiffness

SPUR = preset("spur-gds")


@pytest.fixture(scope="module")
def ellipse_map():
    return make_pit_map(SPUR.flank_grid("pinion", 60, 200), shape="ellipse", severity={0: 0.2})


@pytest.mark.parametrize("pit_model", ["no_contact", "weak_spring"])
@pytest.mark.parametrize("n_slices", [1, 5, 37, 1000])
def test_slice_count_does_not_change_a_spur_pit(ellipse_map, pit_model, n_slices):
    ref = mesh_stiffness(SPUR, pits=ellipse_map, positions_per_cycle=16, n_slices=200, pit_model=pit_model)
    got = mesh_stiffness(SPUR, pits=ellipse_map, positions_per_cycle=16, n_slices=n_slices, pit_model=pit_model)
    np.testing.assert_allclose(got.k_n_per_m, ref.k_n_per_m, rtol=1e-9)
    assert got.k_n_per_m.min() > 1.2e8


def test_pieces_cover_every_slice_once():
    """Invariant: the pieces' shares add to 1 in every slice; with slices equal to columns each slice is one
    piece of share exactly 1 (the per-column model, bit for bit)."""
    grid = SPUR.flank_grid("pinion", 10, 7)
    for n in (1, 3, 7, 20):
        dw = SPUR.contact_face_width_m / n
        sl, cols, share = slice_pieces((np.arange(n) + 0.5) * dw, dw, [(grid, 0.0)])
        np.testing.assert_allclose(np.bincount(sl, weights=share, minlength=n), 1.0, rtol=1e-12)
        assert set(cols[0]) == set(range(7))
    dw = SPUR.contact_face_width_m / 7
    sl, cols, share = slice_pieces((np.arange(7) + 0.5) * dw, dw, [(grid, 0.0)])
    assert list(sl) == list(range(7)) and list(cols[0]) == list(range(7)) and np.all(share == 1.0)
