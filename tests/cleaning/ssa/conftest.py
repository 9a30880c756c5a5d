"""Fixtures of the self-similarity tests: a real walk and the walk with a flipped knee, detected."""

import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import ssa


@pytest.fixture(scope="package")
def walk():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))


@pytest.fixture(scope="package")
def flipped(walk):
    bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    return bad, mask, records, ssa.detect(bad)
