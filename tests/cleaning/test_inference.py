"""EBF inference only where its output is used: the same numbers as a run on the whole take."""


import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import inference
from mocapkit.cleaning.deep.channels import encode


@pytest.fixture(scope="module")
def noisy():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    out, _ = corrupt.angular_noise(walk, amount=0.5, seed=4, joints=["lfemur", "rhumerus"])
    return out


@pytest.mark.parametrize("fps", [None, 60.0])  # at the model's rate, and resampled to it and back
def test_denoise_channels_until_equals_the_whole_take(noisy, fps):
    ebf = deep.shipped_model("ebf")
    take = noisy if fps is None else noisy.resample(fps)
    values, ctx = encode(take, ebf.layout)
    values[40:45, 3] = np.nan  # a gap, lerp-filled for the network
    missing = np.zeros(values.shape, dtype=bool)
    missing[100:110, 5] = True
    whole = inference.denoise_channels(values, ctx, ebf, fps=take.fps, missing=missing)
    for until in (1, 37, len(values) // 2, len(values) - 16, len(values)):
        part = inference.denoise_channels(values, ctx, ebf, fps=take.fps, missing=missing, until=until)
        assert np.array_equal(part[:until], whole[:until], equal_nan=True), until
        assert np.isnan(part[until:]).all()


def test_denoise_cells_equals_the_whole_take_on_those_cells(noisy):
    ebf = deep.shipped_model("ebf")
    cells = np.zeros(noisy.missing().shape, dtype=bool)
    j = noisy.skeleton.index("lfemur")
    cells[120:200, j] = True
    part = deep.denoise(noisy, ebf, cells=cells)
    whole = deep.denoise(noisy, ebf)
    assert np.array_equal(part.rotations[cells], whole.rotations[cells])
    assert np.array_equal(part.rotations[~cells], noisy.rotations[~cells])  # the other cells untouched
    assert deep.denoise(noisy, ebf, cells=np.zeros_like(cells)) is noisy
    with pytest.raises(ValueError, match="cells"):
        deep.denoise(noisy, ebf, cells=cells[:10])
