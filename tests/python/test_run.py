"""ieslam.run against `ieslam run`: the same trajectory bit for bit, and the result's arrays."""
import json

import numpy as np
import pytest

import ieslam
from conftest import LAST, SEED, cli


@pytest.mark.parametrize("name", ["trajectory.tum", "keyframes.tum", "groundtruth.tum",
                                  "selected_frames.txt"])
def test_written_files_equal_the_cli(runs, name):
    _, python_dir, cli_dir = runs
    assert (python_dir / name).read_bytes() == (cli_dir / name).read_bytes()


def test_report_matches_the_cli(runs):
    result, python_dir, cli_dir = runs
    python_report = json.loads((python_dir / "report.json").read_text())
    cli_report = json.loads((cli_dir / "report.json").read_text())
    for key in ["frames_total", "frames_selected", "state_dim", "poses", "features",
                "ate_rmse_m", "options", "seed"]:
        assert python_report[key] == cli_report[key], key
    assert result.ate_rmse_m["keyframes"] == cli_report["ate_rmse_m"]["keyframes"]
    assert result.ate_rmse_m["trajectory"] == cli_report["ate_rmse_m"]["trajectory"]
    assert result.ate_rmse_m["refined"] is None
    assert (python_dir / "map.ply").exists()


def test_arrays_hold_what_the_files_hold(runs):
    result, python_dir, _ = runs
    for array, name in [(result.trajectory, "trajectory.tum"), (result.keyframes, "keyframes.tum"),
                        (result.ground_truth, "groundtruth.tum")]:
        assert array.dtype == np.float64 and array.ndim == 2 and array.shape[1] == 8
        from_file = np.loadtxt(python_dir / name, comments="#", ndmin=2)
        assert array.shape == from_file.shape, name
        # The files print 6 decimals for stamps and 9 for values.
        np.testing.assert_allclose(array[:, 0], from_file[:, 0], rtol=0, atol=1e-6)
        np.testing.assert_allclose(array[:, 1:], from_file[:, 1:], rtol=0, atol=1e-9)
    assert result.trajectory.shape[0] == LAST + 1
    assert np.all(result.trajectory[:, 7] >= 0.0)


def test_keyframes_ids_covariances(runs):
    result, python_dir, _ = runs
    k = result.keyframes.shape[0]
    assert k >= 2
    ids = result.keyframe_ids
    assert len(ids) == k and sorted(result.selected) == sorted(ids)
    assert result.keyframe_source_ids == ids  # no --first/--stride
    stamps = ieslam.load_dataset(str(runs[0].dataset.directory)).timestamps
    np.testing.assert_array_equal(result.keyframes[:, 0], stamps[ids])
    selected = [int(line.split()[0]) for line in
                (python_dir / "selected_frames.txt").read_text().split("\n")
                if line and not line.startswith("#")]
    assert sorted(selected) == sorted(ids)
    c = result.covariances
    assert c.shape == (k, 6, 6) and c.dtype == np.float64
    assert np.all(np.isfinite(c))
    np.testing.assert_allclose(c, np.transpose(c, (0, 2, 1)), rtol=0, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(c) > 0.0)
    assert result.decisions and all("reason" in d for d in result.decisions)


def test_seconds_and_report(runs):
    result, _, _ = runs
    seconds = result.seconds
    assert seconds["total"] > 0.0
    for stage in ["frontend", "selection", "filter"]:
        assert stage in seconds
    assert "ba" not in seconds
    report = result.report
    assert report["seed"] == SEED and report["interrupted"] is False
    assert result.options["threads"] == 1 and result.options["seed"] == SEED
    assert not result.interrupted and result.frames_processed == LAST + 1


def test_options_dict_equals_overrides(seven_scenes):
    # A dict of the registry's sections and the run's flags set the same options.
    a = ieslam.run(seven_scenes, {"dataset": {"last": 5}, "threads": 1, "seed": SEED,
                                  "selector": {"buffer": 2}, "write_map": False})
    b = ieslam.run(seven_scenes, {"write_map": False}, last=5, threads=1, seed=SEED, buffer=2)
    assert a.options == b.options
    assert a.options["selector"]["buffer"] == 2
    np.testing.assert_array_equal(a.trajectory, b.trajectory)


def test_refine(seven_scenes, tmp_path):
    result = ieslam.run(seven_scenes, {"write_map": False}, threads=1, seed=SEED, last=59,
                        refine=True)
    assert result.refinement_failure == ""
    refined = result.refined
    assert refined.shape == result.keyframes.shape
    assert "ba" in result.seconds
    assert result.ate_rmse_m["refined"] is not None
    result.write(str(tmp_path))
    from_file = np.loadtxt(tmp_path / "refined.tum", comments="#", ndmin=2)
    np.testing.assert_allclose(refined[:, 1:], from_file[:, 1:], rtol=0, atol=1e-9)


def test_run_on_from_a_map_equals_the_cli(runs, seven_scenes, tmp_path):
    _, _, cli_run = runs  # a map of frames 0..LAST
    first, last = LAST + 1, LAST + 40
    result = ieslam.run(seven_scenes, {"write_map": False}, map=str(cli_run), threads=1,
                        seed=SEED, first=first, last=last)
    result.write(str(tmp_path / "python"))
    cli("run", "--quiet", "--map", cli_run, "--dataset", seven_scenes, "--output",
        tmp_path / "cli", "--threads", 1, "--seed", SEED, "--first", first, "--last", last)
    for name in ("keyframes.tum", "trajectory.tum", "selected_frames.txt"):
        assert ((tmp_path / "python" / name).read_bytes() ==
                (tmp_path / "cli" / name).read_bytes()), name
    report = json.loads((tmp_path / "cli" / "report.json").read_text())
    mapped = json.loads((cli_run / "report.json").read_text())
    assert report["continued_map"]["keyframes"] == mapped["frames_selected"]
    assert report["frames_selected"] > mapped["frames_selected"]
    assert result.keyframes.shape[0] == report["frames_selected"]
    with pytest.raises(ieslam.DataError, match="map.bin"):
        ieslam.run(seven_scenes, map=str(tmp_path / "nothing"), first=first, last=last)
