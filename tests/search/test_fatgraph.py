"""Fat-graph base poses against a quadratic greedy oracle, and on real features."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from mocapkit.search.fatgraph import fat_graph_base_poses


def naive_base_poses(x, radius, k):
    """O(n^2): neighbour lists from the full distance matrix, then the greedy cover, one pick at a time."""
    n = len(x)
    d = np.sqrt(((x[:, None] - x[None]) ** 2).sum(-1))
    nbrs = []
    for i in range(n):
        order = np.lexsort((np.arange(n), d[i]))
        nbrs.append([j for j in order[:k] if d[i, j] <= radius])
    counts = [len(a) for a in nbrs]
    covered = [False] * n
    labels = [-1] * n
    chosen = []
    while True:
        live = [sum(not covered[j] for j in nbrs[i]) if not covered[i] else 0 for i in range(n)]
        best = max(range(n), key=lambda i: (live[i], -i))
        if live[best] == 0:
            break
        for j in [best] + nbrs[best]:
            if not covered[j]:
                covered[j] = True
                labels[j] = len(chosen)
        chosen.append(best)
    return chosen, labels, counts


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 40), k=st.integers(1, 10), radius=st.floats(0.05, 2.0), seed=st.integers(0, 2**31))
def test_equals_naive_greedy(n, k, radius, seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 2))
    bp = fat_graph_base_poses(x, radius=radius, k=k)
    chosen, labels, counts = naive_base_poses(x, radius, k)
    assert bp.indices.tolist() == chosen
    assert bp.labels.tolist() == labels
    assert bp.counts.tolist() == counts


def test_first_base_pose_has_most_neighbours_on_real_features(small_db):
    x = np.asarray(small_db.features["F15"])
    bp = fat_graph_base_poses(x, radius=15.0, k=64)
    assert bp.counts[bp.indices[0]] == bp.counts.max()
    assert np.all(bp.labels >= 0)  # every frame is covered
    # every frame lies within the radius of its base pose
    dist = np.linalg.norm(x - x[bp.indices[bp.labels]], axis=1)
    assert np.all(dist <= 15.0 + 1e-9)
    assert 1 < len(bp) < len(x) / 2
    assert len(fat_graph_base_poses(x, radius=15.0, k=64, max_poses=3)) == 3
