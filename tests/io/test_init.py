"""``mocapkit.io``'s entry points: ``load`` and ``load_markers`` given what is not one file."""

import pytest

from mocapkit.errors import MocapFormatError
from mocapkit.io import load, load_markers

from .bounded import refusal_of_load


@pytest.mark.parametrize("name", ["takes", "takes.c3d"])
def test_a_folder_is_refused_as_a_folder(tmp_path, name):
    # `mocapkit info FOLDER` said "unknown suffix '(none)' for reading"
    folder = tmp_path / name
    folder.mkdir()
    assert refusal_of_load(folder) == (f"{folder}: a folder, not a file: give one of the files in it "
                                       "(.amc, .bvh, .c3d, .npz, .trc)")
    with pytest.raises(MocapFormatError) as exc:
        load_markers(folder)
    assert str(exc.value) == f"{folder}: a folder, not a file: give one of the files in it (.c3d, .npz, .trc)"
    with pytest.raises(MocapFormatError, match="no such file"):
        load(folder / "missing.bvh")


def test_save_writes_a_marker_set_by_its_suffix(tmp_path):
    # `mocapkit.save(markers, "x.c3d")` said "unknown suffix '.c3d' for writing; known: .amc, .bvh, .npz"
    import numpy as np

    from mocapkit import samples
    from mocapkit.io import save

    ms = load(samples.path("Eb015pr.c3d"))
    for suffix in (".c3d", ".trc", ".npz"):
        back = load(save(ms, tmp_path / f"m{suffix}"))
        assert back.labels == ms.labels and np.allclose(back.positions, ms.positions, equal_nan=True, atol=1e-3)
