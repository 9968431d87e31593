"""cubeforge: turn photographs into cube maps, from Python.

Arrays in and out (numpy, float32 RGBA): :func:`read`, :func:`write`, :func:`convert` of an
array. The command line's jobs, with keyword arguments named as its flags (``--min-size`` is
``min_size=``, ``--from`` is ``from_=``; a flag without a value takes ``True``): :func:`ibl`,
:func:`prefilter`, :func:`irradiance`, :func:`convert`, :func:`control`, :func:`preview`,
:func:`lut`, :func:`info`, :func:`batch`. Each job returns its report as a dict (``written``,
``warnings``, ``summary``, ``quality``; :func:`batch` adds each job's outcome and the
counts) and writes what the CLI writes, byte for byte.

A drop-in for py360convert: :func:`e2c`, :func:`c2e` and :func:`e2p`, with its arguments,
defaults, result shapes and face orientations (``import cubeforge as py360convert``).

Errors are :class:`Error`: :class:`ArgumentError` (also a ``ValueError``) for bad arguments,
:class:`FileError` (also an ``OSError``) for files, with the command line's one-line message.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from typing import Any, Callable, Dict, List, Optional, Sequence, Union

import numpy as np

from . import _cubeforge
from ._errors import ArgumentError, Error, FileError
from ._py360 import c2e, e2c, e2p

__all__ = [
    "Error",
    "ArgumentError",
    "FileError",
    "read",
    "write",
    "convert",
    "ibl",
    "prefilter",
    "irradiance",
    "control",
    "preview",
    "lut",
    "info",
    "batch",
    "e2c",
    "c2e",
    "e2p",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Callable[[int, int, str], Any]


def _flags(options: Dict[str, Any]) -> List[str]:
    """Keyword arguments as the command line's flags: ``min_size=16`` is ``--min-size=16``,
    ``sheen=True`` is ``--sheen``, ``False`` and ``None`` leave the flag out, a list or tuple
    is given comma-separated (``grid_bias=[0, 1]`` is ``--grid-bias=0,1``)."""
    argv = []
    for key, value in options.items():
        flag = "--" + key.rstrip("_").replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            argv.append(flag)
        elif isinstance(value, (list, tuple)):
            argv.append(flag + "=" + ",".join(str(v) for v in value))
        else:
            argv.append(flag + "=" + (os.fspath(value) if isinstance(value, os.PathLike) else str(value)))
    return argv


def _paths(inputs: Union[PathLike, Sequence[PathLike]]) -> List[str]:
    if isinstance(inputs, (str, os.PathLike)):
        return [os.fspath(inputs)]
    return [os.fspath(p) for p in inputs]


def _job(words: List[str], options: Dict[str, Any], progress: Optional[Progress]) -> Dict[str, Any]:
    return _cubeforge.run_job(words + _flags(options), progress)


def read(path: Union[PathLike, Sequence[PathLike]], *, meta: bool = False, level: int = 0, **options: Any) -> Any:
    """Reads anything ``cubeforge convert`` reads: a panorama, a cross or strip, six faces (a
    folder or six files), a KTX2/DDS/KTX/.env cube map with its levels, a part of an EXR.

    Returns a float32 array of linear RGBA: ``(height, width, 4)`` for a single image, or
    ``(6, size, size, 4)`` for a cube map (faces px nx py ny pz nz) at mip ``level``. With
    ``meta=True``, a dict: ``image`` or ``levels`` (every level's faces), ``kind``,
    ``layout``, ``file_format``, ``pixel_format``, ``hdr``, ``stored_levels``, ``part``, ...

    Options are the input flags of the CLI: ``from_``, ``linear``, ``part``, ``decode``,
    ``max_pixels``, ``max_memory``.
    """
    got = _cubeforge.read(_paths(path) + _flags(options))
    if meta:
        return got
    if "image" in got:
        return got["image"]
    levels = got["levels"]
    if not 0 <= level < len(levels):
        raise ArgumentError(f"level={level}: the map has {len(levels)} levels")
    return levels[level]


def write(path: PathLike, array: np.ndarray, *, from_: Optional[str] = None,
          progress: Optional[Progress] = None, **options: Any) -> Dict[str, Any]:
    """Writes an array as ``cubeforge convert`` writes a file: any layout or container the
    name or ``to`` asks for, with the CLI's output flags as keyword arguments (``to``,
    ``size``, ``gpu_format``, ``zstd``, ``exr_float``, ``png16``, ``tonemap``, ...).

    ``array`` is ``(height, width[, channels])`` (a panorama, cross, strip, ball...: its
    layout from its aspect ratio, or ``from_``) or ``(6, size, size, channels)`` (faces px nx
    py ny pz nz), of 1, 3 or 4 linear channels. Returns the job's report.
    """
    array = np.ascontiguousarray(array, dtype=np.float32)
    tmp = tempfile.mkdtemp(prefix="cubeforge-")
    try:
        src = os.path.join(tmp, "faces" if array.ndim == 4 else "input.exr")
        # The array's NaN, infinite and negative values replaced as a file's, with its warning.
        replaced = _cubeforge.write_exr(src, array)
        words = ["convert", src, "-o", os.fspath(path)]
        if array.ndim != 4:
            layout = from_ or _cubeforge.detect_layout(array.shape[1], array.shape[0])
            # The array's own layout unless `to` says otherwise (the CLI's convert would
            # make faces of a panorama written to an .exr).
            options = dict(options, from_=layout)
            if options.get("to") is None and layout is not None and array.ndim != 4:
                options["to"] = layout
        report = _job(words, options, progress)
        if replaced:
            report["warnings"].insert(0, replaced)
        return report
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def convert(input: Any, output: Optional[PathLike] = None, *, to: Optional[str] = None,
            size: Optional[int] = None, progress: Optional[Progress] = None, **options: Any) -> Any:
    """Converts a map between layouts.

    An array in (``(h, w[, c])`` or ``(6, n, n, c)``): the array out, in layout ``to`` at face
    edge ``size`` (faces: ``(6, size, size, 4)``; ``from_`` names a square input's layout).

    Files in (a path, or several): ``cubeforge convert INPUT -o OUTPUT`` with the flags as
    keyword arguments; returns the report.
    """
    if isinstance(input, np.ndarray):
        array = np.ascontiguousarray(input, dtype=np.float32)
        if size is None:
            size = array.shape[1] if array.ndim == 4 else max(1, array.shape[1] // 4)
        if not 1 <= int(size) <= 16384:
            raise ArgumentError(f"size={size}: 1 to 16384")
        return _cubeforge.convert_array(array, to or "equirect", int(size), options.get("from_"))
    if output is None:
        raise ArgumentError("convert: give output= (the CLI's -o)")
    return _job(["convert", *_paths(input), "-o", os.fspath(output)], dict(options, to=to, size=size), progress)


def prefilter(input: Union[PathLike, Sequence[PathLike]], output: PathLike, *,
              progress: Optional[Progress] = None, **options: Any) -> Dict[str, Any]:
    """``cubeforge prefilter``: a prefiltered mip chain (``filter``, ``size``, ``samples``,
    ``roughness``, ...). Returns the report."""
    return _job(["prefilter", *_paths(input), "-o", os.fspath(output)], options, progress)


def irradiance(input: Union[PathLike, Sequence[PathLike]], output: PathLike, *,
               progress: Optional[Progress] = None, **options: Any) -> Dict[str, Any]:
    """``cubeforge irradiance``: a Lambertian irradiance map and its SH (``size``, ``sh``,
    ``method``, ...). Returns the report."""
    return _job(["irradiance", *_paths(input), "-o", os.fspath(output)], options, progress)


def ibl(input: Union[PathLike, Sequence[PathLike]], out_dir: PathLike, target: str, *,
        progress: Optional[Progress] = None, **options: Any) -> Dict[str, Any]:
    """``cubeforge ibl INPUT -o OUT_DIR --target TARGET``: the files an engine loads (bevy,
    gltf, babylon, filament, godot, unity, unreal, three, generic), the same bytes as the
    CLI. Options: ``name``, ``size``, ``min_size``, ``diffuse_size``, ``samples``,
    ``gpu_format``, ``zstd``, ``yaw``, ``sheen``, ``exposure``, ``exr_float``, ...
    Returns the report (``summary`` ends with the engine's loading code)."""
    return _job(["ibl", *_paths(input), "-o", os.fspath(out_dir), "--target", target], options, progress)


def lut(output: PathLike, *, progress: Optional[Progress] = None, **options: Any) -> Dict[str, Any]:
    """``cubeforge lut -o OUTPUT``: a BRDF lookup table (``kind``, ``size``, ...)."""
    return _job(["lut", "-o", os.fspath(output)], options, progress)


def control(recipe: PathLike, output: PathLike, *, progress: Optional[Progress] = None,
            **options: Any) -> Dict[str, Any]:
    """``cubeforge control RECIPE -o OUTPUT``: a control map baked from a recipe."""
    return _job(["control", os.fspath(recipe), "-o", os.fspath(output)], options, progress)


def preview(input: PathLike, output: Optional[PathLike] = None, *, progress: Optional[Progress] = None,
            **options: Any) -> tuple:
    """``cubeforge preview INPUT -o OUTPUT``: a sphere lit by the map (``material``, ``size``,
    ``fov``, ...). Returns ``(report, image)``: the image as read back from the file written
    (without ``output``, a linear EXR in a temporary folder, removed after)."""
    tmp = None
    if output is None:
        tmp = tempfile.mkdtemp(prefix="cubeforge-")
        output = os.path.join(tmp, "preview.exr")
    try:
        report = _job(["preview", os.fspath(input), "-o", os.fspath(output)], options, progress)
        return report, _cubeforge.read_image(os.fspath(output))
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def info(path: PathLike, **options: Any) -> Dict[str, Any]:
    """``cubeforge info PATH --json`` as a dict: layout, sizes, levels, pixel format, colour
    space, statistics, flux. Options: ``from_``, ``linear``, ``part``, ``decode``, ..."""
    import json

    return json.loads(_cubeforge.info(["info", os.fspath(path)] + _flags(options)))


def batch(manifest: PathLike, *, progress: Optional[Progress] = None, **options: Any) -> Dict[str, Any]:
    """``cubeforge batch MANIFEST``: a manifest's jobs, run as the CLI runs them (incremental
    through its state file, a cache, shards), silently. Options: ``dry_run``, ``force``,
    ``shard``, ``depfiles``, ``emit``, ``max_memory``, ``cache``, ``cache_read_only``.
    ``progress(done, total, label)`` hears the jobs ended of those planned (label: the last
    one's command line). The working folder is restored after.

    Returns the report as a dict: ``jobs`` (each ``id``, ``outcome`` — 'ran', 'up to date',
    'from cache', 'would run', 'would fetch' or 'failed' —, ``why``, ``seconds``, ``error``),
    the counts ``ran``, ``up_to_date``, ``failed``, ``from_cache``, ``would_run``,
    ``would_fetch``, ``other_shards``, and ``written`` (absolute paths), ``warnings``,
    ``summary`` (the CLI's summary lines), ``failures``. A failed job raises
    :class:`ArgumentError` ("N of M jobs failed: ..."), the dict as its ``report``.
    """
    here = os.getcwd()
    try:
        return _cubeforge.batch(["batch", os.fspath(manifest)] + _flags(options), progress)
    finally:
        os.chdir(here)
