"""Pit masks from flank photos (datagen.photo) on synthetic photos rendered here.

The renderer: a pit mask (ellipses or a progressive cluster) is carved into a
height map (depth 4-5 photo pixels, walls blurred over 1.5-2 pixels), shaded
Lambertian under a light 40 degrees above the flank from a random azimuth
(so one wall is lit, the other in shadow), with a dark pit floor (albedo 0.35,
optionally rough), optional grinding marks on the intact surface, multiplied
by an uneven illumination (linear and quadratic across the image), plus
Gaussian noise, then quantised to 8 bits. The acceptance level IoU >= 0.8 is
the project's requirement for the photo route (issue 2); measured IoU on these
photos is 0.85-0.94.
"""
from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import ndimage

from datagen.flank import FlankGrid
from datagen.photo import extraction_steps, flank_crop_box, mask_from_image, pit_map_from_image, resample_mask
from datagen.pits import cluster, ellipse
from gearpit.errors import InputError

PHOTO = (240, 800)  # photo pixels of the flank (rows = profile, columns = face)
GRID = FlankGrid(n_profile=60, n_face=200, profile_length_m=6e-3, face_width_m=20e-3, pitch_s_m=2.8e-3)

#: lighting/noise settings: mild = linear light gradient, 2 % noise;
#: harsh = strong linear + quadratic light, 5 % noise, grinding marks, rough pit floors, wider walls
SETTINGS = {
    "mild": dict(light_gradient=0.4, quad=0.0, noise=0.02),
    "harsh": dict(light_gradient=0.8, quad=0.4, noise=0.05, texture=0.05, rough=0.4, blur_px=2.0, pit_depth_px=5.0),
}


def truth_mask(seed: int) -> np.ndarray:
    """Known pit mask at photo resolution: three random ellipses (even seeds) or a cluster (odd seeds)."""
    g = FlankGrid(PHOTO[0], PHOTO[1], 6e-3, 20e-3, 2.8e-3)
    rng = np.random.default_rng(seed)
    if seed % 2:
        return cluster(g, target_severity=rng.uniform(0.08, 0.25), rng=rng) > 0
    d = np.zeros(g.shape)
    for _ in range(3):
        d = np.maximum(d, ellipse(g, centre_s_m=rng.uniform(1.5e-3, 4.5e-3), centre_w_m=rng.uniform(2e-3, 18e-3),
                                  axis_s_m=rng.uniform(0.8e-3, 2.5e-3), axis_w_m=rng.uniform(1e-3, 4e-3),
                                  depth_m=1.0, angle_rad=rng.uniform(0, np.pi)))
    return d > 0


def render_flank_photo(mask: np.ndarray, seed: int, *, light_gradient: float, quad: float, noise: float,
                       texture: float = 0.0, rough: float = 0.0, blur_px: float = 1.5, pit_depth_px: float = 4.0,
                       margin: int = 0, streak: float = 0.0) -> np.ndarray:
    """8-bit photo of a flank carrying ``mask`` (see the module docstring); ``margin`` adds a dark frame.

    ``streak`` adds a specular highlight off the intact surface: a bright band along the face at 65 % of the
    profile (Gaussian, standard deviation 6 % of the profile), strongest at 60 % of the face width, clipped
    at white -- what a curved involute flank under one lamp shows.
    """
    rng = np.random.default_rng(seed + 1000)
    h_px, w_px = mask.shape
    m = mask.astype(float)
    height = -pit_depth_px * ndimage.gaussian_filter(m, blur_px)
    gy, gx = np.gradient(height)
    normal = np.dstack([-gx, -gy, np.ones_like(height)])
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    elev, azim = np.radians(40), np.radians(rng.uniform(0, 360))
    light = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim), np.sin(elev)])
    lambert = np.clip(normal @ light, 0, None) / np.sin(elev)
    soft = ndimage.gaussian_filter(m, 1.0)
    albedo = 1 - 0.65 * soft
    if rough:
        field = ndimage.gaussian_filter(rng.standard_normal(mask.shape), 2.0)
        albedo *= 1 + rough * field / field.std() * soft
    if texture:
        albedo *= 1 + texture * np.sin(np.arange(h_px)[:, None] * 2 * np.pi / 7.0 + rng.uniform(0, 6))
    y, x = np.mgrid[0:h_px, 0:w_px]
    illum = 1 + light_gradient * (x / w_px - 0.5) + quad * (4 * (y / h_px - 0.5) ** 2 - 0.5)
    img = 0.6 * albedo * (0.15 + 0.85 * lambert) * illum + rng.normal(0, noise, mask.shape)
    if streak:
        band = np.exp(-((y - 0.65 * h_px) / (0.06 * h_px)) ** 2) * (0.6 + 0.4 * np.exp(-((x - 0.6 * w_px) / (0.3 * w_px)) ** 2))
        img = img + streak * ndimage.gaussian_filter(band * (1 - soft), 1.0)
    if margin:
        framed = 0.08 + rng.normal(0, noise, (h_px + 2 * margin, w_px + 2 * margin))
        framed[margin:margin + h_px, margin:margin + w_px] = img
        img = framed
    return np.clip(img * 255, 0, 255).astype(np.uint8)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.count_nonzero(a & b) / max(np.count_nonzero(a | b), 1))


@pytest.mark.parametrize("setting", sorted(SETTINGS))
@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4, 5])
def test_mask_from_photo_iou(setting, seed):
    """IoU >= 0.8 against the known mask on the flank grid (ellipses and clusters, two lighting/noise settings).

    Source: the spur paper's route (Gaussian filter, gradient operator,
    threshold, morphology); IoU >= 0.8 is the issue's acceptance level.
    Measured 0.85-0.94.
    """
    truth = truth_mask(seed)
    photo = render_flank_photo(truth, seed, **SETTINGS[setting])
    mask = mask_from_image(photo, GRID)
    assert mask.shape == GRID.shape and mask.dtype == bool
    assert iou(mask, resample_mask(truth, GRID.shape)) >= 0.8


def test_blur_background_also_works():
    """The normalised-blur lighting model reaches the same IoU >= 0.8 on the harsh photos."""
    for seed in (1, 2):
        truth = truth_mask(seed)
        photo = render_flank_photo(truth, seed, **SETTINGS["harsh"])
        assert iou(mask_from_image(photo, GRID, flatten="blur"), resample_mask(truth, GRID.shape)) >= 0.8


def test_uneven_lighting_needs_flattening():
    """Without flattening the harsh lighting defeats the threshold (IoU < 0.5): the test photos are not trivial;
    and the unflattened surface varies by 0.39 of its level, which the extraction warns about."""
    from datagen.photo import PhotoWarning

    truth = truth_mask(3)
    photo = render_flank_photo(truth, 3, **SETTINGS["harsh"])
    with pytest.warns(PhotoWarning, match="noise"):
        mask = mask_from_image(photo, GRID, flatten="none")
    assert iou(mask, resample_mask(truth, GRID.shape)) < 0.5


def test_intact_flank_gives_no_pits():
    """An intact flank under harsh lighting, noise and grinding marks yields an empty mask (no false pits)."""
    for seed in range(3):
        photo = render_flank_photo(np.zeros(PHOTO, bool), seed, **SETTINGS["harsh"])
        assert not extraction_steps(photo, GRID).mask.any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lighting_gradient_and_specular_streak_give_no_false_pits(seed):
    """An intact flank with a light gradient and a specular streak gives an empty mask (severity <= 0.002);
    the same lighting over a pitted flank keeps IoU >= 0.8.

    The streak is a bright band spanning the face at one profile height: a single quadratic lighting surface
    fitted to the brightest calm region (the old default) left the band between streak and tip ~30 % darker
    than its fit, and read it as pits (severity 0.26-0.28 on these photos); the per-row fit does not.
    """
    light = dict(light_gradient=0.4, quad=0.3, noise=0.02, streak=0.5)
    photo = render_flank_photo(np.zeros(PHOTO, bool), seed, **light)
    assert mask_from_image(photo, GRID).mean() <= 0.002
    truth = truth_mask(seed)
    pitted = render_flank_photo(truth, seed, **light)
    assert iou(mask_from_image(pitted, GRID), resample_mask(truth, GRID.shape)) >= 0.8


def test_auto_crop_and_rotation():
    """Auto crop finds the flank in a dark frame within 2 pixels; rot90 turns a sideways photo back; IoU >= 0.8."""
    truth = truth_mask(4)
    photo = render_flank_photo(truth, 4, margin=30, **SETTINGS["harsh"])
    box = flank_crop_box(photo / 255.0)
    assert np.max(np.abs(np.array(box) - [30, 270, 30, 830])) <= 2
    sideways = np.rot90(photo, -1)  # profile now runs across the image
    mask = mask_from_image(sideways, GRID, crop="auto", rot90=1)
    assert iou(mask, resample_mask(truth, GRID.shape)) >= 0.8


def test_pit_map_from_file_and_formats(tmp_path):
    """From a file: one tooth at uniform depth, severity within 0.02 of the truth.

    16-bit and colour versions of the photo give the same mask as the 8-bit gray one.
    """
    truth = truth_mask(1)
    photo = render_flank_photo(truth, 1, **SETTINGS["mild"])
    cv2.imwrite(str(tmp_path / "flank.png"), photo)
    pm = pit_map_from_image(tmp_path / "flank.png", GRID, gear="wheel", tooth=6, depth_m=0.15e-3)
    assert pm.gear == "wheel" and pm.pitted_teeth == [6]
    np.testing.assert_array_equal(np.unique(pm.depth_m[6]), [0.0, 0.15e-3])
    assert abs(pm.severity(6) - resample_mask(truth, GRID.shape).mean()) <= 0.02
    gray = mask_from_image(photo, GRID)
    np.testing.assert_array_equal(mask_from_image(photo.astype(np.uint16) * 257, GRID), gray)
    np.testing.assert_array_equal(mask_from_image(cv2.cvtColor(photo, cv2.COLOR_GRAY2BGR), GRID), gray)


def test_truncated_jpeg_is_refused(tmp_path):
    """A JPEG cut short (first 5000 bytes) raises InputError naming the file; OpenCV decoded it with the missing
    rows grey and the old code returned a mask (the auditor's truncated.jpg: severity 0.325, exit 0).
    The complete file still reads."""
    photo = render_flank_photo(truth_mask(1), 1, **SETTINGS["mild"])
    ok, buf = cv2.imencode(".jpg", photo, [cv2.IMWRITE_JPEG_QUALITY, 85])
    (tmp_path / "full.jpg").write_bytes(buf.tobytes())
    (tmp_path / "cut.jpg").write_bytes(buf.tobytes()[:5000])
    assert mask_from_image(tmp_path / "full.jpg", GRID).any()
    with pytest.raises(InputError, match="cut.jpg"):
        mask_from_image(tmp_path / "cut.jpg", GRID)


def test_bad_input_raises_input_error(tmp_path):
    """Unreadable image names the file; a crop outside the photo and unknown options name their field."""
    (tmp_path / "broken.jpg").write_bytes(b"\x00garbage")
    with pytest.raises(InputError, match="broken.jpg"):
        mask_from_image(tmp_path / "broken.jpg", GRID)
    with pytest.raises(InputError, match="missing.png"):
        pit_map_from_image(tmp_path / "missing.png", GRID, tooth=0, depth_m=2e-4)
    photo = np.full((50, 80), 128, np.uint8)
    with pytest.raises(InputError) as info:
        mask_from_image(photo, GRID, crop=(0, 60, 0, 80))
    assert info.value.field == "image.crop"
    with pytest.raises(InputError) as info:
        mask_from_image(photo, GRID, flatten="tophat")
    assert info.value.field == "image.flatten"


def test_large_photo_is_area_averaged_to_twice_the_grid():
    """A photo far finer than the grid is processed at 2 x the grid per direction (never up), same IoU.

    Source: the auditor's 4000 x 6000 JPEG took 24 s and 2.5 GB for a 219 x 1000 grid (2.5 s, 0.29 GB after).
    Here a 240 x 800 render enlarged 5x (1200 x 4000) must be worked at 120 x 400 and keep IoU >= 0.8; a photo
    coarser than that (240 x 800 for a 100 x 600 grid: 200 x 800) is kept at its own resolution in that direction.
    """
    truth = truth_mask(0)
    photo = render_flank_photo(truth, 0, **SETTINGS["mild"])
    big = cv2.resize(photo, (PHOTO[1] * 5, PHOTO[0] * 5), interpolation=cv2.INTER_LINEAR)
    steps = extraction_steps(big, GRID)
    assert steps.photo_shape == (1200, 4000)
    assert steps.gray.shape == steps.mask.shape == (2 * GRID.n_profile, 2 * GRID.n_face)
    assert iou(resample_mask(steps.mask, GRID.shape), resample_mask(truth, GRID.shape)) >= 0.8
    fine = FlankGrid(n_profile=100, n_face=600, profile_length_m=6e-3, face_width_m=20e-3, pitch_s_m=2.8e-3)
    assert extraction_steps(photo, fine).gray.shape == (200, 800)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_result_depends_little_on_photo_resolution(seed):
    """The same flank photographed at 240 x 800 and at 60 x 200 (the grid's own resolution) gives nearly the same
    mask on a 60 x 200 grid: sizes are in grid pixels, not photo pixels.

    Tolerance: severities within 0.01 of each other and of the truth, IoU >= 0.8 on both. Before (smoothing,
    smallest pit and opening in photo pixels) the 60 x 200 photos gave severity 0.083 / 0.194 / 0.072 for 0.058 /
    0.169 / 0.054 (IoU 0.70 / 0.66 / 0.75); after 0.060 / 0.176 / 0.056 (IoU 0.93 / 0.92 / 0.93).
    """
    truth = truth_mask(seed)
    fine = render_flank_photo(truth, seed, **SETTINGS["mild"])
    coarse = cv2.resize(fine, (GRID.n_face, GRID.n_profile), interpolation=cv2.INTER_AREA)
    want = resample_mask(truth, GRID.shape)
    m_fine, m_coarse = mask_from_image(fine, GRID), mask_from_image(coarse, GRID)
    assert abs(m_fine.mean() - m_coarse.mean()) <= 0.01
    assert abs(m_coarse.mean() - want.mean()) <= 0.01
    assert min(iou(m_fine, want), iou(m_coarse, want)) >= 0.8


def test_a_photo_turned_a_quarter_is_refused_and_a_cameras_orientation_tag_honoured(tmp_path):
    """A photo turned a quarter (height / width 3.3 for a 0.3 flank) was stretched onto the grid without a word
    (an auditor's transposed photo: the right severity by chance, IoU 0.07); now refused naming rot90. A phone's
    portrait JPEG is stored sideways with an EXIF orientation tag (6: turn 90 degrees clockwise to view), which
    the reader ignored (IoU 0.06 in the audit): now it is turned as the camera says, and gives the upright mask."""
    from PIL import Image

    truth = truth_mask(2)
    photo = render_flank_photo(truth, 2, **SETTINGS["mild"])
    upright = mask_from_image(photo, GRID)
    assert iou(upright, resample_mask(truth, GRID.shape)) >= 0.8
    with pytest.raises(InputError, match="rot90"):
        mask_from_image(np.rot90(photo, -1), GRID)
    assert iou(mask_from_image(np.rot90(photo, -1), GRID, rot90=1), upright) == 1.0
    exif = Image.Exif()
    exif[0x0112] = 6
    Image.fromarray(np.ascontiguousarray(np.rot90(photo, 1))).save(tmp_path / "portrait.jpg", quality=95, exif=exif)
    assert iou(mask_from_image(tmp_path / "portrait.jpg", GRID), upright) >= 0.9


def test_cli_photo_crop_and_turn(tmp_path):
    """``gearpit stiffness --photo`` takes the crop and the quarter turns the API has (the audit's scene photo
    on a background came back healthy with exit 0): a sideways photo in a dark frame is refused as it is, and read
    with --photo-crop (the frame cut off) and --photo-rot90 1 to the mask of the plain photo; the options are
    recorded in the summary."""
    import json

    from gearpit.cli import main

    truth = truth_mask(4)
    photo = render_flank_photo(truth, 4, **SETTINGS["mild"])
    framed = np.zeros((photo.shape[1] + 60, photo.shape[0] + 60), np.uint8)
    framed[30:-30, 30:-30] = np.rot90(photo, -1)
    cv2.imwrite(str(tmp_path / "scene.png"), framed)
    cv2.imwrite(str(tmp_path / "flank.png"), photo)
    common = ["stiffness", "--preset", "spur-gds", "--tooth", "1", "--grid", "60x200", "--positions-per-cycle", "8"]
    assert main(common + ["--photo", str(tmp_path / "scene.png"), "--out", str(tmp_path / "a")]) == 2
    crop = f"30,{framed.shape[0] - 30},30,{framed.shape[1] - 30}"
    assert main(common + ["--photo", str(tmp_path / "scene.png"), "--photo-crop", crop, "--photo-rot90", "1",
                          "--out", str(tmp_path / "b")]) == 0
    assert main(common + ["--photo", str(tmp_path / "flank.png"), "--out", str(tmp_path / "c")]) == 0
    got = [json.loads((tmp_path / d / "summary.json").read_text()) for d in ("b", "c")]
    assert got[0]["severity_by_tooth"] == got[1]["severity_by_tooth"] and got[0]["severity_by_tooth"]
    assert got[0]["pits"]["extraction"]["crop"] == [30, framed.shape[0] - 30, 30, framed.shape[1] - 30]
    assert got[0]["pits"]["extraction"]["rot90"] == 1
    assert main(common[:1] + ["--preset", "spur-gds", "--photo-rot90", "1", "--out", str(tmp_path / "d")]) == 2


@pytest.mark.parametrize("kind", ["uniform", "noise", "dark", "checkerboard", "scene"])
def test_an_image_unlike_a_lit_flank_is_warned(kind):
    """Images that are no lit flank gave severity 0 without a word (an audit: uniform, noise, dark, a
    checkerboard; a flank on a dark background 0.12): now a PhotoWarning says why the mask means little. The
    rendered flank photos (two settings, pitted and not) get none."""
    from datagen.photo import PhotoWarning

    rng = np.random.default_rng(0)
    flank = render_flank_photo(truth_mask(2), 2, **SETTINGS["mild"])
    scene = np.full((PHOTO[0] * 3, PHOTO[1] * 2), 12, np.uint8)
    scene[PHOTO[0]:2 * PHOTO[0], PHOTO[1] // 2:PHOTO[1] // 2 + PHOTO[1]] = flank // 3
    image = {"uniform": np.full(PHOTO, 128, np.uint8),
             "noise": rng.integers(0, 256, PHOTO, dtype=np.uint8),
             "dark": (rng.random(PHOTO) * 20).astype(np.uint8),
             "checkerboard": np.kron((np.indices((24, 80)).sum(0) % 2 * 255).astype(np.uint8), np.ones((10, 10), np.uint8)),
             "scene": scene}[kind]
    with pytest.warns(PhotoWarning):
        mask_from_image(image, GRID, check_aspect=False)


@pytest.mark.parametrize("setting, seed", [("mild", 2), ("harsh", 3), ("mild", 5)])
def test_a_rendered_flank_photo_is_not_warned(setting, seed):
    import warnings

    from datagen.photo import PhotoWarning

    for truth in (truth_mask(seed), np.zeros(PHOTO, bool)):
        with warnings.catch_warnings():
            warnings.simplefilter("error", PhotoWarning)
            mask_from_image(render_flank_photo(truth, seed, **SETTINGS[setting]), GRID)
