"""Procedural pits (datagen.pits, datagen.pitshapes) and pit-map files (datagen.pitio).

Grids: FINE has the spur paper's 219 x 1000 pixels (seed 000); its flank size
(6 mm profile, 25 mm face, pitch line 2.8 mm above the start of active profile)
is illustrative. COARSE is a 24 x 100 grid of the same flank.
"""
from __future__ import annotations

import math
import tomllib

import cv2
import numpy as np
import pytest
from scipy import ndimage

from datagen.flank import FlankGrid, PitMap
from datagen.pitio import (load_mask_png, load_npz, load_pit_pngs, read_depth_png, save_npz, save_pit_pngs,
                           write_depth_png)
from datagen.pits import (PitSpec, cluster, default_tolerance, ellipse, make_pit_map, max_severity, rectangle,
                          tooth_rng)
from gearpit.errors import InputError

FINE = FlankGrid(n_profile=219, n_face=1000, profile_length_m=6e-3, face_width_m=25e-3, pitch_s_m=2.8e-3)
COARSE = FlankGrid(n_profile=24, n_face=100, profile_length_m=6e-3, face_width_m=25e-3, pitch_s_m=2.8e-3)


def _ellipse_perimeter(a: float, b: float) -> float:
    """Ramanujan's second approximation for full axes a, b."""
    h = ((a - b) / (a + b)) ** 2
    return math.pi * (a + b) / 2 * (1 + 3 * h / (10 + math.sqrt(4 - 3 * h)))


# ------------------------------------------------------------------ severity

@pytest.mark.parametrize("grid", [FINE, COARSE], ids=["219x1000", "24x100"])
@pytest.mark.parametrize("shape", ["ellipse", "rectangle", "cluster"])
@pytest.mark.parametrize("severity", [0.05, 0.15, 0.20, 0.25])
def test_severity_hits_target(grid, shape, severity):
    """Achieved severity within the stated tolerance max(0.002, 4/pixels) of the target.

    Source: the spur paper's 15/20/25 % severities; tolerance is this module's
    contract (default_tolerance). On the 219 x 1000 grid the measured error is
    at most 25 pixels (rectangle rows/columns granularity), asserted <= 1.2e-4.
    """
    pm = make_pit_map(grid, shape=shape, severity=severity, teeth=[2], seed=7)
    err = abs(pm.severity(2) - severity)
    assert err <= default_tolerance(grid)
    if grid is FINE:
        assert err <= 1.2e-4
    assert pm.pitted_teeth == [2]
    np.testing.assert_array_equal(np.unique(pm.depth_m[2]), [0.0, 0.2e-3])  # flat pits of the default 0.2 mm


def test_per_tooth_severities():
    """A mapping tooth -> severity gives every tooth its own severity (tolerance as above)."""
    wanted = {0: 0.15, 4: 0.20, 9: 0.25}
    pm = make_pit_map(FINE, shape="cluster", severity=wanted, seed=3)
    assert sorted(pm.depth_m) == [0, 4, 9]
    for tooth, sev in wanted.items():
        assert abs(pm.severity(tooth) - sev) <= default_tolerance(FINE)
    spec = PitSpec(shape="ellipse", teeth=(1, 2), severity=(0.1, 0.2))
    assert spec.build(COARSE, gear="wheel").gear == "wheel"
    assert spec.severity_by_tooth == {1: 0.1, 2: 0.2}


# ------------------------------------------------------------- single pits

@pytest.mark.parametrize("angle", [0.0, 0.3, 1.0, math.pi / 2])
@pytest.mark.parametrize("axes_mm", [(2.0, 5.0), (1.0, 1.5)])
def test_ellipse_area_matches_pi_ab_over_4(angle, axes_mm):
    """Pixel area of an unclipped ellipse = pi*a*b/4 within half its perimeter times the larger pixel side.

    Source: area of an ellipse with full axes a, b; the pixel-centre rule can
    only err on pixels the outline crosses. Measured error <= 21 pixels against
    bounds of 79-230 pixels.
    """
    a, b = axes_mm[0] * 1e-3, axes_mm[1] * 1e-3
    d = ellipse(FINE, centre_s_m=3e-3, centre_w_m=12e-3, axis_s_m=a, axis_w_m=b, depth_m=1e-4, angle_rad=angle)
    area = np.count_nonzero(d) * FINE.pixel_area_m2
    bound = 0.5 * _ellipse_perimeter(a, b) * max(FINE.ds_m, FINE.dw_m)
    assert abs(area - math.pi * a * b / 4) <= bound
    rows, cols = np.nonzero(d)
    assert abs(FINE.s_centres_m[rows].mean() - 3e-3) <= FINE.ds_m  # centred where asked, within one pixel
    assert abs(FINE.w_centres_m[cols].mean() - 12e-3) <= FINE.dw_m


def test_rectangle_area_and_rotation():
    """Axis-aligned rectangle area = a*b within one row and one column of pixels; a quarter turn swaps the sides.

    Source: rectangle area; the rotation convention (angle turns the s-axis
    towards w). Tolerance: one pixel row + one pixel column.
    """
    a, b = 1.3e-3, 4.1e-3
    d = rectangle(FINE, centre_s_m=3e-3, centre_w_m=10e-3, axis_s_m=a, axis_w_m=b, depth_m=1e-4)
    assert abs(np.count_nonzero(d) * FINE.pixel_area_m2 - a * b) <= a * FINE.dw_m + b * FINE.ds_m
    rows, cols = np.nonzero(d)
    assert abs((np.ptp(rows) + 1) * FINE.ds_m - a) <= FINE.ds_m
    assert abs((np.ptp(cols) + 1) * FINE.dw_m - b) <= FINE.dw_m
    turned = rectangle(FINE, centre_s_m=3e-3, centre_w_m=10e-3, axis_s_m=b / 2, axis_w_m=a, depth_m=1e-4,
                       angle_rad=math.pi / 2)
    rows, cols = np.nonzero(turned)
    assert abs((np.ptp(rows) + 1) * FINE.ds_m - a) <= FINE.ds_m  # the w-side a now lies along the profile
    assert abs((np.ptp(cols) + 1) * FINE.dw_m - b / 2) <= FINE.dw_m


def test_pit_clipped_to_flank_and_bowl_profile():
    """A pit centred on the face edge keeps half its area; a bowl has the flat pit's footprint.

    Source: symmetry (half of the ellipse lies off the flank), tolerance of the
    area test above; bowl = depth * max(1 - r^2, 0.1) (module docstring), so
    its deepest pixel is within 1 % of depth_m and its shallowest >= 10 %.
    """
    a, b = 2e-3, 4e-3
    d = ellipse(FINE, centre_s_m=3e-3, centre_w_m=0.0, axis_s_m=a, axis_w_m=b, depth_m=1e-4)
    bound = 0.5 * _ellipse_perimeter(a, b) * max(FINE.ds_m, FINE.dw_m)
    assert abs(np.count_nonzero(d) * FINE.pixel_area_m2 - math.pi * a * b / 8) <= bound
    flat = ellipse(FINE, centre_s_m=3e-3, centre_w_m=12e-3, axis_s_m=a, axis_w_m=b, depth_m=1e-4)
    bowl = ellipse(FINE, centre_s_m=3e-3, centre_w_m=12e-3, axis_s_m=a, axis_w_m=b, depth_m=1e-4, profile="bowl")
    np.testing.assert_array_equal(flat > 0, bowl > 0)
    assert bowl.max() == pytest.approx(1e-4, rel=0.01)
    assert bowl[bowl > 0].min() >= 0.1e-4 - 1e-12


# --------------------------------------------------------------- randomness

def test_same_seed_same_bytes_different_seed_differs():
    """Same seed -> identical bytes; another seed -> a different cluster (rule: randomness comes in)."""
    a = make_pit_map(FINE, shape="cluster", severity=0.2, teeth=[0, 5], seed=11)
    b = make_pit_map(FINE, shape="cluster", severity=0.2, teeth=[0, 5], seed=11)
    c = make_pit_map(FINE, shape="cluster", severity=0.2, teeth=[0, 5], seed=12)
    for t in (0, 5):
        assert a.depth_m[t].tobytes() == b.depth_m[t].tobytes()
        assert not np.array_equal(a.depth_m[t], c.depth_m[t])
    assert not np.array_equal(a.depth_m[0], a.depth_m[5])  # teeth get their own pits


def test_tooth_independent_of_other_teeth():
    """A tooth's pits do not change when other teeth are added (per-tooth SeedSequence children)."""
    alone = make_pit_map(FINE, shape="cluster", severity=0.15, teeth=[3], seed=5)
    many = make_pit_map(FINE, shape="cluster", severity={0: 0.25, 3: 0.15, 9: 0.05}, seed=5)
    np.testing.assert_array_equal(alone.depth_m[3], many.depth_m[3])
    spawned = np.random.SeedSequence(5).spawn(4)[3]
    assert np.random.default_rng(spawned).random() == tooth_rng(5, 3).random()


# ---------------------------------------------------------- progressive pits

def test_cluster_concentrates_near_pitch_line():
    """Cluster pits lie about the pitch line.

    Source: the spur paper makes its pits near the pitch line. Tolerance: the
    centroid within 0.15 of the profile length of pitch_s_m (measured <= 0.10
    over 30 seeds) and >= 70 % of pitted pixels within +-0.3 profile lengths
    (two default spreads) of it.
    """
    s = FINE.s_centres_m[:, None]
    for seed in range(5):
        m = cluster(FINE, target_severity=0.25, rng=tooth_rng(seed, 0)) > 0
        rows = np.nonzero(m)[0]
        assert abs(FINE.s_centres_m[rows].mean() - FINE.pitch_s_m) <= 0.15 * FINE.profile_length_m
        band = np.abs(s - FINE.pitch_s_m) <= 0.3 * FINE.profile_length_m
        assert np.count_nonzero(m & band) >= 0.7 * np.count_nonzero(m)


def test_cluster_grows_progressively_and_merges():
    """From 5 % to 25 %: the smaller pit set is contained in the larger, and pits merge.

    Source: progressive pitting (many small pits that grow and coalesce).
    Measured over 30 seeds: 12.8 components at 5 % -> 7.3 at 25 %, fewer on
    every seed; asserted per seed (5 seeds) and on the mean (< 0.75 x).
    """
    n5, n25 = [], []
    for seed in range(5):
        m5 = cluster(FINE, target_severity=0.05, rng=tooth_rng(seed, 0)) > 0
        m25 = cluster(FINE, target_severity=0.25, rng=tooth_rng(seed, 0)) > 0
        assert not np.any(m5 & ~m25)
        n5.append(ndimage.label(m5)[1])
        n25.append(ndimage.label(m25)[1])
        assert n25[-1] < n5[-1]
    assert np.mean(n25) < 0.75 * np.mean(n5)


# ------------------------------------------------------------------- errors

@pytest.mark.parametrize("kwargs, field", [
    (dict(shape="ellipse", severity=0.9, teeth=[0]), "pits.severity[tooth 0]"),
    (dict(shape="rectangle", severity=0.5, teeth=[1], aspect_w_to_s=40.0), "pits.severity[tooth 1]"),
    (dict(shape="cluster", severity=0.7, teeth=[0]), "pits.severity[tooth 0]"),
    (dict(shape="cluster", severity=-0.1, teeth=[0]), "pits.severity[tooth 0]"),
    (dict(shape="blob", severity=0.1, teeth=[0]), "pits.shape"),
    (dict(shape="ellipse", severity=0.1), "pits.teeth"),
    (dict(shape="ellipse", severity={0: 0.1}, teeth=[1]), "pits.teeth"),
    (dict(shape="ellipse", severity=0.1, teeth=[0], depth_m=0.0), "pits.depth_m"),
    (dict(shape="ellipse", severity=0.1, teeth=[0], profile="cone"), "pits.profile"),
    (dict(shape="cluster", severity=0.1, teeth=[0], seed=-1), "pits.seed"),
])
def test_impossible_input_raises_input_error(kwargs, field):
    """Impossible severity or bad options raise InputError naming the field (rule: errors name field/value/allowed)."""
    with pytest.raises(InputError) as info:
        make_pit_map(FINE, **kwargs)
    assert info.value.field == field


def test_max_severity_is_the_largest_whole_pit():
    """Largest ellipse of the flank's proportions covers pi/4 of it; the message names the range.

    Source: area of the ellipse inscribed in a rectangle = pi/4 of it.
    """
    assert max_severity(FINE, "ellipse") == pytest.approx(math.pi / 4)
    assert max_severity(FINE, "rectangle") == pytest.approx(1.0)
    with pytest.raises(InputError, match=r"\[0, 0\.78"):
        make_pit_map(FINE, shape="ellipse", severity=0.8, teeth=[0])


# ---------------------------------------------------------------- PitSpec

def test_pitspec_from_toml_matches_make_pit_map():
    """A TOML [pits] table (depth in mm) builds the same pits as make_pit_map with SI arguments."""
    table = tomllib.loads("""
        [pits]
        shape = "cluster"
        teeth = [0, 7]
        severity = [0.15, 0.25]
        depth_mm = 0.25
        seed = 3
    """)["pits"]
    spec = PitSpec.from_dict(table)
    assert spec.depth_m == pytest.approx(0.25e-3)
    built = spec.build(COARSE)
    direct = make_pit_map(COARSE, shape="cluster", severity={0: 0.15, 7: 0.25}, seed=3, depth_m=0.25e-3)
    for t in (0, 7):
        np.testing.assert_array_equal(built.mask(t), direct.mask(t))
        np.testing.assert_allclose(built.depth_m[t], direct.depth_m[t], rtol=1e-15)
    with pytest.raises(InputError) as info:
        PitSpec.from_dict({**table, "depth": 0.2})
    assert info.value.field == "pits.depth"
    with pytest.raises(InputError) as info:
        PitSpec.from_dict({"shape": "ellipse", "teeth": [0]})
    assert info.value.field == "pits.severity"
    with pytest.raises(InputError) as info:
        PitSpec.from_dict({**table, "severity": [0.1, 0.2, 0.3]})
    assert info.value.field == "pits.severity"


# -------------------------------------------------------------------- files

def _bowl_map(grid: FlankGrid) -> PitMap:
    return make_pit_map(grid, shape="cluster", severity={1: 0.2, 4: 0.1}, seed=2, profile="bowl", gear="wheel")


def test_png_round_trip_to_one_micrometre(tmp_path):
    """16-bit PNG in um: depths round-trip within 0.5 um (stated: 1 um), masks exactly; files only, no leftovers."""
    pm = _bowl_map(FINE)
    paths = save_pit_pngs(pm, tmp_path / "pits")
    assert sorted(p.name for p in (tmp_path / "pits").iterdir()) == ["pitmap.json", "tooth_001.png",
                                                                     "tooth_004.png"]
    assert [p.name for p in paths] == ["tooth_001.png", "tooth_004.png"]
    back = load_pit_pngs(tmp_path / "pits", FINE, gear="wheel")
    assert sorted(back.depth_m) == [1, 4]
    for t in (1, 4):
        np.testing.assert_array_equal(back.mask(t), pm.mask(t))
        assert np.max(np.abs(back.depth_m[t] - pm.depth_m[t])) <= 0.5e-6 + 1e-12


def test_painted_mask_png_loads_with_default_depth(tmp_path):
    """A 1-bit painted PNG (white = pit) and an inverted 8-bit one load as masks of the given depth."""
    mask = np.zeros(COARSE.shape, bool)
    mask[8:14, 30:60] = True
    cv2.imwrite(str(tmp_path / "white.png"), mask.astype(np.uint8) * 255, [cv2.IMWRITE_PNG_BILEVEL, 1])
    d = read_depth_png(tmp_path / "white.png", COARSE, default_depth_m=0.3e-3)
    np.testing.assert_array_equal(d, np.where(mask, 0.3e-3, 0.0))
    cv2.imwrite(str(tmp_path / "black.png"), np.where(mask, 0, 255).astype(np.uint8))
    d = read_depth_png(tmp_path / "black.png", COARSE, invert=True)
    np.testing.assert_array_equal(d > 0, mask)
    pm = load_mask_png(tmp_path / "white.png", COARSE, gear="wheel", tooth=3, depth_m=0.1e-3)
    assert pm.gear == "wheel" and pm.pitted_teeth == [3] and pm.depth_m[3].max() == 0.1e-3
    assert pm.severity(3) == mask.mean()


def test_png_wrong_shape_or_unreadable_raises(tmp_path):
    """A PNG of the wrong size names the shape and the grid's; an unreadable file is named."""
    write_depth_png(tmp_path / "x.png", np.zeros((20, 100)))
    with pytest.raises(InputError) as info:
        read_depth_png(tmp_path / "x.png", COARSE)
    assert info.value.field.startswith("png.shape") and "(24, 100)" in info.value.allowed
    (tmp_path / "bad.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match="bad.png"):
        read_depth_png(tmp_path / "bad.png", COARSE)
    with pytest.raises(InputError) as info:
        write_depth_png(tmp_path / "deep.png", np.full((4, 4), 0.07))  # 70 mm > 65.535 mm
    assert info.value.field == "png.depth_m"
    assert not (tmp_path / "deep.png").exists()


def test_npz_round_trip_exact(tmp_path):
    """NPZ keeps grid, gear, teeth and float64 depths bit for bit; a bad archive raises InputError."""
    pm = _bowl_map(COARSE)
    save_npz(pm, tmp_path / "pits.npz")
    back = load_npz(tmp_path / "pits.npz")
    assert back.grid == COARSE and back.gear == "wheel" and sorted(back.depth_m) == [1, 4]
    for t in (1, 4):
        assert back.depth_m[t].tobytes() == pm.depth_m[t].tobytes()
    save_npz(PitMap.healthy(COARSE), tmp_path / "healthy.npz")
    assert load_npz(tmp_path / "healthy.npz").depth_m == {}
    np.savez(tmp_path / "short.npz", format="gearpit.pitmap/1")
    with pytest.raises(InputError) as info:
        load_npz(tmp_path / "short.npz")
    assert info.value.field == "npz.n_profile"
    with np.load(tmp_path / "pits.npz") as z:
        data = {k: z[k] for k in z.files}
    data["depth_m"] = data["depth_m"][:, :-1]
    np.savez(tmp_path / "cut.npz", **data)
    with pytest.raises(InputError) as info:
        load_npz(tmp_path / "cut.npz")
    assert info.value.field == "npz.depth_m.shape" and "(2, 24, 100)" in info.value.allowed


def _npz_with(tmp_path, name, **changes):
    """A copy of a valid pit-map NPZ (COARSE, wheel teeth 1 and 4) with some arrays replaced."""
    save_npz(_bowl_map(COARSE), tmp_path / "ok.npz")
    with np.load(tmp_path / "ok.npz") as z:
        data = {k: z[k] for k in z.files}
    data.update(changes)
    np.savez(tmp_path / name, **data)
    return tmp_path / name


@pytest.mark.parametrize("factor", [1e3, 4e4])  # depths written in mm as if m (0.2 'm'); 10 m deep pits
def test_npz_depth_outside_range_refused(tmp_path, factor):
    """load_npz enforces DEPTH_RANGE_M (1 um .. 5 mm) on each tooth's deepest pixel, as PNGs, masks and pit
    tables do; before, a 1000x unit slip or 10 m deep pits reached the stiffness code."""
    pm = _bowl_map(COARSE)
    stack = np.stack([pm.depth_m[1], pm.depth_m[4]]) * factor
    with pytest.raises(InputError) as info:
        load_npz(_npz_with(tmp_path, "deep.npz", depth_m=stack))
    assert info.value.field == "npz.depth_m (tooth 1, deepest pixel)" and "0.005] m" in info.value.allowed


@pytest.mark.parametrize("teeth, shown, words", [
    (np.array([1, 1]), 1, "tooth 1 appears 2 times"),         # merged silently into one tooth before
    (np.array([0.5, 4.0]), 0.5, "tooth 0.5 is not one"),      # truncated to tooth 0 before
])
def test_npz_duplicate_or_fractional_teeth_refused(tmp_path, teeth, shown, words):
    with pytest.raises(InputError) as info:
        load_npz(_npz_with(tmp_path, "teeth.npz", teeth=teeth))
    assert info.value.field == "npz.teeth" and info.value.value == shown and words in info.value.allowed


def test_npz_non_scalar_field_and_npy_file_raise_input_error(tmp_path):
    """A non-scalar n_profile and a .npy file given as a pit map name the field / file (a bare TypeError before)."""
    with pytest.raises(InputError) as info:
        load_npz(_npz_with(tmp_path, "arr.npz", n_profile=np.array([24, 1])))
    assert info.value.field == "npz.n_profile" and "single integer" in info.value.allowed
    np.save(tmp_path / "plain.npy", np.zeros(3))
    with pytest.raises(InputError) as info:
        load_npz(tmp_path / "plain.npy")
    assert info.value.field == "npz" and "plain.npy" in info.value.value and ".npy file" in info.value.allowed


def test_png_directory_keeps_gear_and_grid(tmp_path):
    """A PNG directory's sidecar brings a wheel map back as wheel (pinion before) and refuses another grid of the
    same shape (another pair's flank: loaded silently before) or another gear or pair, naming the field."""
    from datagen.geometry import preset
    spur, helical = preset("spur-gds"), preset("helical-dct")
    grid = spur.flank_grid("wheel", 24, 100)
    pm = make_pit_map(grid, shape="ellipse", severity={0: 0.2}, seed=1, gear="wheel")
    save_pit_pngs(pm, tmp_path / "w", pair_name=spur.name)
    back = load_pit_pngs(tmp_path / "w", grid)
    assert back.gear == "wheel" and back.pitted_teeth == [0]
    assert load_pit_pngs(tmp_path / "w", grid, gear="wheel", pair_name=spur.name).gear == "wheel"
    other = helical.flank_grid("wheel", 24, 100)
    assert other.shape == grid.shape and other != grid
    with pytest.raises(InputError) as info:
        load_pit_pngs(tmp_path / "w", other)
    assert info.value.field.startswith("pitmap.json.") and "another grid" in info.value.allowed
    with pytest.raises(InputError) as info:
        load_pit_pngs(tmp_path / "w", grid, gear="pinion")
    assert info.value.field == "pitmap.json.gear" and info.value.value == "wheel"
    with pytest.raises(InputError) as info:
        load_pit_pngs(tmp_path / "w", grid, pair_name=helical.name)
    assert info.value.field == "pitmap.json.pair" and info.value.value == spur.name


def test_png_directory_without_sidecar_reads_with_warning(tmp_path):
    """An old (or hand-painted) directory without the sidecar is read as before, with a warning."""
    pm = _bowl_map(COARSE)
    save_pit_pngs(pm, tmp_path / "old")
    (tmp_path / "old" / "pitmap.json").unlink()
    with pytest.warns(UserWarning, match="gear and grid .* could not be checked"):
        back = load_pit_pngs(tmp_path / "old", COARSE, gear="wheel")
    assert back.gear == "wheel" and sorted(back.depth_m) == [1, 4]


def test_a_pit_map_built_in_python_with_depths_in_mm_is_refused_by_the_stiffness():
    """Every file and CLI entry checks pit depths (1 um .. 5 mm); a PitMap built in Python did not, and 0.2 read
    as metres (a depth meant in mm) reached the stiffness (an audit: mean stiffness 3.725e8 N/m, no word)."""
    from datagen.geometry import preset
    from datagen.stiffness import mesh_stiffness

    pair = preset("spur-gds")
    grid = pair.flank_grid("pinion", 40, 100)
    d = np.zeros(grid.shape)
    d[15:20, 40:50] = 0.2
    with pytest.raises(InputError, match=r"pits.depth_m\[0\].*1000 times"):
        mesh_stiffness(pair, pits=PitMap(grid=grid, depth_m={0: d}, gear="pinion"), positions_per_cycle=8)
    d[15:20, 40:50] = 0.2e-3
    mesh_stiffness(pair, pits=PitMap(grid=grid, depth_m={0: d}, gear="pinion"), positions_per_cycle=8)
