#!/usr/bin/env python3
"""The hostile-input sweep's command-line half (the library's is tests/hostile_inputs/):
seeded mutations of a batch manifest (TOML) run with `cubeforge batch --dry-run` and
`--emit ninja`, and of small OpenEXR, .hdr and UltraHDR panoramas run with `cubeforge ibl --target
bevy`, `info` and `prefilter` under an address-space cap (`ulimit -v`) and a timeout. A
defect is a signal or abort, a hang past the timeout, a message of several lines or one that
does not name the file, or a refused job that left an output behind. Not run in CI (a few
minutes); by hand:

    python3 tests/tools/hostile_sweep.py [ROUNDS]   # target/release/cubeforge, or CUBEFORGE_BIN

Prints what it ran and found per format; exits 1 on any defect.
"""

import os
import random
import resource
import shutil
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXE = os.environ.get("CUBEFORGE_BIN") or os.path.join(REPO, "target", "release", "cubeforge")
CAP = 1 << 30  # bytes of address space the jobs may map (the jobs' budget is a quarter)
TIMEOUT = 60

MANIFEST = """[[job]]
inputs = ["sky*.exr"]
command = "ibl"
args = ["--target", "bevy", "--size", "8"]
output = "build/{stem}/bevy"

[[job]]
inputs = ["sky.exr"]
command = "prefilter"
args = ["--size", "8", "--filter", "ggx"]
output = "build/{stem}.ktx2"

[[job]]
command = "lut"
args = ["--size", "16"]
output = "build/lut.png"
"""

NUMBERS = [b"0", b"-1", b"1e309", b"nan", b"inf", b"4294967296", b"18446744073709551616",
           b"99999999999999999999", b"65537", b"16384", b"0x7fffffff", b"-0.0"]


def limit():
    resource.setrlimit(resource.RLIMIT_AS, (CAP, CAP))


def run(args, cwd):
    try:
        p = subprocess.run([EXE, *args], cwd=cwd, capture_output=True, timeout=TIMEOUT,
                           preexec_fn=limit)
    except subprocess.TimeoutExpired:
        return None
    return p


def mutate(rng, src, text):
    b = bytearray(src)
    for _ in range(1 + rng.randrange(3)):
        if not b:
            b.append(0)
        at = rng.randrange(min(len(b), 512) if rng.randrange(4) else len(b))
        k = rng.randrange(9 if text else 6)
        if k == 0:
            b[at] ^= 1 << rng.randrange(8)
        elif k == 1:
            b[at] = rng.randrange(256)
        elif k == 2:
            del b[at:at + 1 + rng.randrange(64)]
        elif k == 3:
            span = b[at:at + 1 + rng.randrange(128)]
            to = rng.randrange(len(b))
            b[to:to] = span
        elif k == 4:
            b[at:at] = bytes(rng.randrange(256) for _ in range(1 + rng.randrange(8)))
        elif k == 5:
            # A number, a 32-bit field made extreme.
            if text:
                digits = [i for i in range(at, len(b)) if chr(b[i]).isdigit()]
                if digits:
                    i = digits[0]
                    j = i
                    while j < len(b) and chr(b[j]).isdigit():
                        j += 1
                    b[i:j] = rng.choice(NUMBERS)
            else:
                v = rng.choice([0, 1, 0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, 16384, 8191, 65536])
                b[at:at + 4] = v.to_bytes(4, "little")
        elif k == 6:
            b[at:at] = rng.choice([b'"', b"'", b"[", b"]", b"{", b"}", b"=", b",", b"\n", b"#", b"\\"])
        elif k == 7:
            start = b.rfind(b"\n", 0, at) + 1
            end = b.find(b"\n", at)
            end = len(b) if end < 0 else end + 1
            if rng.randrange(2):
                del b[start:end]
            else:
                b[start:start] = b[start:end]
        else:
            depth = rng.choice([64, 200, 1000, 20000])
            b[at:at] = b"[" * depth + b"1" + (b"]" * depth if rng.randrange(2) else b"")
    if rng.randrange(12) == 0 and b:
        del b[rng.randrange(len(b)):]
    return bytes(b)


class Tally:
    def __init__(self, what):
        self.what, self.runs, self.ok, self.refused, self.defects = what, 0, 0, 0, []

    def check(self, p, names, round_, left=None):
        self.runs += 1
        if p is None:
            self.defects.append(f"{self.what} {round_}: hung past {TIMEOUT} s")
            return
        err = p.stderr.decode("utf-8", "replace").strip()
        if p.returncode < 0 or p.returncode > 2 or "panicked" in err:
            self.defects.append(f"{self.what} {round_}: exit {p.returncode}: {err[-300:]}")
        elif p.returncode == 0:
            self.ok += 1
        else:
            self.refused += 1
            lines = [l for l in err.splitlines() if l.startswith("cubeforge: error")]
            if len(lines) != 1 or not any(n in lines[0] for n in names):
                self.defects.append(f"{self.what} {round_}: the error: {err[-300:]}")
            if left and os.path.exists(left):
                self.defects.append(f"{self.what} {round_}: refused, but left {left}")

    def report(self):
        print(f"{self.what}: {self.runs} runs, {self.ok} ran, "
              f"{self.refused} refused, {len(self.defects)} defects")
        for d in self.defects[:20]:
            print("  DEFECT", d)
        return not self.defects


def manifests(rounds, dir_):
    shutil.copy(os.path.join(REPO, "fixtures", "sky.exr"), os.path.join(dir_, "sky.exr"))
    rng = random.Random(0x6D616E69)
    path = os.path.join(dir_, "m.toml")
    dry, emit = Tally("manifest (batch --dry-run)"), Tally("manifest (batch --emit ninja)")
    for r in range(rounds):
        with open(path, "wb") as f:
            f.write(mutate(rng, MANIFEST.encode(), True))
        dry.check(run(["batch", "m.toml", "--dry-run"], dir_), ["m.toml", "sky.exr", "build"], r)
        emit.check(run(["batch", "m.toml", "--emit", "ninja"], dir_), ["m.toml", "sky.exr", "build"], r)
        for leftover in ("build.ninja",):
            p = os.path.join(dir_, leftover)
            if os.path.exists(p):
                os.remove(p)
    return dry.report() & emit.report()


def panoramas(rounds, dir_):
    ok = True
    for ext, extra in (("exr", []), ("hdr", []), ("jpg", ["--ultrahdr"])):
        src = os.path.join(dir_, f"src.{ext}")
        p = run(["convert", os.path.join(REPO, "fixtures", "sky.exr"), "-o", src, "--to", "equirect",
                 "--size", "64", *extra], dir_)
        assert p and p.returncode == 0, p and p.stderr
        body = open(src, "rb").read()
        rng = random.Random(hash(ext) & 0xFFFF)
        tallies = {c: Tally(f".{ext} ({c})") for c in ("ibl", "info", "prefilter")}
        name = f"pano.{ext}"
        for r in range(rounds):
            with open(os.path.join(dir_, name), "wb") as f:
                f.write(mutate(rng, body, False))
            out = os.path.join(dir_, "out")
            shutil.rmtree(out, ignore_errors=True)
            budget = ["--max-memory", str(CAP // 4)]
            env_stream = {"CUBEFORGE_STREAM_TEXELS": "0"}
            tallies["ibl"].check(run(["ibl", name, "-o", "out", "--target", "bevy", "--size", "8", *budget], dir_),
                                 [name], r, left=out)
            os.environ.update(env_stream)
            tallies["info"].check(run(["info", name, *budget], dir_), [name], r)
            del os.environ["CUBEFORGE_STREAM_TEXELS"]
            tallies["prefilter"].check(run(["prefilter", name, "-o", "c.ktx2", "--size", "8", "--filter", "ggx", *budget], dir_),
                                       [name], r, left=os.path.join(dir_, "c.ktx2"))
            if os.path.exists(os.path.join(dir_, "c.ktx2")):
                os.remove(os.path.join(dir_, "c.ktx2"))
        for t in tallies.values():
            ok &= t.report()
    return ok


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    with tempfile.TemporaryDirectory() as d:
        ok = manifests(rounds, d)
        ok &= panoramas(rounds, d)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
