"""A C3D written from a TRC or npz that states its modelled points lists them, so that info and clean of it leave
them out of the markers: Plug-in Gait's PiG_Motion-FlatFoot-Full.c3d (shared data), through a TRC or npz."""

from __future__ import annotations

import numpy as np
import pytest

from mocapkit.io import load_markers, save_markers


@pytest.mark.parametrize("via", ["trc", "npz"])
def test_a_c3d_written_from_a_trc_or_npz_keeps_its_modelled_points(via, shared_data, tmp_path, capsys):
    # before, the C3D listed none: info counted 193 markers and clean treated angles, forces and joint centres as such
    from mocapkit.cleaning.markers import clean_markers
    from mocapkit.cli import main

    pig = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    mid = tmp_path / f"pig.{via}"
    save_markers(pig, mid, keep_modelled=True)
    out = tmp_path / "pig.c3d"
    save_markers(load_markers(mid), out)
    back = load_markers(out)
    assert back.modelled_kinds().tolist() == pig.modelled_kinds().tolist()  # angles ... powers, and positions
    assert int(back.modelled().sum()) == 158
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    assert "113 (+80 modelled quantities: angles, forces, moments, powers; not markers)" in capsys.readouterr().out
    res = clean_markers(back)
    cols = back.modelled()
    assert np.array_equal(res.markers.positions[:, cols], back.positions[:, cols], equal_nan=True)
    save_markers(back, tmp_path / "again.c3d")  # written back, the lists are the file's own: nothing added
    again = load_markers(tmp_path / "again.c3d").source.parameters["POINT"]
    for key in ("ANGLES", "FORCES", "MOMENTS", "POWERS", "MODELLED_POSITIONS"):
        assert again[key] == back.source.parameters["POINT"][key]


def test_a_c3d_written_back_keeps_its_parameters_as_they_were(shared_data, tmp_path):
    pig = load_markers(shared_data / "c3d_markers" / "PiG_Motion-FlatFoot-Full.c3d")
    save_markers(pig, tmp_path / "pig.c3d")
    back = load_markers(tmp_path / "pig.c3d")
    assert "MODELLED_POSITIONS" not in back.source.parameters["POINT"]
    assert back.modelled_kinds().tolist() == pig.modelled_kinds().tolist()
