"""The HDM05 scenarios the reconstruction benchmarks run on (Tautges 2012, sec. 3.6.1; Krüger et al. 2010, sec. 5.2).

The knowledge base is HDM05 ASF/AMC clips of ``../shared/data/hdm05_asfamc``
(5 actors bd, bk, dg, mm, tr; 11 motion classes; 120 fps, resampled here). The
test clips are never in the database:

* scenario "other actors" (thesis scenario 2/3): the database holds the other
  four actors, the test clips are all clips of the held-out actor;
* scenario "same actor" (thesis scenario 1): the database also holds the test
  actor's other repetitions of the class, but never the test clip itself.

:func:`database` caches what it builds under ``benchmarks/.cache`` keyed by the
file list, frame rate and features.
"""

from __future__ import annotations

import re
from pathlib import Path

from _corpus import DEFAULT_DATA, _cached  # noqa: F401  (also puts src/ on sys.path)

from mocapkit.database import MotionDatabase  # noqa: E402

HDM05 = DEFAULT_DATA / "hdm05_asfamc"
ACTORS = ("bd", "bk", "dg", "mm", "tr")
LOCOMOTION = ("jogLeftCircle4StepsRstart", "sneak2StepsLStart")
_NAME = re.compile(r"HDM_(?P<actor>[a-z]+)_(?P<cls>.+)_(?P<rep>\d+)_120\.amc$")


def parse(path: Path) -> tuple[str, str, int]:
    """(actor, class, repetition) of an HDM05 file name."""
    m = _NAME.match(Path(path).name)
    if m is None:
        raise ValueError(f"{path}: not an HDM05 clip name")
    return m["actor"], m["cls"], int(m["rep"])


def clips(actors=ACTORS, classes=None, data: Path = HDM05) -> list[Path]:
    """HDM05 clip paths of the given actors and classes (all classes when None), sorted."""
    paths = sorted(Path(data).glob("HDM_*_120.amc"))
    if not paths:
        raise SystemExit(f"no HDM05 clips under {data}; pass --data")
    out = []
    for p in paths:
        actor, cls, _ = parse(p)
        if actor in actors and (classes is None or cls in classes):
            out.append(p)
    return out


def database(paths, fps: float, features=("F15",)) -> MotionDatabase:
    """A cached MotionDatabase of ``paths`` at ``fps``."""
    paths = sorted(Path(p) for p in paths)
    key = {"kind": "hdm05", "files": [p.name for p in paths], "features": list(features), "fps": float(fps), "v": 1}
    return _cached(key, lambda: MotionDatabase.build(paths, fps=fps, features=features, progress=True))


def scenario(test_actor: str = "mm", classes=None, same_actor: bool = False, data: Path = HDM05):
    """Database paths and test paths of one scenario.

    Returns ``(db_paths, test_paths)``: with ``same_actor=False`` the database
    has every other actor's clips of ``classes`` and the tests are the test
    actor's; with ``same_actor=True`` each test clip's database must drop only
    that clip, so ``db_paths`` is every clip of ``classes`` and callers remove
    the test clip (:func:`without`).
    """
    tests = clips((test_actor,), classes, data)
    others = tuple(a for a in ACTORS if a != test_actor)
    db = clips(ACTORS if same_actor else others, classes, data)
    return db, tests


def without(paths, clip: Path) -> list[Path]:
    return [p for p in paths if Path(p).name != Path(clip).name]
