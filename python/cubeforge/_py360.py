"""py360convert's ``e2c``, ``c2e`` and ``e2p``, computed by cubeforge: its arguments, defaults, result
shapes, face keys (F R B L U D) and face orientations, texel for texel (its face grids run
edge to edge, its padding and face masks are its own), in parallel and without the GIL.

py360convert's faces against cubeforge's (``read``/``convert`` give px nx py ny pz nz): F is
+Z (cubeforge's pz), R is +X (px), B is -Z (nz), L is -X (nx), U is +Y (py), D is -Y (ny),
each face the right way up as cubeforge lays it out (the OpenGL cube-map convention); the
texel grids differ by py360convert's edge-to-edge sampling (half a texel at the borders).
"""

from __future__ import annotations

from numbers import Real
from typing import Dict, List, Sequence, Tuple, Union

import numpy as np

from . import _cubeforge
from ._errors import ArgumentError

_NEAREST = {"nearest"}
_BILINEAR = {"linear", "bilinear"}
_KEYS = "FRBLUD"
# Dice cells (column, row) of F R B L U D, as py360convert's cube_h2dice.
_DICE = [(1, 1), (2, 1), (3, 1), (0, 1), (1, 0), (1, 2)]


def _nearest(mode: str) -> bool:
    m = str(mode).lower()
    if m in _NEAREST:
        return True
    if m in _BILINEAR:
        return False
    raise ArgumentError(f"mode={mode!r}: cubeforge's e2c, c2e and e2p take 'bilinear' or 'nearest'")


def _texels(name: str, value) -> int:
    """A size in texels: a positive integer that fits 63 bits (a negative or enormous one
    is an ArgumentError naming it, not an OverflowError from the conversion)."""
    n = int(value)
    if not 1 <= n < 2**63:
        raise ArgumentError(f"{name}={value!r}: a positive number of texels")
    return n


def _as_float(img: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(img, dtype=np.float32)


def _back(out: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The result in the input's type, as py360convert keeps it (integers rounded, clipped)."""
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        return np.clip(np.rint(out), info.min, info.max).astype(dtype)
    return out.astype(dtype, copy=False)


def e2c(e_img: np.ndarray, face_w: int = 256, mode: str = "bilinear",
        cube_format: str = "dice") -> Union[np.ndarray, List[np.ndarray], Dict[str, np.ndarray]]:
    """Convert an equirectangular image to a cube map, as ``py360convert.e2c``.

    Parameters: ``e_img`` of shape [H, W] or [H, W, *]; ``face_w`` the face edge; ``mode``
    'bilinear' or 'nearest'; ``cube_format`` 'dice' (3 face_w x 4 face_w), 'horizon'
    (face_w x 6 face_w, F R B L U D), 'list' (six faces) or 'dict' (keys F R B L U D).
    """
    e_img = np.asarray(e_img)
    if e_img.ndim not in (2, 3):
        raise ValueError("e_img must have 2 or 3 dimensions.")
    squeeze = e_img.ndim == 2
    src = e_img[..., None] if squeeze else e_img
    w = _texels("face_w", face_w)
    if cube_format == "dice":
        # Laid out as a dice by cubeforge itself: no row of faces copied into it after.
        dice = _back(_cubeforge.e2c_faces(_as_float(src), w, _nearest(mode), True), e_img.dtype)
        return dice[..., 0] if squeeze else dice
    horizon = _cubeforge.e2c_faces(_as_float(src), w, _nearest(mode), False)
    horizon = _back(horizon, e_img.dtype)
    faces = [horizon[:, i * w:(i + 1) * w] for i in range(6)]
    if squeeze:
        faces = [f[..., 0] for f in faces]
        horizon = horizon[..., 0]
    if cube_format == "horizon":
        return horizon
    if cube_format == "list":
        return faces
    if cube_format == "dict":
        return dict(zip(_KEYS, faces))
    raise NotImplementedError


def _faces_of(cubemap, cube_format: str) -> List[np.ndarray]:
    if cube_format == "horizon":
        if not isinstance(cubemap, np.ndarray):
            raise TypeError('cubemap must be a numpy array for cube_format="horizon"')
        if cubemap.shape[0] * 6 != cubemap.shape[1]:
            raise ValueError("Cubemap's width must by 6x its height.")
        w = cubemap.shape[0]
        return [cubemap[:, i * w:(i + 1) * w] for i in range(6)]
    if cube_format == "list":
        if not isinstance(cubemap, list):
            raise TypeError('cubemap must be a list for cube_format="list"')
        if len({x.shape for x in cubemap}) != 1:
            raise ValueError("All cubemap elements must have same shape")
        return list(cubemap)
    if cube_format == "dict":
        if not isinstance(cubemap, dict):
            raise TypeError('cubemap must be a dict for cube_format="dict"')
        if len({x.shape for x in cubemap.values()}) != 1:
            raise ValueError("All cubemap elements must have same shape")
        return [cubemap[k] for k in _KEYS]
    if cube_format == "dice":
        if not isinstance(cubemap, np.ndarray):
            raise TypeError('cubemap must be a numpy array for cube_format="dice"')
        if cubemap.shape[0] % 3 != 0:
            raise ValueError("Dice image height must be a multiple of 3.")
        w = cubemap.shape[0] // 3
        if cubemap.shape[1] != w * 4:
            raise ValueError(f'Dice width must be 4 "faces" (4x{w}={4 * w}) wide.')
        return [cubemap[sy * w:(sy + 1) * w, sx * w:(sx + 1) * w] for sx, sy in _DICE]
    raise ValueError(f'Unknown cube_format "{cube_format}".')


def c2e(cubemap, h: int, w: int, mode: str = "bilinear", cube_format: str = "dice") -> np.ndarray:
    """Convert a cube map to an equirectangular image, as ``py360convert.c2e``.

    Parameters: ``cubemap`` in ``cube_format`` ('dice', 'horizon', 'list' or 'dict', as
    :func:`e2c` returns them); ``h`` and ``w`` the panorama's size (``w`` a multiple of 8);
    ``mode`` 'bilinear' or 'nearest'.
    """
    nearest = _nearest(mode)
    if w % 8 != 0:
        raise ValueError("w must be a multiple of 8.")
    faces = _faces_of(cubemap, cube_format)
    dtype = faces[0].dtype
    squeeze = faces[0].ndim == 2
    if faces[0].shape[0] != faces[0].shape[1]:
        raise ValueError("Cubemap faces must be square.")
    # Each face as it lies (a dice's cell, a horizon's slice): float32 ones are not copied.
    faces = [np.asarray(f[..., None] if squeeze else f, dtype=np.float32) for f in faces]
    out = _cubeforge.c2e_faces(faces, _texels("h", h), _texels("w", w), nearest)
    out = _back(out, dtype)
    return out[..., 0] if squeeze else out


def e2p(e_img: np.ndarray, fov_deg: Union[float, Tuple[float, float]], u_deg: float, v_deg: float,
        out_hw: Sequence[int], in_rot_deg: float = 0, mode: str = "bilinear") -> np.ndarray:
    """Convert an equirectangular image to a perspective view, as ``py360convert.e2p``.

    Parameters: ``e_img`` of shape [H, W] or [H, W, *]; ``fov_deg`` the field of view in
    degrees, one for both or (horizontal, vertical); ``u_deg`` the view's longitude (- left,
    + right), ``v_deg`` its latitude (- down, + up); ``out_hw`` the view's (height, width);
    ``in_rot_deg`` a turn about the view axis; ``mode`` 'bilinear' or 'nearest'. Returns
    (out_h, out_w[, *]) in the input's type.
    """
    e_img = np.asarray(e_img)
    if e_img.ndim not in (2, 3):
        raise ValueError("e_img must have 2 or 3 dimensions.")
    squeeze = e_img.ndim == 2
    src = e_img[..., None] if squeeze else e_img
    # py360convert's own conversions: radians through numpy, u negated.
    if isinstance(fov_deg, Real):
        h_fov = v_fov = float(np.deg2rad(float(fov_deg)))
    else:
        h_fov, v_fov = float(np.deg2rad(fov_deg[0])), float(np.deg2rad(fov_deg[1]))
    u = -float(np.deg2rad(u_deg))
    v = float(np.deg2rad(v_deg))
    in_rot = float(np.deg2rad(in_rot_deg))
    out = _cubeforge.e2p_view(_as_float(src), h_fov, v_fov, u, v, in_rot,
                              _texels("out_hw[0]", out_hw[0]), _texels("out_hw[1]", out_hw[1]),
                              _nearest(mode))
    out = _back(out, e_img.dtype)
    return out[..., 0] if squeeze else out
