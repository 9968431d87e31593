#!/usr/bin/env python3
"""Issue 47's 16K row: `ibl --target bevy` and `info` of a 16K half-float ZIP panorama beside
OpenEXR's own read of the same file (its Python bindings), alternating, best of RUNS.

    python3 tests/tools/big_input.py BINARY FILE.exr      # RUNS=3 by default

Make FILE with `cubeforge convert esplanade.hdr -o /tmp/p16k.exr --to equirect --size 4096`
(keep it out of the repository). Prints each stage's best time (`-v`), the peak RSS
(/usr/bin/time) and OpenEXR's read time."""
import os, re, subprocess, sys, tempfile, time

import OpenEXR

binary, path = sys.argv[1], sys.argv[2]
runs = int(os.environ.get("RUNS", "3"))
best = {}


def keep(name, value):
    best[name] = min(best.get(name, value), value)


for _ in range(runs):
    t = time.time()
    f = OpenEXR.File(path)
    _ = [c.pixels for c in f.channels().values()]
    keep("openexr read", time.time() - t)
    del f, _
    for job in (["ibl", "--target", "bevy", "-o", tempfile.mkdtemp()], ["info"]):
        cmd = ["/usr/bin/time", "-f", "TIME %e %M", binary, job[0], path] + job[1:] + ["-v"]
        out = subprocess.run(cmd, capture_output=True, text=True).stderr
        for line in out.splitlines():
            m = re.match(r"cubeforge: (\w+)\s+([\d.]+) s", line)
            if m:
                keep(f"{job[0]} {m.group(1)}", float(m.group(2)))
            m = re.match(r"TIME ([\d.]+) (\d+)", line)
            if m:
                keep(f"{job[0]} wall", float(m.group(1)))
                keep(f"{job[0]} peak MB", int(m.group(2)) / 1024)
for k, v in best.items():
    print(f"{k:24} {v:9.3f}")
