"""ieslam.load_dataset: frames as NumPy arrays."""
import numpy as np
import pytest

import ieslam


def test_frames_have_the_right_shapes_and_types(seven_scenes):
    dataset = ieslam.load_dataset(seven_scenes, last=4)
    assert len(dataset) == 5 and dataset.format == "7scenes" and dataset.has_ground_truth
    frames = list(dataset)
    assert [f.index for f in frames] == list(range(5))
    for frame in frames:
        assert frame.colour.dtype == np.uint8 and frame.colour.ndim == 3
        assert frame.colour.shape[2] == 3
        assert frame.depth.dtype == np.float32 and frame.depth.ndim == 2
        assert np.all(frame.depth >= 0.0) and np.any(frame.depth > 0.0)
        assert float(frame.depth.max()) < 20.0  # metres, not millimetres
        assert frame.T_w_c_gt.shape == (4, 4)
    np.testing.assert_array_equal(dataset.timestamps, [f.timestamp for f in frames])
    assert dataset.ground_truth.shape == (5, 8)
    assert dataset.K.shape == (3, 3)
    assert dataset[-1].index == 4
    with pytest.raises(IndexError):
        dataset[5]


def test_stride_and_format(seven_scenes):
    dataset = ieslam.load_dataset(seven_scenes, format="7scenes", first=2, last=8, stride=3)
    assert [f.source_index for f in dataset] == [2, 5, 8]
    with pytest.raises(ieslam.ConfigError, match="dataset.format"):
        ieslam.load_dataset(seven_scenes, format="kitti")
    with pytest.raises(ieslam.ConfigError, match="dataset.strid"):
        ieslam.load_dataset(seven_scenes, strid=2)
