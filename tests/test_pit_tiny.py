"""A requested pit of one pixel comes back as one pixel (datagen.pitshapes._sized_ellipse).

Invariant: the pixel count closest to the request is reachable for a single pixel on any grid. Before the fix a
centred ellipse on a grid with an even column count (its centre on a pixel edge) grew in pairs: a one-pixel request
on 20x50 gave 0 pixels (an intact tooth, pitted_teeth []), on 60x200 2 pixels.
"""
from __future__ import annotations

import pytest

from datagen.geometry import preset
from datagen.pits import make_pit_map


@pytest.mark.parametrize("shape", ["ellipse", "rectangle", "cluster"])
@pytest.mark.parametrize("grid_px", [(20, 50), (20, 51), (60, 200), (219, 1000)])
def test_one_pixel_request_gives_one_pixel(grid_px, shape):
    grid = preset("spur-gds").flank_grid("pinion", *grid_px)
    n = grid.n_active_pixels
    pm = make_pit_map(grid, shape=shape, severity={0: 1.0 / n}, seed=1)
    assert pm.pitted_teeth == [0]
    assert int(pm.mask(0).sum()) == 1


@pytest.mark.parametrize("grid_px", [(20, 50), (60, 200)])
def test_small_odd_requests_are_met(grid_px):
    grid = preset("spur-gds").flank_grid("pinion", *grid_px)
    for k in (1, 3, 5):
        pm = make_pit_map(grid, shape="ellipse", severity={0: k / grid.n_active_pixels})
        assert int(pm.mask(0).sum()) == k


def test_coarse_grid_refusal_names_the_resolution():
    """An 8x12 grid stalls a 0.25 cluster at 0.2083; the refusal said "at most 50000 pits" while the limit is 0.6.
    It now names the grid's resolution and the reachable severity."""
    from gearpit.errors import InputError

    grid = preset("spur-gds").flank_grid("pinion", 8, 12)
    with pytest.raises(InputError, match="resolution") as err:
        make_pit_map(grid, shape="cluster", severity={0: 0.25}, seed=0)
    assert "stalled at" in str(err.value)
