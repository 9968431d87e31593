"""The jobs: the CLI's own, built from keyword arguments named as its flags, writing the
CLI's bytes; reports as dicts, progress, a stop from Python, errors as Python expects."""

import os
import pathlib

import numpy as np
import pytest

import cubeforge
from conftest import REPO, run_cli, ticks_during

SKY = str(REPO / "fixtures" / "sky.exr")


def _files(folder: pathlib.Path):
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("target", ["bevy", "gltf", "filament"])
def test_ibl_writes_the_cli_bytes(tmp_path, cli, target):
    flags = {"size": 32, "diffuse_size": 8, "samples": 4, "min_size": 8}
    report = cubeforge.ibl(SKY, tmp_path / "py", target=target, **flags)
    run_cli(cli, "ibl", SKY, "-o", str(tmp_path / "cli"), "--target", target,
            "--size", "32", "--diffuse-size", "8", "--samples", "4", "--min-size", "8")
    ours, theirs = _files(tmp_path / "py"), _files(tmp_path / "cli")
    assert ours.keys() == theirs.keys() and ours
    assert ours == theirs
    assert len(report["written"]) >= 1
    assert set(report) == {"written", "warnings", "summary", "quality"}
    assert report["summary"]


def test_prefilter_with_progress_and_flag_spellings(tmp_path, cli):
    seen = []
    out = tmp_path / "ggx.ktx2"
    report = cubeforge.prefilter(SKY, out, filter="ggx", size=32, samples=8, zstd=19,
                                 progress=lambda done, total, label: seen.append((done, total, label)))
    run_cli(cli, "prefilter", SKY, "-o", str(tmp_path / "cli.ktx2"), "--filter", "ggx", "--size", "32",
            "--samples", "8", "--zstd")
    assert out.read_bytes() == (tmp_path / "cli.ktx2").read_bytes()
    assert str(out) in report["written"]
    assert seen and seen[-1][0] == seen[-1][1]


def test_a_raising_callback_stops_the_job_and_writes_nothing(tmp_path):
    out = tmp_path / "stopped.ktx2"

    def stop(done, total, label):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cubeforge.prefilter(SKY, out, filter="ggx", size=256, samples=512, progress=stop)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_a_job_releases_the_gil(tmp_path):
    """Another Python thread runs while a job works (it counts, the job's thread computes)."""
    during = ticks_during(
        lambda: cubeforge.prefilter(SKY, tmp_path / "ggx.ktx2", filter="ggx", size=64, samples=64)
    )
    assert during > 1000


def test_info_lut_preview_convert(tmp_path):
    d = cubeforge.info(SKY)
    assert d["kind"] == "equirect" and d["width"] == 512
    lut = tmp_path / "lut.png"
    cubeforge.lut(lut, size=16)
    assert lut.exists()
    report, image = cubeforge.preview(SKY, size=32)
    assert image.shape == (32, 32, 4) and image.dtype == np.float32
    report = cubeforge.convert(SKY, tmp_path / "faces", to="faces", size=16)
    assert len(report["written"]) == 6


def test_errors_are_python_errors(tmp_path):
    with pytest.raises(cubeforge.FileError) as e:
        cubeforge.prefilter(tmp_path / "missing.exr", tmp_path / "o.ktx2", filter="ggx")
    assert isinstance(e.value, OSError) and isinstance(e.value, cubeforge.Error)
    assert "missing.exr" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(cubeforge.ArgumentError) as e:
        cubeforge.prefilter(SKY, tmp_path / "o.ktx2", filter="nope")
    assert isinstance(e.value, ValueError)
    with pytest.raises(ValueError):
        cubeforge.ibl(SKY, tmp_path / "x", target="bevy", size=0)
    bad = tmp_path / "bad.exr"
    bad.write_bytes(b"not an exr at all")
    with pytest.raises(OSError):
        cubeforge.read(bad)
    assert not (tmp_path / "o.ktx2").exists() and not (tmp_path / "x").exists()


def test_batch_returns_its_report_and_keeps_the_working_folder(tmp_path):
    (tmp_path / "m.toml").write_text(
        f'[[job]]\ninputs = ["{SKY}"]\ncommand = "convert"\nargs = ["--size", "8", "--to", "hcross"]\n'
        'output = "{stem}.png"\n'
        '[[job]]\ncommand = "lut"\nargs = ["--size", "8"]\noutput = "lut.png"\n'
    )
    here = os.getcwd()
    seen = []
    report = cubeforge.batch(tmp_path / "m.toml", progress=lambda *a: seen.append(a))
    assert os.getcwd() == here
    assert (report["ran"], report["up_to_date"], report["failed"], report["from_cache"]) == (2, 0, 0, 0)
    assert sorted(report["written"]) == [str(tmp_path / "lut.png"), str(tmp_path / "sky.png")]
    assert [j["outcome"] for j in report["jobs"]] == ["ran", "ran"]
    assert report["jobs"][0]["id"].startswith("convert ") and report["jobs"][0]["why"]
    assert report["summary"][-1].startswith("batch: 2 jobs: 2 ran, 0 up to date, 0 failed")
    assert seen and seen[-1][:2] == (2, 2)
    again = cubeforge.batch(tmp_path / "m.toml")
    assert (again["ran"], again["up_to_date"], again["written"]) == (0, 2, [])
    assert [j["outcome"] for j in again["jobs"]] == ["up to date", "up to date"]
    dry = cubeforge.batch(tmp_path / "m.toml", dry_run=True, force=True)
    assert dry["would_run"] == 2 and not dry["written"]
    ninja = cubeforge.batch(tmp_path / "m.toml", emit="ninja")
    assert ninja["written"] == [str(tmp_path / "build.ninja")] and ninja["jobs"] == []
    assert ninja["summary"][0].startswith("batch: wrote build.ninja (2 jobs)")


def test_a_stopped_batch_runs_no_further_job_and_keeps_what_finished(tmp_path):
    """An exception from the progress callback (as Ctrl-C) stops the batch between jobs: the
    running one ends whole, the rest do not start, and a rerun builds only those."""
    jobs = "".join(
        f'[[job]]\ninputs = ["{SKY}"]\ncommand = "prefilter"\n'
        f'args = ["--filter", "ggx", "--size", "256", "--samples", "1024"]\noutput = "g{i}.ktx2"\n'
        for i in range(12)
    )
    (tmp_path / "m.toml").write_text(jobs)

    def stop(done, total, label):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cubeforge.batch(tmp_path / "m.toml", progress=stop)
    built = sorted(p.name for p in tmp_path.glob("g*.ktx2"))
    assert len(built) < 12
    again = cubeforge.batch(tmp_path / "m.toml")
    assert (again["ran"], again["up_to_date"]) == (12 - len(built), len(built))


def test_a_failed_batch_job_raises_with_the_report(tmp_path):
    (tmp_path / "m.toml").write_text(
        f'[[job]]\ninputs = ["{SKY}"]\ncommand = "convert"\nargs = ["--size", "8", "--to", "hcross"]\n'
        'output = "{stem}.png"\n'
        '[[job]]\ninputs = ["missing.exr"]\ncommand = "convert"\nargs = ["--size", "8"]\n'
        'output = "missing.png"\n'
    )
    with pytest.raises(cubeforge.ArgumentError) as e:
        cubeforge.batch(tmp_path / "m.toml")
    assert "1 of 2 jobs failed" in str(e.value) and "missing.exr" in str(e.value)
    report = e.value.report
    assert (report["ran"], report["failed"]) == (1, 1)
    assert [j["outcome"] for j in report["jobs"]] == ["ran", "failed"]
    assert "missing.exr" in report["jobs"][1]["error"] and len(report["failures"]) == 1
    assert not (tmp_path / "missing.png").exists()


def test_ctrl_c_stops_a_job_and_writes_nothing(tmp_path):
    """SIGINT while a job runs: KeyboardInterrupt in Python, no output, the process goes on."""
    import signal
    import subprocess
    import sys

    out = tmp_path / "long.ktx2"
    script = (
        "import sys, cubeforge\n"
        "first = []\n"
        "def tell(done, total, label):\n"
        "    if not first: first.append(1); print('started', flush=True)\n"
        "try:\n"
        f"    cubeforge.prefilter({SKY!r}, {str(out)!r}, filter='ggx', size=512, samples=4096, progress=tell)\n"
        "    print('finished')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted', flush=True)\n"
    )
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "started"
    p.send_signal(signal.SIGINT)
    rest, _ = p.communicate(timeout=120)
    assert rest.strip() == "interrupted" and p.returncode == 0
    assert list(tmp_path.iterdir()) == []
