"""Control signals: marker files and motions turned into markers in a database skeleton's units and frame."""

import itertools

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.features import parse_up_axis, virtual_markers
from mocapkit.motion import unit_scale_cm
from mocapkit.reconstruct.control import control_markers, parse_use, up_axis_note, up_rotation

AXES = ["x", "y", "z", "-x", "-y", "-z"]


@pytest.mark.parametrize("src,dst", list(itertools.product(AXES, AXES)))
def test_up_rotation_is_proper_and_maps_up_to_up(src, dst):
    P = up_rotation(src, dst)
    assert np.allclose(P @ P.T, np.eye(3)) and np.isclose(np.linalg.det(P), 1.0)
    assert np.allclose(P @ parse_up_axis(src), parse_up_axis(dst))


def test_parse_use_errors():
    assert parse_use(["a=b", "c"]) == [("a", "b"), ("c", "c")]
    for bad in ("", " , ", "=head", "a,a=b"):
        with pytest.raises(ValueError):
            parse_use(bad)


def test_motion_markers_convert_units_between_rigs():
    # the CMU walk's joints read on the HDM05 skeleton: same unit (1/0.45 inch), same Y up -> identical positions
    walk = mocapkit.load(samples.path("12_walk.amc"))
    hdm = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).skeleton
    pos, joints, fps = control_markers(walk, "lhand,head,root=root", hdm)
    assert joints == ["lhand", "head", "root"] and fps == walk.fps
    ref = virtual_markers(walk, ["lhand", "head", "root"]) * unit_scale_cm(walk.skeleton) / unit_scale_cm(hdm)
    np.testing.assert_allclose(pos, ref, rtol=0, atol=1e-12)


def test_c3d_markers_in_skeleton_units_and_y_up():
    ms = mocapkit.load(samples.path("Eb015pr.c3d"))
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).skeleton
    label = ms.labels[0]
    pos, joints, fps = control_markers(ms, f"{label}=head", sk)
    assert pos.shape == (ms.num_frames, 1, 3) and fps == ms.fps
    raw = ms.positions[:, 0] * ms.unit_cm / unit_scale_cm(sk)
    ok = np.isfinite(raw).all(axis=1)
    # Z-up (x, y, z) -> Y-up (y, z, x): the file's height becomes the second coordinate
    np.testing.assert_allclose(pos[ok, 0, 1], raw[ok, 2])
    np.testing.assert_allclose(pos[ok, 0, 0], raw[ok, 1])
    assert np.isnan(pos[~ok]).all()


def test_bad_names_are_named():
    ms = mocapkit.load(samples.path("Eb015pr.c3d"))
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).skeleton
    with pytest.raises(ValueError, match="no marker"):
        control_markers(ms, "NOPE=head", sk)
    with pytest.raises(ValueError, match="unknown joint"):
        control_markers(ms, f"{ms.labels[0]}=elbowz", sk)


def test_a_bare_label_names_the_subject_prefixed_one():
    # Vicon Nexus writes "Subject:LFHD"; --use LFHD=head names it when one subject has it, and refuses two
    import dataclasses

    ms = mocapkit.load(samples.path("Eb015pr.c3d"))
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).skeleton
    a, b = ms.labels[0], ms.labels[1]
    prefixed = dataclasses.replace(ms, labels=tuple(f"Bastian:{x}" for x in ms.labels))
    got, _, _ = control_markers(prefixed, f"{a}=head,{b}=lhand", sk)
    want, _, _ = control_markers(ms, f"{a}=head,{b}=lhand", sk)
    assert np.array_equal(got, want, equal_nan=True)
    two = dataclasses.replace(ms, labels=(f"Bastian:{a}", f"Other:{a}") + tuple(ms.labels[2:]))
    with pytest.raises(ValueError, match=f"marker {a} is Bastian:{a} or Other:{a} in the file; give the full label"):
        control_markers(two, f"{a}=head", sk)


def test_a_marker_never_seen_is_named_in_a_warning_from_python():
    """The command line leaves it out with a note; a Python call says the same in a UserWarning."""
    import warnings

    import numpy as np

    from mocapkit.reconstruct.control import warn_unseen

    x = np.zeros((5, 3, 3))
    x[:, 1] = np.nan
    with pytest.warns(UserWarning, match=r"marker\(s\) on rhand never seen in any frame: left out"):
        assert warn_unseen(x, ["lhand", "rhand", "root"]) == ["rhand"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert warn_unseen(np.zeros((5, 3, 3)), ["lhand", "rhand", "root"]) == []


def test_a_marker_file_read_with_the_wrong_vertical_is_said():
    """Trial: an OpenSim-style Y-up TRC (the shared data's T.trc) given to `reconstruct --markers/--ssg` without
    --up-axis was read Z-up and the body reconstructed lying on its side, with no note at all. CMU 85_02.c3d
    (Z-up) as a Y-up file (y, z, x): said, with the axis to pass; read with that axis, or the file itself, not."""
    import dataclasses
    from pathlib import Path

    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).skeleton
    use = "LFHD=head,LWRA=lhand,RWRA=rhand,LANK=lfoot,RANK=rfoot,LFWT=root"

    def note(markers, up=None):
        return up_axis_note(control_markers(markers, use, sk, up_axis=up)[0], [j for _, j in parse_use(use)], sk, up)

    assert note(take) == "" and note(take, "z") == ""
    y_up = dataclasses.replace(take, positions=take.positions[..., [1, 2, 0]])
    assert note(y_up) == ("the markers stand along the file's y axis, not z (the default, the C3D convention): the "
                          "body was reconstructed lying on its side; pass --up-axis y")
    assert note(y_up, "y") == ""
    assert note(y_up, "-y").endswith("not -y: the body was reconstructed upside down; pass --up-axis y")
    assert note(take, "x").endswith("not x: the body was reconstructed lying on its side; pass --up-axis z")


def test_control_markers_warns_from_python_where_the_file_stands_along_another_axis():
    """Trial T1: a Y-up TRC through control_markers and markers.reconstruct in Python came back lying on its side
    with no word; the command printed up_axis_note. control_markers now says it as a UserWarning (the command takes
    it from there), naming Python's argument."""
    import dataclasses
    import warnings
    from pathlib import Path

    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "85_02.c3d")[:120]
    sk = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).skeleton
    use = "LFHD=head,LWRA=lhand,RWRA=rhand,LANK=lfoot,RANK=rfoot,LFWT=root"
    y_up = dataclasses.replace(take, positions=take.positions[..., [1, 2, 0]])
    with pytest.warns(UserWarning, match=r"^the markers stand along the file's y axis, not z \(the default, the C3D "
                                         r"convention\): the body was reconstructed lying on its side; pass "
                                         r"up_axis='y'$"):
        control_markers(y_up, use, sk)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        control_markers(y_up, use, sk, up_axis="y")
        control_markers(take, use, sk)
