"""Times the same commands with two builds, alternating, best of N, at the current thread count.

Put the two binaries in BINS (default benchbin/) as cubeforge-before and cubeforge-after, then
`RAYON_NUM_THREADS=2 python3 tests/tools/compare_builds.py` (RUNS=N, ONLY=substring of a job).
"""
import os, subprocess, sys, tempfile, time
b = os.environ.get("BINS", "benchbin"); n = int(os.environ.get("RUNS", "5")); w = tempfile.mkdtemp()
run = lambda v, args: subprocess.run([f"{b}/cubeforge-{v}", "--quiet"] + args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
run("after", f"convert fixtures/sky.exr -o {w}/pano.hdr --to equirect --size 1024".split())
run("after", f"convert fixtures/sky.exr -o {w}/pano.exr --to equirect --size 1024".split())
jobs = [
    "convert W/pano.hdr -o W/faces --to faces --size 1024",
    "convert W/pano.exr -o W/sky.ktx2 --size 1024",
    "convert W/pano.hdr -o W/octa.exr --to octahedral --size 1024",
    "prefilter W/pano.hdr -o W/ggx.ktx2 --filter ggx --size 256",
    "prefilter W/pano.hdr -o W/cos.ktx2 --filter cosine --size 256",
    "irradiance W/pano.hdr -o W/irr.ktx2 --size 32",
    "ibl W/pano.hdr -o W/bevy --target bevy --size 256",
    "preview W/pano.hdr -o W/prev.png --size 512 --material glass",
]
print(f"{'job (RAYON_NUM_THREADS=' + os.environ.get('RAYON_NUM_THREADS', 'all') + ')':<62} {'before':>8} {'after':>8} {'ratio':>6}")
only = os.environ.get("ONLY")
for j in jobs:
    if only and only not in j:
        continue
    args = j.replace("W/", w + "/").split()
    best = {"before": 1e9, "after": 1e9}
    for _ in range(n):
        for v in ("before", "after"):
            s = time.perf_counter(); rc = run(v, args); t = time.perf_counter() - s
            if rc != 0: print("failed:", v, j, file=sys.stderr)
            best[v] = min(best[v], t)
    print(f"{j.replace('W/', ''):<62} {best['before']:8.3f} {best['after']:8.3f} {best['after'] / best['before']:6.3f}")
