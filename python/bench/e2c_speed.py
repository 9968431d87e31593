"""cubeforge.e2c, c2e and e2p beside py360convert's, in one process (BENCHMARKS.md's Python
section).

    python python/bench/e2c_speed.py [PANORAMA] [RUNS]

A 4096 x 2048 RGB float32 panorama (PANORAMA, default ../shared/fixtures/real/hdr/esplanade.hdr,
resampled to that size by cubeforge) to six 1024 faces (dice), and those faces back to a
4096 x 2048 panorama, and a 1024 x 1024 view of 90 degrees (u 40, v 10); best of RUNS
(default 3) for each, the two libraries alternating, and
the PSNR of cubeforge's result against py360convert's (on v/(1+v), peak 1).
"""

import os
import pathlib
import sys
import time

import numpy as np
import py360convert

import cubeforge

REPO = pathlib.Path(__file__).resolve().parents[2]
path = sys.argv[1] if len(sys.argv) > 1 and sys.argv[1] else REPO.parent / "shared/fixtures/real/hdr/esplanade.hdr"
runs = int(sys.argv[2]) if len(sys.argv) > 2 else 3
if not pathlib.Path(path).exists():
    path = REPO / "fixtures" / "sky.exr"   # the bundled sky where the real ones are absent
pano = cubeforge.convert(cubeforge.read(path), to="equirect", size=1024)[..., :3].copy()
assert pano.shape == (2048, 4096, 3)


def best(f):
    """Best wall time of RUNS, and the CPU time of that run (all threads)."""
    times = []
    for _ in range(runs):
        t, c = time.perf_counter(), time.process_time()
        out = f()
        times.append((time.perf_counter() - t, time.process_time() - c))
    return min(times), out


def psnr(a, b):
    a, b = a / (1 + np.abs(a)), b / (1 + np.abs(b))
    return 10 * np.log10(1 / np.mean((a.astype(np.float64) - b) ** 2))


print(f"{os.path.basename(str(path))} as 4096 x 2048 RGB float32; best of {runs}; "
      f"{os.cpu_count()} CPUs, RAYON_NUM_THREADS={os.environ.get('RAYON_NUM_THREADS', 'all')}")
cubeforge.e2c(pano, 64)  # first call's one-time costs (thread pool) out of the timing


def line(name, py, cf, db):
    (w_py, c_py), (w_cf, c_cf) = py, cf
    print(f"{name}: py360convert {w_py:.3f} s (CPU {c_py:.3f}), cubeforge {w_cf:.3f} s "
          f"(CPU {c_cf:.3f}): {w_py / w_cf:.1f}x wall, {c_py / c_cf:.1f}x CPU, {db:.1f} dB")


t_py, faces_py = best(lambda: py360convert.e2c(pano, face_w=1024))
t_cf, faces_cf = best(lambda: cubeforge.e2c(pano, face_w=1024))
line("e2c 1024 faces", t_py, t_cf, psnr(faces_py, faces_cf))
t_py, back_py = best(lambda: py360convert.c2e(faces_py, 2048, 4096))
t_cf, back_cf = best(lambda: cubeforge.c2e(faces_py, 2048, 4096))
line("c2e 4096 x 2048", t_py, t_cf, psnr(back_py, back_cf))
view = (90, 40, 10, (1024, 1024))
t_py, pers_py = best(lambda: py360convert.e2p(pano, *view))
t_cf, pers_cf = best(lambda: cubeforge.e2p(pano, *view))
line("e2p 1024 x 1024, 90 degrees", t_py, t_cf, psnr(pers_py, pers_cf))
