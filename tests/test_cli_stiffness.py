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
