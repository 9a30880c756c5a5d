"""Sparse reconstruction by self-similarity (Aristidou et al. 2018, Fig. 8)."""

import dataclasses

import numpy as np

import mocapkit
from mocapkit import rotations as R
from mocapkit.reconstruct.sparse import reconstruct_sparse


def test_sparse_reconstruction_from_nine_joints():
    """Fig. 8: nine joints of a sneak take, the other take of the actor as context."""
    a = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    b = mocapkit.load(mocapkit.samples.path("HDM_bk_sneak2StepsLStart_005_120.amc"))
    nine = ["lowerneck", "lhumerus", "rhumerus", "lradius", "rradius", "lfemur", "rfemur", "ltibia", "rtibia"]
    sparse = np.array(a.rotations)
    known = [a.skeleton.index(n) for n in nine]
    unknown = [j for j in range(a.num_joints) if j not in known and j != 0]
    sparse[:, unknown] = np.nan
    out = reconstruct_sparse(dataclasses.replace(a, rotations=sparse), nine, [b])
    assert np.array_equal(out.rotations[:, known], a.rotations[:, known])
    assert np.isfinite(out.rotations).all()
    err = np.degrees(R.geodesic_angle(out.rotations[:, unknown], a.rotations[:, unknown]))
    rest = np.degrees(R.geodesic_angle(np.broadcast_to(R.identity(), a.rotations[:, unknown].shape), a.rotations[:, unknown]))
    moving = rest.mean(axis=0) > 5
    assert err[:, moving].mean() < 0.5 * rest[:, moving].mean()
