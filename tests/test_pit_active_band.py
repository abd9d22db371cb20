"""Severity on the active flank: the contact band of a gear wider than its mate (datagen.flank, datagen.pitshapes).

helical-dct: pinion 19.8 mm, wheel 16.9 mm, so 2.9 mm of the pinion face (14.6 %) never makes contact (the
stiffness offsets its slices by (b - b_contact) / 2). Severity = pitted area / active flank area counts only the
contact band, and procedural pits are drawn on it. Spur pairs with equal face widths are unchanged.
"""
from __future__ import annotations

import hashlib

import numpy as np
import pytest

from datagen.flank import PitMap
from datagen.geometry import preset
from datagen.pits import default_tolerance, make_pit_map
from datagen.stiffness import mesh_stiffness
from gearpit.errors import InputError

HELICAL = preset("helical-dct")
SPUR = preset("spur-gds")


def _strip_columns(grid):
    """Columns whose centre lies outside the contact band (computed here from the pair, not from the grid)."""
    off = (HELICAL.pinion.face_width_m - HELICAL.contact_face_width_m) / 2
    w = grid.w_centres_m
    return (w < off) | (w > HELICAL.pinion.face_width_m - off)


def test_pits_in_the_non_contact_strips_do_not_count():
    """Invariant: a map pitted only in the strips outside the contact face has severity 0 (was 0.146: the
    strips' share of the face) and the same stiffness as the healthy pair."""
    grid = HELICAL.flank_grid("pinion", 40, 200)
    strip = _strip_columns(grid)
    assert 0.13 < strip.mean() < 0.16
    d = np.zeros(grid.shape)
    d[:, strip] = 0.2e-3
    pm = PitMap(grid=grid, depth_m={0: d}, gear="pinion")
    assert pm.severity(0) == 0.0
    # the stiffness of the columns wholly outside the band (a column whose centre is outside but which reaches
    # into the band contacts over that part: the slices see it, the centre-rule severity does not)
    off = (HELICAL.pinion.face_width_m - HELICAL.contact_face_width_m) / 2
    edges = np.arange(grid.n_face + 1) * grid.dw_m
    outside = (edges[1:] <= off) | (edges[:-1] >= HELICAL.pinion.face_width_m - off)
    d = np.zeros(grid.shape)
    d[:, outside] = 0.2e-3
    pm = PitMap(grid=grid, depth_m={0: d}, gear="pinion")
    h = mesh_stiffness(HELICAL, positions_per_cycle=8)
    p = mesh_stiffness(HELICAL, pits=pm, positions_per_cycle=8, n_slices=h.n_slices)
    np.testing.assert_allclose(p.k_n_per_m, h.k_n_per_m, rtol=1e-12)   # summation order only


@pytest.mark.parametrize("shape", ["ellipse", "rectangle", "cluster"])
def test_procedural_pits_lie_on_the_contact_band(shape):
    """Invariant: no procedural pit pixel in the strips (a 0.30 cluster put 8.3 % of its pixels there, giving
    0.324 of the contact band), and the requested severity is met on the contact band within the tolerance."""
    grid = HELICAL.flank_grid("pinion", 40, 200)
    strip = _strip_columns(grid)
    pm = make_pit_map(grid, shape=shape, severity={0: 0.3}, seed=4)
    m = pm.mask(0)
    assert not m[:, strip].any()
    band_severity = m[:, ~strip].mean()
    assert abs(band_severity - 0.3) <= default_tolerance(grid)
    assert pm.severity(0) == pytest.approx(band_severity, abs=1e-12)


def test_active_band_of_the_narrower_gear_is_the_whole_face():
    grid = HELICAL.flank_grid("wheel", 40, 200)
    assert grid.active_cols == slice(0, 200)
    assert grid.n_active_pixels == 40 * 200


# golden: sha256 (first 16 hex digits) of the depth maps the code before this change drew; regenerate with
#   python -c "import hashlib; from datagen.geometry import preset; from datagen.pits import make_pit_map;
#   g = preset('spur-gds').flank_grid('pinion', 60, 200); [print(s, hashlib.sha256(make_pit_map(g, shape=s,
#   severity={0: 0.15}, seed=5).depth_m[0].tobytes()).hexdigest()[:16]) for s in ('ellipse', 'rectangle', 'cluster')]"
SPUR_GOLDEN = {"ellipse": "ae544482526dd1f8", "rectangle": "01733bff2b3bc6c1", "cluster": "6e9f0a840dcbc97d"}


@pytest.mark.parametrize("shape", sorted(SPUR_GOLDEN))
def test_equal_face_widths_unchanged(shape):
    """Golden (exact bytes): on spur-gds (both gears 20 mm) every column is active and the maps and severities
    are those of the code that counted the whole face."""
    grid = SPUR.flank_grid("pinion", 60, 200)
    assert grid.active_cols == slice(0, 200)
    pm = make_pit_map(grid, shape=shape, severity={0: 0.15}, seed=5)
    assert hashlib.sha256(pm.depth_m[0].tobytes()).hexdigest()[:16] == SPUR_GOLDEN[shape]
    assert pm.severity(0) == float(pm.mask(0).mean())


def test_stiffness_refuses_a_grid_with_another_contact_width():
    """A helical pinion map drawn on a grid that claims the whole face is in contact is refused by name."""
    g = HELICAL.flank_grid("pinion", 20, 50)
    from datagen.flank import FlankGrid

    whole = FlankGrid(n_profile=20, n_face=50, profile_length_m=g.profile_length_m, face_width_m=g.face_width_m,
                      pitch_s_m=g.pitch_s_m)
    pm = make_pit_map(whole, shape="ellipse", severity={0: 0.2})
    with pytest.raises(InputError, match="contact_face_width_m"):
        mesh_stiffness(HELICAL, pits=pm, positions_per_cycle=8)
