"""benchmarks/drift_detection.py's gate_blockers: the cells each gate of the drift rule alone keeps from being evidence."""

import importlib.util
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mocapkit.cleaning.ssa import SSAParams

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def load(name):
    sys.path.insert(0, str(BENCHMARKS))
    try:
        spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCHMARKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(BENCHMARKS))


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
