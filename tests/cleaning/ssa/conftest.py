"""Fixtures of the self-similarity tests: a real walk and the walk with a flipped knee, detected; HDM05 takes with
real-style errors and clean's detection of them."""

import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import ssa
from mocapkit.cleaning.whole_take import detect_take, take_params


@pytest.fixture(scope="package")
def walk():
    return mocapkit.load(mocapkit.samples.path("131_01.bvh"))


@pytest.fixture(scope="package")
def flipped(walk):
    bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    return bad, mask, records, ssa.detect(bad)


@pytest.fixture(scope="package")
def hdm05_errors(shared_data):
    """``errors(take, seed)``: ``(ref, bad, mask, det)``, the HDM05 ``take`` (an .amc of the shared data's
    hdm05_asfamc), it with four real-style errors (:func:`mocapkit.corrupt.real_errors`, ``seed``), their (F, J)
    mask, and clean's detection of it (``detect_take`` with ``take_params()``); each pair made once. Skips where
    the take is not in the shared data."""
    made = {}

    def errors(take: str, seed: int):
        if (take, seed) not in made:
            path = shared_data / "hdm05_asfamc" / take
            if not path.is_file():
                pytest.skip(f"HDM05 {take} not in the shared data")
            ref = mocapkit.load(path)
            bad, mask, _ = corrupt.real_errors(ref, n_errors=4, seed=seed)
            made[take, seed] = ref, bad, mask, detect_take(bad, None, params=take_params()).detection
        return made[take, seed]

    return errors
