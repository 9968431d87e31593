"""Arrays in and out: read any input to float32 RGBA, write an array as the CLI writes files,
convert an array between layouts in memory."""

import numpy as np
import pytest

import cubeforge
from conftest import REPO, psnr

SKY = str(REPO / "fixtures" / "sky.exr")


def test_read_a_panorama_and_its_metadata():
    img = cubeforge.read(SKY)
    assert img.dtype == np.float32 and img.ndim == 3 and img.shape[2] == 4
    assert img.shape[1] == 2 * img.shape[0]
    meta = cubeforge.read(SKY, meta=True)
    assert meta["layout"] == "equirect" and meta["file_format"] == "exr"
    assert np.array_equal(meta["image"], img)


def test_write_then_read_every_level(tmp_path):
    faces = cubeforge.convert(cubeforge.read(SKY), to="faces", size=16)
    assert faces.shape == (6, 16, 16, 4)
    out = tmp_path / "sky.ktx2"
    report = cubeforge.write(out, faces, gpu_format="rgba32f", levels=5)
    assert report["written"] == [str(out)]
    back = cubeforge.read(out, meta=True)
    assert back["kind"] == "ktx2" and len(back["levels"]) == 5
    assert np.allclose(back["levels"][0], faces)


def test_write_an_rgb_panorama_as_png_and_exr(tmp_path):
    rgb = np.linspace(0, 1, 32 * 16 * 3, dtype=np.float32).reshape(16, 32, 3)
    cubeforge.write(tmp_path / "p.exr", rgb, exr_float="f32")
    back = cubeforge.read(tmp_path / "p.exr")
    assert np.allclose(back[..., :3], rgb) and np.all(back[..., 3] == 1)
    cubeforge.write(tmp_path / "p.png", rgb)
    assert psnr(rgb, cubeforge.read(tmp_path / "p.png")[..., :3]) > 40


def test_convert_round_trip_in_memory():
    pano = cubeforge.read(SKY)
    faces = cubeforge.convert(pano, to="faces", size=64)
    cross = cubeforge.convert(faces, to="hcross", size=64)
    assert cross.shape == (3 * 64, 4 * 64, 4)
    back = cubeforge.convert(cross, to="equirect", size=pano.shape[1] // 4)
    assert back.shape == pano.shape
    assert psnr(pano, back) > 30


def test_bad_arrays_are_value_errors():
    with pytest.raises(ValueError):
        cubeforge.convert(np.zeros((4, 4, 2), np.float32), to="faces", size=4)
    with pytest.raises(ValueError):
        cubeforge.convert(np.zeros((8, 16, 3), np.float32), to="nowhere", size=4)
