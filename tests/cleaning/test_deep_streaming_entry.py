"""deep.denoise_rows refuses what is not a skeleton and file-channel rows at its entry, in one clear TypeError."""

import pytest

import mocapkit
from mocapkit.cleaning import deep


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:40]


def test_a_motion_given_for_the_skeleton_or_the_rows_is_a_type_error_naming_it(walk):
    with pytest.raises(TypeError, match=r"skeleton must be a Skeleton \(motion.skeleton\), got Motion"):
        deep.denoise_rows(walk, walk.channel_values(), walk.fps)
    with pytest.raises(TypeError, match=r"rows must be an array .*got Motion"):
        deep.denoise_rows(walk.skeleton, walk, walk.fps)
    with pytest.raises(ValueError, match=r"2-D"):
        deep.denoise_rows(walk.skeleton, walk.channel_values()[0], walk.fps)
