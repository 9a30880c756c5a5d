"""A C3D of more than 255 points: C3D states their labels and descriptions past the 255th in POINT:LABELS2,
DESCRIPTIONS2 ... (a parameter's dimension is one byte). Read and written back, every point keeps its label,
its samples and its description past the 255th."""

import sys
from pathlib import Path

import numpy as np

import mocapkit
from mocapkit.io.c3d import read_c3d, write_c3d

EB015PR = Path(mocapkit.__file__).parent / "data" / "Eb015pr.c3d"


def _tiled(path: Path, points: int = 300) -> list[str]:
    """A C3D of ``points`` markers (Eb015pr.c3d's 26 tiled, each copy 10 mm further along x) written by ezc3d
    with its LABELS2/DESCRIPTIONS2; returns the labels."""
    import ezc3d

    c = ezc3d.c3d(str(EB015PR))
    pts = c["data"]["points"]
    n = pts.shape[1]
    names = c["parameters"]["POINT"]["LABELS"]["value"][:n]
    copies = -(-points // n)
    labels = [f"{name}_{r}" for r in range(copies) for name in names][:points]
    new = ezc3d.c3d()
    new["parameters"]["POINT"]["RATE"]["value"] = c["parameters"]["POINT"]["RATE"]["value"]
    new["parameters"]["POINT"]["UNITS"]["value"] = c["parameters"]["POINT"]["UNITS"]["value"]
    new["parameters"]["POINT"]["LABELS"]["value"] = labels
    tiled = np.concatenate([pts + np.array([10.0 * r, 0, 0, 0])[:, None, None] for r in range(copies)], axis=1)
    tiled[3] = 1
    new["data"]["points"] = tiled[:, :points, :100]
    # ezc3d states its own blank first 255 descriptions; the points past the 255th get theirs in DESCRIPTIONS2
    new["parameters"]["POINT"]["DESCRIPTIONS2"] = {"type": -1, "description": "", "is_locked": False,
                                                   "value": [f"point {i + 1}" for i in range(255, points)]}
    new.write(str(path))
    return labels


def test_a_c3d_of_300_points_is_written_back_whole(tmp_path, monkeypatch):
    """Before 0.16.0 the writer handed ezc3d one list of 300 POINT:DESCRIPTIONS, which ezc3d stated as 44 (its
    count cut to a byte): ezc3d refused the file written ('The format is not standard'), the ``c3d`` package
    read it with points 256-300 called M256... And the ``c3d`` package's reader (mocapkit's fallback) read no
    LABELS2: a file of 300 points read as 255 labels and 45 made-up names."""
    import ezc3d

    src, out = tmp_path / "m300.c3d", tmp_path / "out.c3d"
    labels = _tiled(src)
    take = read_c3d(src)
    assert list(take.labels) == labels
    write_c3d(take, out)
    back = ezc3d.c3d(str(out))  # raised OSError before
    point = back["parameters"]["POINT"]
    assert point["LABELS"]["value"] + point["LABELS2"]["value"] == labels
    assert point["DESCRIPTIONS2"]["value"] == [f"point {i + 1}" for i in range(255, 300)]
    again = read_c3d(out)
    assert list(again.labels) == labels and np.array_equal(again.positions, take.positions, equal_nan=True)
    for path in (src, out):  # the fallback reader names every point as the file does
        with monkeypatch.context() as m:
            m.setitem(sys.modules, "ezc3d", None)  # `import ezc3d` fails: the fallback reader reads it
            with_package = read_c3d(path)
        assert with_package.reader == "c3d" and list(with_package.labels) == labels
        assert np.array_equal(with_package.positions, take.positions, equal_nan=True)

