"""Pits with sub-pixel outlines (datagen.pitshapes.subpixel_pit, PitMap.coverage): the pit of the tooth_pit effect.

References: the outline's geometry (an ellipse's area pi a b / 4, a rectangle's a b); the same ellipse drawn in
whole pixels on a grid 16 times finer (datagen.pitshapes.sized_pit, an independent drawing), averaged over each
coarse pixel; and the whole-pixel model of datagen.pit_stiffness, which a map whose shares are all 1 must give to
the bit.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from datagen.flank import PitMap
from datagen.geometry import preset, spur_pair_example
from datagen.pit_stiffness import pixel_stiffness_map
from datagen.pits import PitSpec, make_pit_map, max_severity, sized_pit, subpixel_pit
from datagen.simulate import Case, OperatingPoint
from datagen.stiffness import mesh_stiffness
from gearpit.errors import InputError

HELICAL = preset("helical-dct")
SPUR = spur_pair_example()


@pytest.mark.parametrize("pair,shape", [(HELICAL, "ellipse"), (SPUR, "ellipse"), (HELICAL, "rectangle")])
def test_the_map_holds_the_requested_area(pair, shape):
    """The shares sum to the requested severity: a rectangle's exactly (its overlaps are exact), an ellipse's to
    the sub-samples' resolution (1e-4 of the flank; the whole-pixel drawing's tolerance is 2e-3)."""
    g = pair.flank_grid("pinion", 64, 48)
    for sev in (0.01, 0.0537, 0.2, 0.41):
        pm = make_pit_map(g, shape=shape, severity=sev, teeth=[0], subpixel=True)
        tol = 1e-12 if shape == "rectangle" else 1e-4
        assert abs(pm.severity(0) - sev) <= tol, (shape, sev, pm.severity(0))
        share = pm.coverage[0]
        assert np.all((share > 0) == (pm.depth_m[0] > 0)) and share.max() == 1.0
        assert 0 < np.count_nonzero((share > 0) & (share < 1))      # an outline that cuts pixels


def test_the_shares_are_a_finer_grids_whole_pixel_ellipse_averaged():
    """Independent drawing: the whole-pixel ellipse of the same severity on a grid 16 times finer each way, averaged
    over every coarse pixel, gives the shares to 0.1 on every pixel, 1 % of the pit's area in all."""
    n = 16
    coarse = HELICAL.flank_grid("pinion", 40, 40)
    fine = HELICAL.flank_grid("pinion", 40 * n, 40 * n)
    _, share = subpixel_pit(coarse, shape="ellipse", severity=0.2)
    ref = (sized_pit(fine, shape="ellipse", severity=0.2) > 0).reshape(40, n, 40, n).mean(axis=(1, 3))
    assert np.abs(share - ref).max() <= 0.1
    assert np.abs(share - ref).sum() <= 0.01 * share.sum()


def _loss(pair, sev, *, subpixel=True, pit_model="no_contact"):
    g = pair.flank_grid("pinion", 64, 64)
    ms = mesh_stiffness(pair, pits=make_pit_map(g, shape="ellipse", severity=sev, teeth=[0], subpixel=subpixel),
                        pit_model=pit_model, n_slices=64)
    return ms.k_n_per_m


@pytest.mark.parametrize("pair", [HELICAL, SPUR], ids=["helical", "spur"])
def test_the_mesh_stiffness_moves_continuously_with_the_severity(pair):
    """A step of 1e-4 in severity moves the record by about a fiftieth of a step of 5e-3 (at most a tenth, and not
    zero); the whole-pixel pit moves it by zero or by whole pixels. And the stiffness the pit removes over the
    revolution grows smoothly: its second differences over steps of 0.01 stay under 10 % of the first."""
    k0, k1, k2 = (_loss(pair, s) for s in (0.2, 0.2001, 0.205))
    small, large = np.abs(k1 - k0).max(), np.abs(k2 - k0).max()
    assert 0 < small <= 0.1 * large, (small, large)
    healthy = _loss(pair, 0.0)
    sevs = np.arange(0.10, 0.301, 0.01)
    removed = np.array([np.sum(np.tile(healthy, _loss(pair, s).size // healthy.size) - _loss(pair, s)) for s in sevs])
    d1, d2 = np.diff(removed), np.diff(removed, 2)
    assert np.all(d1 > 0) and np.abs(d2).max() <= 0.1 * np.abs(d1).min(), (d1, d2)


@pytest.mark.parametrize("pit_model", ["no_contact", "weak_spring"])
def test_shares_of_one_give_the_whole_pixel_record_to_the_bit(pit_model):
    """The whole-pixel ellipse with its coverage spelled out as 1 on every pitted pixel: the same record to the bit
    (the share arithmetic adds exact zeros and multiplies by exact ones)."""
    g = HELICAL.flank_grid("pinion", 64, 64)
    pm = make_pit_map(g, shape="ellipse", severity=0.15, teeth=[0])
    ones = replace(pm, coverage={0: (pm.depth_m[0] > 0).astype(float)})
    a = mesh_stiffness(HELICAL, pits=pm, pit_model=pit_model).k_n_per_m
    b = mesh_stiffness(HELICAL, pits=ones, pit_model=pit_model).k_n_per_m
    assert np.array_equal(a, b)
    assert np.array_equal(pixel_stiffness_map(HELICAL, pm, 0, pit_model=pit_model),
                          pixel_stiffness_map(HELICAL, ones, 0, pit_model=pit_model))


@pytest.mark.parametrize("pit_model", ["no_contact", "weak_spring"])
def test_a_half_pitted_pixel_carries_half_the_load_it_loses(pit_model):
    """One pixel's share set to 0.5: its stiffness picture lies halfway between the intact and the wholly pitted
    pixel's (no_contact: half the intact; weak_spring: the mean of intact and weak), less the smaller section loss."""
    g = SPUR.flank_grid("pinion", 32, 16)
    depth = np.zeros(g.shape)
    depth[16, 8] = 0.2e-3
    whole = PitMap(grid=g, depth_m={0: depth})
    half = replace(whole, coverage={0: np.where(depth > 0, 0.5, 0.0)})
    healthy = pixel_stiffness_map(SPUR, PitMap(grid=g), 0, pit_model=pit_model)[16, 8]
    w = pixel_stiffness_map(SPUR, whole, 0, pit_model=pit_model)[16, 8]
    h = pixel_stiffness_map(SPUR, half, 0, pit_model=pit_model)[16, 8]
    mid = 0.5 * (healthy + w)
    assert w < h < healthy
    assert abs(h - mid) <= 0.02 * (healthy - w), (healthy, w, h)


def test_bad_coverage_and_options_are_refused_naming_the_field():
    g = SPUR.flank_grid("pinion", 16, 16)
    depth = np.zeros(g.shape)
    depth[4:6, 4:6] = 1e-4
    for cov, field in ((np.where(depth > 0, 1.5, 0.0), "pits.coverage[0]"),
                       (np.where(depth > 0, 0.0, 0.0), "pits.coverage[0]"),
                       (np.full(g.shape, 0.5), "pits.coverage[0]"),
                       (np.ones((3, 3)), "pits.coverage[0].shape")):
        with pytest.raises(InputError) as e:
            PitMap(grid=g, depth_m={0: depth}, coverage={0: cov})
        assert e.value.field == field
    with pytest.raises(InputError) as e:
        PitMap(grid=g, depth_m={0: depth}, coverage={1: depth})
    assert e.value.field == "pits.coverage.tooth"
    with pytest.raises(InputError) as e:
        make_pit_map(g, shape="cluster", severity=0.1, teeth=[0], subpixel=True)
    assert e.value.field == "pits.subpixel"
    with pytest.raises(InputError) as e:
        subpixel_pit(g, shape="ellipse", severity=max_severity(g, "ellipse") + 0.01)
    assert e.value.field == "pits.severity"
    with pytest.raises(InputError) as e:
        PitSpec.from_dict({"shape": "ellipse", "teeth": [0], "severity": 0.1, "subpixel": "yes"})
    assert e.value.field == "pits.subpixel"


def test_the_pits_table_key_round_trips_and_is_left_out_when_false():
    """``subpixel = true`` in a [pits] table builds the sub-pixel map and is written back; a case without it
    writes the table it always wrote (no new key)."""
    spec = PitSpec.from_dict({"shape": "ellipse", "teeth": [0], "severity": 0.12, "subpixel": True})
    assert spec.subpixel and spec.build(SPUR.flank_grid("pinion", 32, 32)).coverage
    op = OperatingPoint(1000.0, 50.0)
    on = Case(SPUR, op, pits=spec).to_dict()["pits"]
    off = Case(SPUR, op, pits=replace(spec, subpixel=False)).to_dict()["pits"]
    assert on["subpixel"] is True and "subpixel" not in off
    back = Case.from_dict(Case(SPUR, op, pits=spec).to_dict())
    assert back.pits == spec


def test_a_sub_pixel_map_round_trips_through_npz_and_is_refused_as_depth_pngs(tmp_path):
    """NPZ keeps the shares exactly (the record of the map read back is the record of the map); a depth PNG cannot
    hold them, so writing one is refused by name before any file is written."""
    from datagen.pitio import load_npz, save_npz, save_pit_pngs

    g = HELICAL.flank_grid("pinion", 48, 48)
    pm = make_pit_map(g, shape="ellipse", severity=0.17, teeth=[0, 3], subpixel=True)
    back = load_npz(save_npz(pm, tmp_path / "p.npz"))
    assert sorted(back.coverage) == [0, 3] and all(np.array_equal(back.coverage[t], pm.coverage[t]) for t in (0, 3))
    assert back.severity(0) == pm.severity(0)
    with pytest.raises(InputError) as e:
        save_pit_pngs(pm, tmp_path / "pngs")
    assert e.value.field == "pits.coverage" and not (tmp_path / "pngs").exists()
