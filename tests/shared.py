"""Real takes several test modules share: the curated takes of ``../shared/data`` that golden I/O tests
walk, and a real take on a rig of no known family (:func:`unknown_rig`).

``peer_files/`` (other projects' test files, many deliberately odd) and
``bandai_namco_full/`` (an archive to unpack) are not curated takes: the I/O
tests read the former by name, and nothing in ``make test`` needs the latter.
"""

from pathlib import Path

NOT_CURATED = ("peer_files", "bandai_namco_full")


def curated_files(shared_data: Path, pattern: str) -> list[Path]:
    """Every file under ``shared_data`` matching ``pattern`` (recursive), sorted, outside :data:`NOT_CURATED`."""
    return sorted(p for p in shared_data.rglob(pattern) if not set(p.relative_to(shared_data).parts) & set(NOT_CURATED))


#: A real take on a rig of its own (VictorS-67/pybvh's test clip, HumanIK names, Z up; see tests/data/README.md).
PYBVH = Path(__file__).resolve().parent / "data" / "pybvh_test1_zup.bvh"


def unknown_rig(path: Path):
    """The pybvh clip with its joints renamed ``bone0``, ``bone1``, ...: a real take on a rig of no known family,
    which nothing shipped serves; saved as BVH at ``path``, returned as a Motion."""
    import dataclasses

    import mocapkit

    take = mocapkit.load(PYBVH)
    sk = take.skeleton
    odd = dataclasses.replace(sk, joint_names=tuple(f"bone{j}" for j in range(sk.num_joints)))
    take = dataclasses.replace(take, skeleton=odd)
    mocapkit.save(take, path)
    return mocapkit.load(path)
