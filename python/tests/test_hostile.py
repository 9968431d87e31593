"""Hostile calls: odd arrays, huge sizes, paths that are folders or FIFOs. Each raises a
cubeforge exception with a clear message (or works); none may take the interpreter down.
The crashes among them were found by a sweep of such calls (the hostile branch)."""

import os
import struct

import numpy as np
import pytest

import cubeforge
from conftest import REPO

SKY = str(REPO / "fixtures" / "sky.exr")


def test_huge_outputs_are_refused_not_aborted():
    """e2c(face_w=10**6) and e2p(out_hw=(10**6, 10**6)) aborted the interpreter when their
    output could not be allocated; sizes whose count overflows wrapped."""
    pano = np.zeros((8, 16, 3), np.float32)
    for call in (
        lambda: cubeforge.e2c(pano, face_w=10**6),
        lambda: cubeforge.e2c(pano, face_w=2**62, cube_format="dice"),
        lambda: cubeforge.e2p(pano, 90, 0, 0, (10**6, 10**6)),
        lambda: cubeforge.e2p(pano, 90, 0, 0, (2**40, 2**40)),
        lambda: cubeforge.c2e(np.zeros((4, 24, 3), np.float32), h=2**40, w=2**41, cube_format="horizon"),
    ):
        with pytest.raises(cubeforge.ArgumentError, match="memory budget"):
            call()


def test_negative_and_enormous_sizes_are_argument_errors():
    """They were OverflowErrors of the conversion to an unsigned size, naming nothing."""
    pano = np.zeros((8, 16, 3), np.float32)
    for call, name in (
        (lambda: cubeforge.e2c(pano, face_w=-5), "face_w"),
        (lambda: cubeforge.e2c(pano, face_w=2**64), "face_w"),
        (lambda: cubeforge.e2p(pano, 90, 0, 0, (-1, 4)), "out_hw"),
        (lambda: cubeforge.c2e(np.zeros((4, 24, 3), np.float32), h=-8, w=16, cube_format="horizon"), "h="),
        (lambda: cubeforge.convert(pano, to="faces", size=-1), "size"),
        (lambda: cubeforge.convert(pano, to="faces", size=2**64), "size"),
    ):
        with pytest.raises(cubeforge.ArgumentError, match=name):
            call()


def test_non_finite_view_angles_are_refused():
    pano = np.ones((8, 16, 3), np.float32)
    for fov, u, v in ((90, float("inf"), 0), (float("nan"), 0, 0), (90, 0, float("-inf"))):
        with pytest.raises(cubeforge.ArgumentError, match="finite"):
            cubeforge.e2p(pano, fov, u, v, (4, 4))


def test_non_finite_arrays_are_refused_by_convert_and_replaced_by_write(tmp_path):
    """convert() of an array carried NaN and infinities into its output; write() replaces
    them (and negatives) as a file's are when it is read, with the same one warning, and
    writes finite values. NaN was written as 0 without the warning."""
    for value in (np.nan, np.inf, -np.inf, -2.0):
        bad = np.ones((8, 16, 4), np.float32)
        bad[3, 5, 1] = value
        if not np.isfinite(value):
            with pytest.raises(cubeforge.ArgumentError, match="NaN or infinite"):
                cubeforge.convert(bad, to="faces", size=4)
        report = cubeforge.write(tmp_path / "p.exr", bad)
        replaced = [w for w in report["warnings"] if "replaced" in w]
        assert replaced == ["array: replaced 1 NaN, infinite or negative values by 0 "
                            "(and values above 1e28 by 1e28)"], report
        stats = cubeforge.info(tmp_path / "p.exr")["stats"]
        assert stats["nan"] == 0 and stats["inf"] == 0, stats


def test_odd_arrays_are_converted_or_refused():
    """Other dtypes, strides and layouts are converted to float32 RGBA; shapes that are no
    image, empty sides and strings are refused with the shape or the value."""
    base = np.linspace(0, 1, 16 * 32 * 4, dtype=np.float64).reshape(16, 32, 4)
    for arr in (
        base.astype(np.uint8),
        base.astype(np.float16),
        base[::2, ::2],
        base[::-1],
        np.asfortranarray(base),
        np.broadcast_to(np.float32(1), (8, 16, 4)),
    ):
        faces = cubeforge.convert(arr, to="faces", size=4)
        assert faces.shape == (6, 4, 4, 4) and np.isfinite(faces).all()
    for shape in ((0, 0, 4), (8, 0, 4), (8, 16, 0), (16,), (5, 4, 4, 4), (6, 4, 5, 4)):
        with pytest.raises(cubeforge.ArgumentError, match="shape"):
            cubeforge.convert(np.zeros(shape, np.float32), to="faces", size=4)
    with pytest.raises(ValueError):
        cubeforge.convert(np.array([["a"] * 16] * 8), to="faces", size=4)
    with pytest.raises(cubeforge.ArgumentError, match="1 to 16384"):
        cubeforge.convert(np.zeros((8, 16, 4), np.float32), to="faces", size=2**40)


def test_folders_fifos_and_claimed_sizes_are_file_errors(tmp_path):
    fifo = tmp_path / "pipe.exr"
    os.mkfifo(fifo)
    for call in (
        lambda: cubeforge.read(fifo),
        lambda: cubeforge.info(fifo),
        lambda: cubeforge.ibl(fifo, tmp_path / "out", "bevy"),
        lambda: cubeforge.read(tmp_path),
    ):
        with pytest.raises(cubeforge.FileError, match=str(tmp_path)):
            call()
    with pytest.raises(cubeforge.FileError, match="pipe.exr"):
        cubeforge.write(fifo, np.zeros((8, 16, 4), np.float32))
    # The demo sky's header claiming 16384 x 8192 over its 512 x 256 body: read and info
    # (streamed) say the file and what is missing.
    b = open(SKY, "rb").read()
    for name in (b"dataWindow", b"displayWindow"):
        at = b.index(name + b"\0box2i\0") + len(name) + len(b"\0box2i\0") + 4
        b = b[:at] + struct.pack("<4i", 0, 0, 16383, 8191) + b[at + 16:]
    claims = tmp_path / "claims.exr"
    claims.write_bytes(b)
    for call in (lambda: cubeforge.read(claims), lambda: cubeforge.info(claims)):
        with pytest.raises(cubeforge.FileError, match="claims.exr"):
            call()
