"""`gearpit stiffness`: outputs, and bad input -> one line, exit 2, nothing written."""
import json

import numpy as np
import pytest

from gearpit.cli import main


def test_stiffness_writes_csv_png_json(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["stiffness", "--preset", "spur-gds", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    for key in ("mean_n_per_m", "min_n_per_m", "max_n_per_m", "mean_n_per_mm_um", "contact_ratio_transverse",
                "contact_ratio_overlap"):
        assert key in summary
    assert summary["min_n_per_m"] < summary["mean_n_per_m"] < summary["max_n_per_m"]
    data = np.loadtxt(out / "stiffness.csv", delimiter=",", skiprows=1)
    assert data.shape[0] == 29 * 64
    assert data[:, 2].mean() == pytest.approx(summary["mean_n_per_m"], rel=1e-6)
    assert (out / "stiffness.png").stat().st_size > 1000


def test_stiffness_with_procedural_pits(tmp_path, capsys):
    pits = tmp_path / "pits.toml"
    pits.write_text('[pits]\nshape = "ellipse"\nteeth = [2]\nseverity = 0.15\ndepth_mm = 0.2\n')
    out = tmp_path / "o"
    assert main(["stiffness", "--preset", "helical-dct", "--pits", str(pits), "--grid", "60x100",
                 "--out", str(out), "--json"]) == 0
    s = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert s["pitted_teeth"] == {"pinion": [2]}
    assert s["severity_by_tooth"]["2"] == pytest.approx(0.15, abs=0.01)


@pytest.mark.parametrize("files, args, field", [
    ({"pair.toml": "[pair\n"}, ["--pair", "{pair.toml}"], "file"),
    ({"pair.toml": '[pair]\npreset = "spur-gds"\nfoo = 1\n'}, ["--pair", "{pair.toml}"], "pair.foo"),
    ({"pair.toml": '[pair]\npreset = "spur-gds"\n[pair.pinion]\nteeth = 29\nface_width_mm = -3\n'},
     ["--pair", "{pair.toml}"], "pair.pinion.face_width_mm"),
    ({"m.png": None}, ["--mask", "{m.png}", "--grid", "50x60"], "shape"),
    ({"bad.png": b"not an image"}, ["--photo", "{bad.png}"], "bad.png"),
    ({}, ["--preset", "nope"], "preset"),
    ({}, ["--grid", "3x", "--photo", "x.png"], "--grid"),
])
def test_bad_input_one_line_exit_2_nothing_written(tmp_path, capsys, files, args, field):
    for name, content in files.items():
        p = tmp_path / name
        if content is None:  # a valid PNG of the wrong shape
            import cv2
            cv2.imwrite(str(p), np.zeros((10, 10), np.uint8))
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)
    out = tmp_path / "out"
    def fill(a):
        for k in files:
            a = a.replace("{" + k + "}", str(tmp_path / k))
        return a

    argv = ["stiffness", "--out", str(out)] + [fill(a) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert field in err
    assert not out.exists()


def _summary(out):
    return json.loads((out / "summary.json").read_text())


def test_pits_run_records_its_spec_and_map(tmp_path):
    """summary.json of a --pits run holds the TOML's [pits] table (shape, seed, severities, depth, teeth), the
    resolved spec, the file's SHA-256 and the pit map beside it (before: severity_by_tooth and pitted_teeth only)."""
    import hashlib

    from datagen.geometry import preset
    from datagen.pitio import load_npz
    from datagen.pits import PitSpec

    pits = tmp_path / "pits.toml"
    pits.write_text('[pits]\nshape = "cluster"\nteeth = [1, 3]\nseverity = [0.1, 0.2]\ndepth_mm = 0.3\nseed = 11\n')
    out = tmp_path / "o"
    assert main(["stiffness", "--pits", str(pits), "--grid", "30x60", "--positions-per-cycle", "8",
                 "--out", str(out)]) == 0
    rec = _summary(out)["pits"]
    assert rec["source"] == "pits" and rec["gear"] == "pinion" and rec["grid"] == "30x60"
    assert rec["table"] == {"shape": "cluster", "teeth": [1, 3], "severity": [0.1, 0.2], "depth_mm": 0.3, "seed": 11}
    assert rec["sha256"] == hashlib.sha256(pits.read_bytes()).hexdigest()
    assert rec["spec"]["seed"] == 11 and rec["spec"]["depth_m"] == pytest.approx(0.3e-3)
    # the run is reproducible from its outputs: the recorded table rebuilds the saved map bit for bit
    saved = load_npz(out / rec["pit_map_file"])
    rebuilt = PitSpec.from_dict(rec["table"]).build(preset("spur-gds").flank_grid("pinion", 30, 60), "pinion")
    assert sorted(saved.depth_m) == sorted(rebuilt.depth_m) == [1, 3]
    for t in (1, 3):
        assert saved.depth_m[t].tobytes() == rebuilt.depth_m[t].tobytes()


def test_photo_run_records_photo_hash_options_and_mask(tmp_path):
    """A --photo run records the photo's path and SHA-256, the extraction options it used and the extracted map
    (pits.npz), which the photo extraction with those options reproduces."""
    import hashlib

    import cv2

    from datagen.geometry import preset
    from datagen.photo import pit_map_from_image
    from datagen.pitio import load_npz

    img = np.full((120, 240), 200, np.uint8)
    cv2.ellipse(img, (120, 60), (30, 14), 0, 0, 360, 40, -1)
    photo = tmp_path / "flank.png"
    cv2.imwrite(str(photo), img)
    out = tmp_path / "o"
    assert main(["stiffness", "--photo", str(photo), "--tooth", "2", "--depth-mm", "0.15", "--grid", "30x60",
                 "--positions-per-cycle", "8", "--out", str(out)]) == 0
    s = _summary(out)
    rec = s["pits"]
    assert rec["source"] == "photo" and rec["file"] == str(photo) and rec["tooth"] == 2 and rec["depth_mm"] == 0.15
    assert rec["sha256"] == hashlib.sha256(photo.read_bytes()).hexdigest()
    assert {"crop", "rot90", "sigma_grid_px", "flatten"} <= set(rec["extraction"])
    saved = load_npz(out / rec["pit_map_file"])
    assert saved.pitted_teeth == [2] and s["pitted_teeth"] == {"pinion": [2]}
    again = pit_map_from_image(photo, preset("spur-gds").flank_grid("pinion", 30, 60), tooth=2, depth_m=0.15e-3,
                               **rec["extraction"])
    np.testing.assert_array_equal(saved.depth_m[2], again.depth_m[2])
