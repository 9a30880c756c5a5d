"""How much of a take detection judged (mocapkit.cleaning.judged), on the shipped CMU take 131_01 (BVH, 120 fps)."""

from __future__ import annotations

import pytest

import mocapkit
from mocapkit.cleaning import ssa
from mocapkit.cleaning.judged import not_judged, not_judged_note
from mocapkit.samples import path


@pytest.fixture(scope="module")
def take():
    return mocapkit.load(path("131_01.bvh"))[:480]


def test_frames_no_neighbour_word_judges_are_counted_and_said(take):
    every = ssa.detect(take)  # max_word_angle_deg None: every word has its neighbours, every frame judged
    assert not_judged(every) == (0, 0) and not_judged_note(every, take.num_frames) == ""
    none = ssa.detect(take, max_word_angle_deg=1e-6)  # no word within 1e-6 deg of another: nothing judged
    assert not_judged(none) == (480, 0)
    # judged against itself alone (no context: so every take of a rig the default context does not hold, U2's
    # Bandai batch): "or its context" said a context had been searched
    assert not_judged_note(none, 480) == ("480 of 480 frames not judged: no similar motion in the take (judged "
                                          "against itself alone)")
    with_context = ssa.detect(take[:240], [take[240:400]], max_word_angle_deg=1e-6)
    assert len(with_context.context_clips) == 2
    assert not_judged_note(with_context, 240) == ("240 of 240 frames not judged: no similar motion in the take or its "
                                                  "context")
    # put back at frames 10-489 of a 500-frame take: the frames outside (calibration poses, left alone) not counted
    padded = none.padded(10, 500)
    assert not_judged(padded) == (480, 0)
    assert not_judged_note(padded, 500).startswith("480 of 500 frames not judged")
    assert not_judged_note(None, 480) == ""
