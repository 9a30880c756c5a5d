"""Marker files other projects ship (``../shared/data/peer_files``), read by mocapkit and by its peers in the same run.

Usage::

    python benchmarks/peer_files.py [--data DIR] [--json]

Every ``.c3d`` and ``.trc`` under ``DIR/peer_files`` (BTKData, ezc3d-testFiles,
py-c3d; 74 C3D and 13 TRC files) is read by ``mocapkit.io.load_markers`` in this
process, and each C3D file by the two peers, ezc3d and the ``c3d`` package, each
in a child process (a peer may crash on a malformed file), giving frames x points
or the error. A file is *read as a peer reads it* when mocapkit gives the same
frames x points as at least one peer that reads it.

The last line of stdout is the shared JSON object of ``benchmarks/_harness.py``.
Figures: files, read, refused, peer_read_mocapkit_refused (a file some peer
reads that mocapkit refuses; target 0), disagree_with_peers (read, but with
frames x points no peer gives; target 0), jumpy (read, median marker step over
5 cm per frame: a data block read from the wrong place; target 0),
zero_gap_files. Baselines: the C3D files ezc3d reads and the ones the ``c3d``
package reads (``read_c3d``: mocapkit's count on the C3D files). Details: the
table, one row per file.
"""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))

import _harness as harness  # noqa: E402

DEFAULT_DATA = REPO.parent / "shared" / "data"

_PEER = r"""
import json, sys, warnings
warnings.simplefilter("ignore")
kind, path = sys.argv[1], sys.argv[2]
try:
    if kind == "ezc3d":
        import ezc3d
        pts = ezc3d.c3d(path)["data"]["points"]
        out = [int(pts.shape[2]), int(pts.shape[1])]
    else:
        import c3d
        with open(path, "rb") as fh:
            r = c3d.Reader(fh)
            frames = [p.shape[0] for _, p, _ in r.read_frames()]
        out = [len(frames), int(frames[0]) if frames else 0]
    print(json.dumps(out))
except Exception as exc:
    print(json.dumps(f"{type(exc).__name__}: {exc}"[:120]))
"""


def peer_read(kind: str, path: Path) -> str | tuple[int, int]:
    """(frames, points) a peer reads from ``path``, or its error (a crash or hang included)."""
    try:
        p = subprocess.run([sys.executable, "-c", _PEER, kind, str(path)], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return "hang (60 s)"
    if p.returncode != 0:
        return f"crash (exit {p.returncode})"
    got = json.loads(p.stdout.strip().splitlines()[-1])
    return tuple(got) if isinstance(got, list) else got


def main() -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    args = ap.parse_args()
    from mocapkit.errors import MocapFormatError
    from mocapkit.io import load_markers

    root = args.data / "peer_files"
    files = sorted(p for p in root.rglob("*") if p.is_file() and p.suffix.lower() in (".c3d", ".trc"))
    rows = []
    for f in files:
        row = {"file": str(f.relative_to(root))}
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ms = load_markers(f)
            step = np.linalg.norm(np.diff(ms.positions, axis=0), axis=-1) * ms.unit_cm
            med = float(np.nanmedian(step)) if np.isfinite(step).any() else None
            row.update(mocapkit=[ms.num_frames, ms.num_markers], reader=ms.reader, units=ms.units,
                       missing=round(float(ms.missing().mean()), 4), zero_gaps=ms.zero_gaps,
                       median_step_cm=None if med is None else round(med, 3))
        except MocapFormatError as exc:
            row.update(mocapkit="refused", reason=exc.reason)
        if f.suffix.lower() == ".c3d":
            for kind in ("ezc3d", "c3d"):
                got = peer_read(kind, f)
                row[kind] = list(got) if isinstance(got, tuple) else got
        rows.append(row)

    def peers_read(r):
        return [tuple(r[k]) for k in ("ezc3d", "c3d") if isinstance(r.get(k), list) and r[k][0] > 0 and r[k][1] > 0]

    read = [r for r in rows if isinstance(r["mocapkit"], list)]
    c3d_rows = [r for r in rows if r["file"].lower().endswith(".c3d")]
    figures = {
        "files": len(rows),
        "read": len(read),
        "refused": len(rows) - len(read),
        "peer_read_mocapkit_refused": sum(1 for r in rows if r["mocapkit"] == "refused" and peers_read(r)),
        "disagree_with_peers": sum(1 for r in read if peers_read(r) and tuple(r["mocapkit"]) not in peers_read(r)),
        "jumpy": sum(1 for r in read if r.get("median_step_cm") is not None and r["median_step_cm"] > 5.0),
        "zero_gap_files": sum(1 for r in read if r.get("zero_gaps")),
        "read_c3d": sum(1 for r in c3d_rows if isinstance(r["mocapkit"], list)),
    }
    baselines = {"read_c3d": sum(1 for r in c3d_rows if peers_read(r))}
    details = {
        "ezc3d_reads": sum(1 for r in c3d_rows if isinstance(r.get("ezc3d"), list) and r["ezc3d"][1] > 0),
        "c3d_package_reads": sum(1 for r in c3d_rows if isinstance(r.get("c3d"), list) and r["c3d"][1] > 0),
        "table": rows,
    }
    targets = {name: {"value": 0, "op": "<=", "of": "figures"}
               for name in ("peer_read_mocapkit_refused", "disagree_with_peers", "jumpy")}
    harness.emit("peer_files", args, figures=figures, baselines=baselines, targets=targets, details=details)


if __name__ == "__main__":
    main()
