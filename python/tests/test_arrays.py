"""Arrays in and out: read any input to float32 RGBA, write an array as the CLI writes files,
convert an array between layouts in memory."""

import numpy as np
import pytest

import cubeforge
from conftest import REPO, psnr, ticks_during

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


def _owner(a):
    """The object that owns an array's memory: the end of its chain of bases."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a.base


def test_outputs_are_handed_over_without_a_copy():
    """Every array cubeforge returns is a view of the memory Rust filled (its owner a Rust
    object, never a numpy copy); an image read or converted is the library's own texels."""
    pano = cubeforge.read(SKY)
    arrays = {
        "read": pano,
        "read meta": cubeforge.read(SKY, meta=True)["image"],
        "convert image": cubeforge.convert(pano, to="equirect", size=32),
        "convert faces": cubeforge.convert(pano, to="faces", size=16),
        "e2c dice": cubeforge.e2c(pano, 16),
        "e2c horizon": cubeforge.e2c(pano, 16, cube_format="horizon"),
        "e2c list": cubeforge.e2c(pano, 16, cube_format="list")[0],
        "c2e": cubeforge.c2e(cubeforge.e2c(pano, 16), 32, 64),
        "e2p": cubeforge.e2p(pano, 90, 10, 20, (16, 24)),
    }
    for name, a in arrays.items():
        assert a.dtype == np.float32, name
        owner = _owner(a)
        assert owner is not None and not isinstance(owner, np.ndarray), (name, type(owner))
    assert type(_owner(pano)).__name__ == "Texels"
    pano[0, 0] = 7  # numpy's to write: the texels are the array's own
    assert np.all(pano[0, 0] == 7)


def test_float32_c_contiguous_inputs_are_not_copied():
    """A float32 C-contiguous array is read in place (numpy allocates nothing the size of it,
    as tracemalloc sees numpy's allocations); any other type is converted once."""
    import tracemalloc

    big = np.ones((1024, 2048, 3), np.float32)  # 24 MiB
    horizon = np.ones((512, 6 * 512, 3), np.float32)  # 18 MiB
    calls = [
        (lambda a: cubeforge.e2c(a, 8), big),
        (lambda a: cubeforge.e2p(a, 60, 0, 0, (8, 8)), big),
        # c2e reads the six faces where they lie in the horizon (no stack of them).
        (lambda a: cubeforge.c2e(a, 8, 16, cube_format="horizon"), horizon),
    ]
    for call, array in calls:
        for given, copied in [(array, False), (array.astype(np.float64), True)]:
            tracemalloc.start()
            call(given)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            if copied:
                assert peak >= array.nbytes, peak  # the test sees a copy
            else:
                assert peak < array.nbytes // 8, peak


def test_array_calls_release_the_gil():
    """Another Python thread runs while e2c, c2e and e2p work (each some tens of ms)."""
    pano = np.ones((1024, 2048, 3), np.float32)
    faces = cubeforge.e2c(pano, 256, cube_format="horizon")
    calls = [
        lambda: cubeforge.e2c(pano, 512),
        lambda: cubeforge.c2e(faces, 1024, 2048, cube_format="horizon"),
        lambda: cubeforge.e2p(pano, 90, 0, 0, (1024, 1024)),
    ]
    for call in calls:
        assert ticks_during(call) > 0
