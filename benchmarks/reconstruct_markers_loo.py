"""Six markers, every HDM05 actor held out in turn (Krüger et al. 2010, sec. 5.2): mean joint error per performer.

Usage::

    python benchmarks/reconstruct_markers_loo.py [--quick] [--json] [--k K] [--head-weight 1.5] [--clips-per-class 2]
        [--locomotion-clips 0] [--max-frames 150] [--bandai-styles elderly,angry,...] [--bandai-takes 7]

The same as ``python benchmarks/reconstruct_markers.py --leave-one-out``
(see that script for the scenario, the figures and the baselines): each of
the five HDM05 actors held out in turn, the database the other four actors'
clips of all 11 classes; per held-out actor the mean error on locomotion (jog,
sneak, hop: every clip of the actor's) and on all classes (two clips of each), beside the nearest-neighbour baseline and the
previous defaults (``k=256``, no head weight in the search) in the same run; then held-out Bandai Namco styles
with the large database (the figure per style, over seven of its locomotion takes: all of
each dataset-1 style's). Target: <= 2.0 cm on
locomotion for every held-out actor and style.
"""

from __future__ import annotations

import sys

import reconstruct_markers


if __name__ == "__main__":
    raise SystemExit(reconstruct_markers.main(["--leave-one-out", *sys.argv[1:]]))
