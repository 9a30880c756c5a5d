"""benchmarks/ssa_detection.py's false_positive_pairs: where the pairs scored as false positives are."""

from types import SimpleNamespace

import numpy as np

from mocapkit.cleaning.ssa.cues import CAUSES

from .helpers import load


def test_false_positive_pairs_name_the_joint_the_rule_and_the_untouched_takes_own():
    bench = load("ssa_detection")
    fps = 120.0  # words of 75 frames every 25
    F, J = 300, 3
    bit = {name: 1 << i for i, (name, _) in enumerate(CAUSES)}
    causes = np.zeros((F, J), dtype=np.uint16)
    truth = np.zeros((F, J), dtype=bool)
    causes[100, 0] = bit["break"]  # a lone false positive of joint 0, which the untouched take flags too
    causes[180:190, 1] = bit["swap"]  # joint 1's swap flags, before an injected error's cells
    truth[240:250, 1] = True
    causes[40, 2] = bit["break"] | bit["spike"]  # joint 2, at a cell of unknown truth: not scored
    ignore = np.zeros((F, J), dtype=bool)
    ignore[40, 2] = True
    own = np.zeros((F, J), dtype=bool)
    own[100, 0] = True
    det = SimpleNamespace(flags=causes != 0, causes=lambda: causes.copy(), joint_names=("a", "b", "c"))
    got = bench.false_positive_pairs(det, truth, fps, ignore, own)
    n, s = bench.word_frames(fps)
    assert (n, s) == (75, 25)
    # frame 100 lies in the words starting at 50, 75 and 100; frames 180-189 in those at 125, 150 and 175, the
    # last of which holds frames 240-249 too
    assert got == {"a": {"pairs": 3, "untouched_take": 3, "causes": {"break": 3}},
                   "b": {"pairs": 2, "untouched_take": 0, "causes": {"swap": 2}}}
    # the score counts the same false positives
    assert bench.score(det.flags, truth, fps, ignore=ignore).fp == 5
    assert bench.merge_pairs(bench.merge_pairs({}, got), got)["a"] == {"pairs": 6, "untouched_take": 6, "causes": {"break": 6}}
