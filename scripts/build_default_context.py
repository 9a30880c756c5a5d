"""Rebuild the default context bundled with mocapkit (``src/mocapkit/data/context/``).

The default context is what ``mocapkit clean`` and ``mocapkit detect`` compare
a take with when no ``--context`` is given (:mod:`mocapkit.context`): a small
motion database of common human motion, so that a take of ordinary movement
has neighbours to be judged against (Aristidou et al. 2018, section 3.3).

It is made of real takes of the project's data set (``../shared/data``,
README there), chosen by rule so the build is reproducible:

* HDM05 (Müller et al. 2007, Univ. Bonn, free for research): for each of the
  11 motion classes (jog in a circle, sneak, grab high, deposit on the floor,
  rotate arms, throw, kick, elbow to knee, squat, hop; lie down left out: long
  and rare), the first ``--per-class`` takes of actors bd, bk, dg and tr in
  name order. Actor ``mm`` is left out (the coverage benchmark measures on
  it), and so is every take an existing benchmark uses as a query (the first
  ``bd``/``bk`` jog and ``bk``/``dg`` sneak takes).
* CMU (mocap.cs.cmu.edu, free for research and commercial use): 01_01
  (playground: forward jumps, turning around). Subject 131 and the CMU takes the
  benchmarks query (12, 11_01, the dances, the zombie walk) are left out.

Every take is resampled to the analysis rate (24 fps) and stored on the
Acclaim skeleton of the first take; the database is written with
:meth:`MotionDatabase.save` (atomic). Run from the repository root::

    python scripts/build_default_context.py --data ../shared/data --overwrite
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

from mocapkit.context import build_context, default_context_path  # noqa: E402

CLASSES = ("jogLeftCircle", "sneak2Steps", "grabHighR", "depositFloorR", "rotateArmsBothBackward", "throwBasketball",
           "kickLFront", "elbowToKnee", "squat1Reps", "hopBothLegs")
ACTORS = ("bd", "bk", "dg", "tr")
#: Takes the existing benchmarks use as queries (ssa_detection, ssa_repair, ssa_speed, clean_takes).
BENCHMARK_QUERIES = ("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bk_jogLeftCircle4StepsRstart_003_120.amc",
                     "HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_dg_sneak2StepsLStart_007_120.amc")
CMU = ("01_01.amc",)


def select(data: Path, per_class: int) -> list[Path]:
    """The takes of the default context, in a fixed order."""
    hdm = sorted((data / "hdm05_asfamc").glob("HDM_*_120.amc"))
    out = []
    for cls in CLASSES:
        pool = [p for p in hdm if f"_{cls}" in p.name and p.name.split("_")[1] in ACTORS and p.name not in BENCHMARK_QUERIES]
        chosen, actors = [], set()
        for p in pool:  # one take per actor first, so the class is seen on several bodies
            if p.name.split("_")[1] not in actors:
                chosen.append(p)
                actors.add(p.name.split("_")[1])
        out += chosen[:per_class]
    return out + [data / "cmu_asfamc" / n for n in CMU]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data", help="the project's data set")
    ap.add_argument("--out", type=Path, default=default_context_path(), help="database folder to write")
    ap.add_argument("--per-class", type=int, default=3, help="HDM05 takes per motion class (distinct actors)")
    ap.add_argument("--overwrite", action="store_true", help="replace an existing database folder")
    args = ap.parse_args(argv)
    files = select(args.data, args.per_class)
    missing = [p for p in files if not p.is_file()]
    if missing:
        print(f"missing takes: {', '.join(map(str, missing))}", file=sys.stderr)
        return 1
    db, notes = build_context(files, progress=True, label="the bundled default context")
    db.info.pop("notes", None)
    db.info["sources"] = [p.name for p in files]
    db.save(args.out, overwrite=args.overwrite, inputs=files)
    for n in notes:
        print(n, file=sys.stderr)
    size = sum(f.stat().st_size for f in args.out.rglob("*") if f.is_file())
    print(f"wrote {args.out}: {db.num_clips} clips, {db.duration:.1f} s at {db.fps:g} fps, {size / 2**20:.2f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
