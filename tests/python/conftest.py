"""Shared fixtures of the Python module's tests: the `ieslam` binary the module is compared
with, the shared data, and one short run through both (ctest sets IESLAM_BINARY and
IESLAM_SHARED_DATA_DIR; PYTHONPATH holds build/python)."""
import os
import pathlib
import subprocess

import pytest

BINARY = os.environ.get("IESLAM_BINARY", "")
SHARED_DATA = pathlib.Path(os.environ.get("IESLAM_SHARED_DATA_DIR", ""))
SEVEN_SCENES = SHARED_DATA / "7scenes-dev"
# Frames 0..99: a few seconds in Release; 6 keyframes, enough for a keyframe ATE (>= 3).
LAST = 99
SEED = 3


def cli(*args, check=True):
    """Runs `ieslam ARGS`; returns the completed process (stdout and stderr as text)."""
    if not BINARY:
        pytest.fail("IESLAM_BINARY is not set (run the tests through ctest)")
    return subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True, check=check)


@pytest.fixture(scope="session")
def seven_scenes():
    if not (SEVEN_SCENES / "camera-intrinsics.txt").exists():
        pytest.fail(f"no dataset at {SEVEN_SCENES} (IESLAM_SHARED_DATA_DIR)")
    return str(SEVEN_SCENES)


@pytest.fixture(scope="session")
def runs(seven_scenes, tmp_path_factory):
    """The same run through the module (written with result.write) and through the CLI."""
    import ieslam

    root = tmp_path_factory.mktemp("runs")
    result = ieslam.run(seven_scenes, threads=1, seed=SEED, last=LAST)
    result.write(str(root / "python"))
    cli("run", "--quiet", "--dataset", seven_scenes, "--output", root / "cli", "--threads", 1,
        "--seed", SEED, "--last", LAST)
    return result, root / "python", root / "cli"
