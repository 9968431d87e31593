#!/usr/bin/env python3
"""Issue 47's 16K row: `ibl --target bevy` and `info` of a 16K half-float ZIP panorama beside
OpenEXR's own read of the same file (its Python bindings), alternating, best of RUNS.

    python3 tests/tools/big_input.py BINARY FILE.exr [BEFORE]    # RUNS=3 by default

Make FILE with `cubeforge convert esplanade.hdr -o /tmp/p16k.exr --to equirect --size 4096`
(keep it out of the repository); a 16K Radiance FILE.hdr (made the same way) is timed without
OpenEXR's read. Prints each stage's best time (`-v`), the peak RSS
(/usr/bin/time) and OpenEXR's read time; with BEFORE (another build of cubeforge) its
figures too, in a second column, measured in the same loop."""
import os, re, subprocess, sys, tempfile, time

binary, path = sys.argv[1], sys.argv[2]
builds = {"after": binary}
if len(sys.argv) > 3:
    builds = {"before": sys.argv[3], "after": binary}
runs = int(os.environ.get("RUNS", "3"))
best = {name: {} for name in builds}


def keep(build, name, value):
    b = best[build]
    b[name] = min(b.get(name, value), value)


for _ in range(runs):
    if path.endswith(".exr"):
        import OpenEXR

        t = time.time()
        f = OpenEXR.File(path)
        _ = [c.pixels for c in f.channels().values()]
        for build in builds:
            keep(build, "openexr read", time.time() - t)
        del f, _
    for build, exe in builds.items():
        for job in (["ibl", "--target", "bevy", "-o", tempfile.mkdtemp()], ["info"]):
            cmd = ["/usr/bin/time", "-f", "TIME %e %M", exe, job[0], path] + job[1:] + ["-v"]
            out = subprocess.run(cmd, capture_output=True, text=True).stderr
            for line in out.splitlines():
                m = re.match(r"cubeforge: (\w+)\s+([\d.]+) s", line)
                if m:
                    keep(build, f"{job[0]} {m.group(1)}", float(m.group(2)))
                m = re.match(r"TIME ([\d.]+) (\d+)", line)
                if m:
                    keep(build, f"{job[0]} wall", float(m.group(1)))
                    keep(build, f"{job[0]} peak MB", int(m.group(2)) / 1024)
print(f"{'':24} " + " ".join(f"{b:>9}" for b in builds))
for k in best["after"]:
    print(f"{k:24} " + " ".join(f"{best[b].get(k, float('nan')):9.3f}" for b in builds))
