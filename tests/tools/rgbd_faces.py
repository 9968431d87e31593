"""Decodes the RGBD PNGs Babylon's parser sliced out of a .env file (tests/tools/env_check.mjs)
with Pillow, an independent PNG decoder, and Babylon's fromRGBD formula: linear = pow(rgb, 2.2)
/ a. Babylon uploads the images with Y inverted, so rows are flipped back to the OpenGL face
order. Writes <dir>/m<level>_f<face>.f32 (RGB float32 little-endian, row by row) beside each PNG.

    python3 rgbd_faces.py <dir> <levels>
"""
import struct
import sys

from PIL import Image

folder, levels = sys.argv[1], int(sys.argv[2])
for level in range(levels):
    for face in range(6):
        name = f"{folder}/m{level}_f{face}"
        img = Image.open(name + ".png")
        if img.mode != "RGBA":
            sys.exit(f"{name}.png is {img.mode}, not RGBA")
        img = img.transpose(Image.Transpose.FLIP_TOP_BOTTOM)
        out = bytearray()
        for r, g, b, a in img.getdata():
            a = max(a, 1) / 255.0
            out += struct.pack("<3f", *(((v / 255.0) ** 2.2) / a for v in (r, g, b)))
        with open(name + ".f32", "wb") as f:
            f.write(out)
print("decoded", levels * 6, "faces")
