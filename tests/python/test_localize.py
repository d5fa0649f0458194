"""ieslam.localize against `ieslam localize`: the same placements, and its errors."""
import json

import numpy as np
import pytest

import ieslam
from conftest import LAST, SEED, cli


def test_localize_equals_the_cli(runs, seven_scenes, tmp_path):
    _, _, cli_run = runs  # a map of frames 0..LAST
    first, last = LAST - 19, LAST + 20  # 20 mapped frames, then 20 beyond the map
    result = ieslam.localize(str(cli_run), seven_scenes, threads=1, seed=SEED, first=first,
                             last=last)
    cli("localize", "--quiet", "--map", cli_run, "--dataset", seven_scenes, "--output",
        tmp_path, "--threads", 1, "--seed", SEED, "--first", first, "--last", last)
    report = json.loads((tmp_path / "report.json").read_text())
    ours = result["report"]
    for key in ("frames_localized", "frames_localized_by_map", "resumptions", "ate_rmse_m",
                "consistency", "frames_not_localized"):
        assert ours[key] == report[key], key
    placed = np.loadtxt(tmp_path / "trajectory.tum")
    assert result["trajectory"].shape == placed.shape
    np.testing.assert_allclose(result["trajectory"], placed, atol=1e-6)
    covariances = np.loadtxt(tmp_path / "covariances.txt")
    np.testing.assert_allclose(result["covariances"].reshape(len(placed), 36),
                               covariances[:, 1:], rtol=1e-6)
    assert len(result["placed"]) == last - first + 1
    assert result["placed"][:20] == ["map"] * 20
    assert result["report"]["frames_localized"] >= 20


def test_localize_errors(runs, seven_scenes, tmp_path):
    with pytest.raises(ieslam.DataError, match="map.bin"):
        ieslam.localize(str(tmp_path), seven_scenes)
    _, _, cli_run = runs
    with pytest.raises(ieslam.ConfigError, match="buffer"):
        ieslam.localize(str(cli_run), seven_scenes, buffer=4)
