"""benchmarks/drift_detection.py's gate_blockers: the cells each gate of the drift rule alone keeps from being evidence."""

from types import SimpleNamespace

import numpy as np

from mocapkit.cleaning.ssa import SSAParams

from .helpers import load


def test_each_cell_counted_under_the_one_gate_that_stops_it():
    bench = load("drift_detection")
    nan = np.nan
    # the left arm digresses by 4 (drift_z 3) at every frame; frame 1 its partner by 2, frame 2 its parent by 2
    # (both at or over half drift_z), frame 3 the other joints agree with their neighbours only to 10 deg
    change = np.array([[nan, 0, 4, 0, 0], [nan, 0, 4, 2, 0], [nan, 2, 4, 0, 0], [nan, 0, 4, 0, 0]])
    agreement = np.where(np.isnan(change), nan, np.radians(1.0))
    agreement[3, 2] = np.radians(10.0)
    det = SimpleNamespace(params=SSAParams(drift=True), change=change, consistency=change, agreement=agreement,
                          joint_names=("Root", "Spine", "UpperArm_L", "UpperArm_R", "Neck"),
                          parents=np.array([-1, 0, 1, 1, 1]))
    got = bench.gate_blockers(det, np.ones(change.shape, dtype=bool))
    # the neck alone falls short of drift_z at frames 0, 1 and 3 (at frame 2 its parent stops it too); the spine and
    # the right arm are stopped by two gates each (their own level, and the arm as child or partner)
    assert got == {"cells": 16, "pass": 1, "z": 3, "agreement": 1, "others": 0, "partner": 1, "chain": 1}
    assert bench.gate_blockers(det, np.zeros(change.shape, dtype=bool)) == dict.fromkeys(got, 0)
    # a gate the parameters turn off passes every cell: the partner's and the chain's cells pass
    det.params = det.params.replace(drift_partner_ratio=None, drift_chain_ratio=None)
    assert bench.gate_blockers(det, np.ones(change.shape, dtype=bool))["pass"] == 3


def test_paired_drifts_are_those_a_partner_or_chain_neighbour_carries_at_once():
    bench = load("drift_detection")
    from mocapkit.corrupt import ErrorRecord

    names = ("Root", "Spine", "UpperArm_L", "UpperArm_R", "LowerArm_L")
    parents = np.array([-1, 0, 1, 1, 2])

    def rec(joint, start, end):
        return ErrorRecord("smooth_drift", joint, start, end)

    # both arms at once (partners), an arm and its forearm at once (a chain); both arms one after the other, and
    # the left forearm with the right arm (neither partners nor a chain) at once, are single
    assert bench.paired_drifts([rec("UpperArm_L", 0, 30), rec("UpperArm_R", 20, 50)], names, parents).tolist() == [True, True]
    assert bench.paired_drifts([rec("LowerArm_L", 0, 30), rec("UpperArm_L", 29, 50)], names, parents).tolist() == [True, True]
    assert bench.paired_drifts([rec("UpperArm_L", 0, 30), rec("UpperArm_R", 30, 50)], names, parents).tolist() == [False, False]
    assert bench.paired_drifts([rec("LowerArm_L", 0, 30), rec("UpperArm_R", 0, 30)], names, parents).tolist() == [False, False]


def test_drift_recall_scores_single_and_paired_drifts_apart():
    bench = load("drift_detection")
    from mocapkit.corrupt import ErrorRecord

    names = ("Root", "Spine", "UpperArm_L", "UpperArm_R")
    F = 96
    records = [ErrorRecord("smooth_drift", "UpperArm_L", 0, 40), ErrorRecord("smooth_drift", "Spine", 50, 90)]
    truth = np.zeros((F, 4), dtype=bool)
    truth[5:35, 2] = truth[55:85, 1] = True
    ignore = np.zeros_like(truth)
    flags = np.zeros_like(truth)
    flags[5:35, 2] = True  # the arm's drift found, the spine's missed
    got = bench.drift_recall(flags, truth, ignore, records, np.array([False, True]), names, 24.0)
    assert got["recall_single_drifts"][1] == 0 and got["recall_single_drifts"][0] > 0
    assert got["recall_paired_drifts"][0] == 0 and got["recall_paired_drifts"][1] > 0
    assert bench.drift_recall(flags, truth, ignore, records, np.array([False, False]), names, 24.0)[
        "recall_paired_drifts"] == (0, 0)
