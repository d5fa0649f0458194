"""ieslam.evaluate against `ieslam evaluate`: the same numbers to the printed digit."""
import numpy as np
import pytest

import ieslam
from conftest import cli


def printed(text):
    return {key: value for key, value in (line.split() for line in text.strip().split("\n"))}


@pytest.mark.parametrize("flags, kwargs", [
    ([], {}),
    (["--delta", 3, "--delta-unit", "f", "--max-diff", 0.05], {"delta": 3, "delta_unit": "f",
                                                                 "max_diff": 0.05}),
])
def test_evaluate_equals_the_cli(runs, flags, kwargs):
    _, python_dir, _ = runs
    gt, est = str(python_dir / "groundtruth.tum"), str(python_dir / "trajectory.tum")
    process = cli("evaluate", "--gt", gt, "--est", est, *flags)
    result = ieslam.evaluate(gt, est, **kwargs)
    assert result["text"] == process.stdout
    expected = printed(process.stdout)
    assert set(result["values"]) == set(expected)
    for key, value in result["values"].items():
        if key.endswith(".pairs"):
            assert str(value) == expected[key]
        else:
            assert f"{value:.6f}" == expected[key], key
    assert result["ate_pairs"].shape == (result["values"]["ate.pairs"], 3)
    errors = result["ate_pairs"][:, 2]
    assert np.sqrt(np.mean(errors ** 2)) == pytest.approx(result["ate"]["rmse"], rel=1e-12)


def test_evaluate_arrays(runs):
    result, python_dir, _ = runs
    from_files = ieslam.evaluate(str(python_dir / "groundtruth.tum"),
                                 str(python_dir / "trajectory.tum"))
    from_arrays = ieslam.evaluate(result.ground_truth, result.trajectory)
    # The arrays are not rounded as the files are.
    assert from_arrays["ate"]["rmse"] == pytest.approx(from_files["ate"]["rmse"], abs=1e-6)
    assert from_arrays["aligned_estimate"].shape == result.trajectory.shape
    assert result.ate_rmse_m["trajectory"] == from_files["ate"]["rmse"]


def test_evaluate_errors(runs):
    result, python_dir, _ = runs
    with pytest.raises(ieslam.ConfigError, match="delta_unit"):
        ieslam.evaluate(result.ground_truth, result.trajectory, delta_unit="weeks")
    with pytest.raises(ieslam.ConfigError, match="maxdiff"):
        ieslam.evaluate(result.ground_truth, result.trajectory, maxdiff=1)
    with pytest.raises(ieslam.DataError, match="N x 8"):
        ieslam.evaluate(result.ground_truth, result.trajectory[:, :7])
    with pytest.raises(ieslam.DataError, match="nope.tum"):
        ieslam.evaluate(str(python_dir / "nope.tum"), result.trajectory)
