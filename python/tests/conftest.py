"""Shared helpers: the repository, the CLI binary the byte-for-byte tests compare with, the
real panoramas (../shared/fixtures/real, skipped when absent), and tools that CI must have."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
REAL = REPO.parent / "shared" / "fixtures" / "real"
IN_CI = os.environ.get("CI") == "true"


def need(module: str):
    """Imports a test tool: skipped when missing, but a failure under CI (CI=true)."""
    try:
        return __import__(module)
    except ImportError:
        if IN_CI:
            pytest.fail(f"{module} is missing (CI installs it)")
        pytest.skip(f"{module} is not installed")


@pytest.fixture(scope="session")
def cli() -> str:
    """The cubeforge binary (CUBEFORGE_BIN, else target/release/cubeforge)."""
    exe = os.environ.get("CUBEFORGE_BIN") or str(REPO / "target" / "release" / "cubeforge")
    if not os.path.exists(exe):
        if IN_CI:
            pytest.fail(f"{exe} is missing: cargo builds it before the Python tests")
        pytest.skip(f"{exe} is missing (cargo build --release)")
    return exe


def run_cli(exe: str, *args: str) -> None:
    subprocess.run([exe, "-q", *args], check=True)


def psnr(a, b) -> float:
    """PSNR in dB of b against a, on v/(1+v) (peak 1): the project's measure for radiance."""
    import numpy as np

    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    a, b = a / (1 + np.abs(a)), b / (1 + np.abs(b))
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(1.0 / mse)


def ticks_during(call) -> int:
    """How many times another Python thread counted while `call()` ran: more than none only
    when the call let go of the GIL."""
    import threading

    ticks, stop = [0], threading.Event()

    def count():
        while not stop.is_set():
            ticks[0] += 1

    t = threading.Thread(target=count)
    t.start()
    while ticks[0] == 0:
        pass
    before = ticks[0]
    try:
        call()
    finally:
        during = ticks[0] - before
        stop.set()
        t.join()
    return during
