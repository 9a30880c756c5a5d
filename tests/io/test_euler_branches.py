"""Written Euler curves are continuous, as a graph editor shows them (BVH and AMC, from a source file or fresh):
a changed cell takes the triple (whole turns, the middle angle's two branches) nearest its unchanged neighbours,
never the branch of the broken value it replaces; a file with no source is Euler-filtered frame to frame. Unchanged
cells keep their text (the golden tests in test_bvh / test_amc_writer hold that too)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt as C
from mocapkit import io
from mocapkit import rotations as R
from mocapkit.io.amc_writer import write_amc
from mocapkit.io.asfamc import amc_dofs, read_amc
from mocapkit.io.bvh import read_bvh, write_bvh
from mocapkit.motion import Motion, Skeleton

DATA = Path(mocapkit.__file__).parent / "data"
TAKE = DATA / "131_01.bvh"  # CMU 131_01 (the take of the report: RThumb, LeftToe)
WALK, WALK_ASF = DATA / "12_walk.amc", DATA / "12.asf"
START_01_01 = Path(__file__).resolve().parents[1] / "data" / "cmu_01_01_start.bvh"


def _bvh_table(path: Path) -> tuple[list[str], np.ndarray]:
    """(joint name per column, the (F, C) numbers) of a BVH, parsed independently of mocapkit."""
    text = path.read_text()
    head, motion = text.split("MOTION", 1)
    cols, joint = [], None
    for line in head.splitlines():
        t = line.split()
        if t and t[0] in ("ROOT", "JOINT"):
            joint = t[1]
        if t and t[0] == "CHANNELS":
            cols += [(joint, c) for c in t[2:]]
    rows = [ln for ln in motion.splitlines()[3:] if ln.strip()]
    return cols, np.array([[float(v) for v in ln.split()] for ln in rows])


def _with_column(path: Path, out: Path, col: int, frames, fn) -> None:
    """Copy BVH ``path`` to ``out`` with column ``col`` of ``frames`` (data line indices) replaced by ``fn(value)``."""
    lines = path.read_text().splitlines(keepends=True)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    for f in frames:
        tok = lines[at + f].split()
        tok[col] = repr(fn(float(tok[col])))
        lines[at + f] = " ".join(tok) + "\n"
    out.write_text("".join(lines))


def _rot_cols(cols, joint):
    return [k for k, (j, c) in enumerate(cols) if j == joint and c.endswith("rotation")]


def test_a_repaired_run_is_written_on_its_neighbours_branch_not_the_broken_values(tmp_path):
    """The report's RThumb case: broken cells read 200 deg off; the repair brings the right rotation back, and it
    is written next to its neighbours (before: within 180 deg of the broken value, 360 deg off them)."""
    cols, good = _bvh_table(TAKE)
    col = _rot_cols(cols, "LeftElbow")[0]
    broken = tmp_path / "broken.bvh"
    _with_column(TAKE, broken, col, range(300, 310), lambda v: v + 200.0)
    out = tmp_path / "repaired.bvh"
    write_bvh(read_bvh(TAKE), out, like=broken)  # the repair: the file's own rotations again
    _, got = _bvh_table(out)
    np.testing.assert_allclose(got[:, col], good[:, col], atol=1e-5)
    assert np.abs(np.diff(got[295:315, col])).max() < 30.0


def test_a_file_on_the_other_branch_stays_there_where_edited(tmp_path):
    """A joint the file writes as the equivalent (a+180, 180-b, c+180) triples, continuous; a small edit (as denoise
    makes) is written on that branch (before: on the [-90, 90] branch, 180 deg jumps at each edge)."""
    cols, good = _bvh_table(TAKE)
    k = _rot_cols(cols, "LeftShoulder")
    flipped = tmp_path / "flipped.bvh"
    lines = TAKE.read_text().splitlines(keepends=True)
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    for f in range(good.shape[0]):
        tok = lines[at + f].split()
        a, b, c = (float(tok[i]) for i in k)
        tok[k[0]], tok[k[1]], tok[k[2]] = repr(a + 180.0), repr(180.0 - b), repr(c + 180.0)
        lines[at + f] = " ".join(tok) + "\n"
    flipped.write_text("".join(lines))
    m = read_bvh(flipped)
    j = m.skeleton.joint_names.index("LeftShoulder")
    rot = np.array(m.rotations)
    rot[100:160, j] = R.quaternion_multiply(rot[100:160, j], R.euler_to_quaternion([2.0, -1.0, 1.5], "ZYX"))
    out = tmp_path / "edited.bvh"
    write_bvh(dataclasses.replace(m, rotations=rot), out, like=flipped)
    _, was = _bvh_table(flipped)
    _, got = _bvh_table(out)
    assert np.abs(got[:, k] - was[:, k]).max() < 10.0
    assert np.abs(np.diff(got[:, k], axis=0)).max() < 30.0
    back = read_bvh(out)
    assert np.degrees(R.geodesic_angle(back.rotations[:, j], rot[:, j])).max() < 1e-4


def _gimbal_path(F: int) -> np.ndarray:
    """ZYX angles (F, 3) of a continuous rotation whose middle angle goes 40 -> 140 deg."""
    return np.stack([np.linspace(10, 50, F), np.linspace(40.3, 140, F), np.linspace(-30, 30, F)], axis=1)


def test_a_fresh_bvh_is_continuous_through_gimbal_lock(tmp_path):
    """No source text (convert, npz -> bvh): every frame the triple nearest the one before (before: the middle
    angle folded back at 90 deg and the other two jumped 180 deg)."""
    F = 101
    sk = Skeleton(("root", "arm"), [-1, 0], [[0, 0, 0], [0, 1, 0]],
                  channels=(("Xposition", "Yposition", "Zposition"), ("Zrotation", "Yrotation", "Xrotation")))
    path = _gimbal_path(F)
    rot = np.stack([np.tile([1.0, 0, 0, 0], (F, 1)), R.euler_to_quaternion(path, "ZYX")], axis=1)
    out = tmp_path / "arm.bvh"
    write_bvh(Motion(sk, rot, np.zeros((F, 3)), 60.0, "arm"), out)
    _, got = _bvh_table(out)
    np.testing.assert_allclose(got[:, 3:], path, atol=1e-5)


def test_npz_round_trip_of_a_cmu_start_gives_its_angles_back(tmp_path):
    """CMU 01_01's first frames through npz and back: the same angles (a T-pose frame 0 first, 136 deg away from
    frame 1, does not carry the next frames onto the other branch)."""
    m = read_bvh(START_01_01)
    npz = tmp_path / "start.npz"
    io.save(m, npz)
    out = tmp_path / "back.bvh"
    io.save(io.load(npz), out)
    _, was = _bvh_table(START_01_01)
    _, got = _bvh_table(out)
    np.testing.assert_allclose(got, was, atol=2e-4)


def test_a_corrupt_flip_is_not_written_alternating(tmp_path):
    """`mocapkit corrupt --kind errors --seed 3` on 131_01: LeftToe flipped 180 deg about its bone over frames
    408-454; written -175.9, 184.2, -175.8, ... frame to frame before (each near the clean value's branch, a tie)."""
    m = read_bvh(TAKE)
    bad, mask = C.corrupt(m, "errors", seed=3)[:2]
    out = tmp_path / "err.bvh"
    io.save(bad, out, like=TAKE)
    cols, was = _bvh_table(TAKE)
    _, got = _bvh_table(out)
    rot = [k for k, (_, c) in enumerate(cols) if c.endswith("rotation")]
    new_jumps = (np.abs(np.diff(got[:, rot], axis=0)) > 300) & ~(np.abs(np.diff(was[:, rot], axis=0)) > 300)
    toe = m.skeleton.joint_names.index("LeftToe")
    assert mask[408:455, toe].all()
    assert not new_jumps.any()


# -- AMC ------------------------------------------------------------------------------


def _amc_rows(path: Path, bone: str) -> np.ndarray:
    """The numbers of ``bone``'s line in every frame of an AMC, parsed independently."""
    return np.array([[float(v) for v in ln.split()[1:]] for ln in path.read_text().splitlines()
                     if ln.split()[:1] == [bone]])


def _amc_with(path: Path, out: Path, bone: str, frames, fn) -> None:
    """Copy AMC ``path`` to ``out`` with ``bone``'s line of ``frames`` (0-based) rewritten as ``fn(numbers)``."""
    lines, seen = [], -1
    for ln in path.read_text().splitlines(keepends=True):
        if ln.split()[:1] == [bone]:
            seen += 1
            if seen in frames:
                ln = bone + " " + " ".join(repr(float(v)) for v in fn(np.array([float(x) for x in ln.split()[1:]]))) + "\n"
        lines.append(ln)
    out.write_text("".join(lines))


def test_a_repaired_amc_run_is_written_on_its_neighbours_branch(tmp_path):
    """backflip's lhand/lhumerus case: broken values 200 deg off on a 3-dof and a 2-dof bone; the repaired
    rotations are written next to the unchanged frames (before: -7.3, -368.7, -10.2, -371.5)."""
    m = read_amc(WALK, WALK_ASF)
    broken = tmp_path / "broken.amc"
    _amc_with(WALK, tmp_path / "half.amc", "lhumerus", range(40, 50), lambda v: v + [0.0, 0.0, 200.0])
    _amc_with(tmp_path / "half.amc", broken, "lhand", range(60, 66), lambda v: v + [200.0, 0.0])
    out = tmp_path / "repaired.amc"
    io.save(m, out, like=broken, asf=WALK_ASF)
    for bone in ("lhumerus", "lhand"):
        np.testing.assert_allclose(_amc_rows(out, bone), _amc_rows(WALK, bone), atol=1e-4)
    was, got = broken.read_text().splitlines(), out.read_text().splitlines()  # written like the broken file
    assert len(was) == len(got) and sum(a != b for a, b in zip(was, got)) == 16


def test_a_fresh_amc_is_continuous_through_gimbal_lock(tmp_path):
    """AMC written with no source (the root turning through ry = 90, as backflip's root does): continuous dofs."""
    m = read_amc(WALK, WALK_ASF)
    F = m.num_frames
    xyz = _gimbal_path(F)[:, ::-1]  # rx ry rz, extrinsic xyz: the same matrix as intrinsic ZYX of the reversed
    rot = np.array(m.rotations)
    c = m.skeleton.axes[0]
    rot[:, 0] = R.quaternion_multiply(R.quaternion_multiply(c, R.euler_to_quaternion(xyz, "xyz")),
                                      R.quaternion_conjugate(c))
    out = tmp_path / "turning.amc"
    write_amc(dataclasses.replace(m, rotations=rot), out)
    assert amc_dofs(m.skeleton)[0][3:] == ("rx", "ry", "rz")
    np.testing.assert_allclose(_amc_rows(out, "root")[:, 3:], xyz, atol=1e-5)
    bvh = tmp_path / "turning.bvh"  # convert backflip.amc -> .bvh: the BVH root likewise
    write_bvh(dataclasses.replace(m, rotations=rot), bvh)
    cols, got = _bvh_table(bvh)
    assert np.abs(np.diff(got[:, _rot_cols(cols, "root")], axis=0)).max() < 10.0


def test_two_dof_bones_take_whole_turns_only(tmp_path):
    """lhand (rx rz) turning far past 90 deg about rx: no equivalent-triple trick without a third dof (it would
    write another rotation), whole turns keep it continuous, and it reads back the same."""
    m = read_amc(WALK, WALK_ASF)
    j = m.skeleton.joint_names.index("lhand")
    F = m.num_frames
    xz = np.stack([np.linspace(-170, 250, F), np.linspace(-20, 20, F)], axis=1)
    c = m.skeleton.axes[j]
    rot = np.array(m.rotations)
    rot[:, j] = R.quaternion_multiply(R.quaternion_multiply(c, R.euler_to_quaternion(xz, "xz")),
                                      R.quaternion_conjugate(c))
    out = tmp_path / "hand.amc"
    write_amc(dataclasses.replace(m, rotations=rot), out)
    np.testing.assert_allclose(_amc_rows(out, "lhand"), xz, atol=1e-5)
    back = read_amc(out, WALK_ASF)
    assert np.degrees(R.geodesic_angle(back.rotations[:, j], rot[:, j])).max() < 1e-4


def test_a_root_that_only_moved_keeps_its_angles_text(tmp_path):
    """A changed root position rewrites the root's position numbers only: its unchanged angles keep the file's text
    (before: the whole line was reformatted, '-2.48972' -> '-2.489720')."""
    m = read_amc(WALK, WALK_ASF)
    root = np.array(m.root_positions)
    root[5, 0] += 1.0
    out = tmp_path / "moved.amc"
    io.save(dataclasses.replace(m, root_positions=root), out, like=WALK)
    was = [ln for ln in WALK.read_text().splitlines() if ln.startswith("root ")]
    got = [ln for ln in out.read_text().splitlines() if ln.startswith("root ")]
    assert [i for i, (a, b) in enumerate(zip(was, got)) if a != b] == [5]
    assert got[5].split()[4:] == was[5].split()[4:]
    assert float(got[5].split()[1]) == float(was[5].split()[1]) + 1.0


BANDAI_TAKE = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"  # Bandai Namco game rig


def _rotation_columns(cols):
    return np.array([k for k, (_, c) in enumerate(cols) if c.endswith("rotation")])


def test_a_bvh_written_from_an_npz_made_from_a_bvh_keeps_the_bvhs_numbers_where_nothing_changed(tmp_path):
    """The trial's `mocapkit corrupt take.bvh g.npz --kind gaps` then `mocapkit fill g.npz -o f.bvh`: the cells the
    fill did not touch came back on another Euler branch (the Bandai hips' 179.11 as -180.89, a spine at 150/90/-147
    as -30/90/33): the .npz kept quaternions only. It keeps the file's numbers now, and they come back."""
    take = read_bvh(BANDAI_TAKE)
    holed, mask = C.gaps(take, start_prob=0.01, seed=3)
    g = tmp_path / "g.npz"
    io.save(holed, g, like=BANDAI_TAKE)
    from mocapkit.cleaning.gapfill import fill_motion

    filled = fill_motion(io.load(g), method="linear")
    out = tmp_path / "f.bvh"
    io.save(filled, out, like=g)
    cols, src = _bvh_table(BANDAI_TAKE)
    _, got = _bvh_table(out)
    rot = _rotation_columns(cols)
    joint_of = np.array([take.skeleton.index(cols[k][0]) for k in rot])
    kept = ~mask[:, joint_of]  # (F, rotation columns): cells the fill did not touch
    assert kept.sum() > 0.8 * kept.size and (~kept).any()
    np.testing.assert_allclose(got[:, rot][kept], src[:, rot][kept], atol=1e-6)
    # the filled cells on the branch nearest the file's numbers of those cells (the gap's own were the file's)
    far = np.abs(got[:, rot] - src[:, rot]) > 90.0
    assert not far[~kept].any()


def test_a_changed_cell_near_the_files_rotation_is_written_nearest_the_files_numbers(tmp_path):
    """The trial's noisy BVHs from `mocapkit corrupt --kind noise`: a joint near gimbal lock (the Bandai spine at
    Y = 90) or past 180 degrees was chained frame to frame off the file's curve, so a few degrees of noise read as
    180 degree jumps against the source. Each changed cell within 90 degrees of the file's rotation is now the
    triple nearest the file's numbers of that cell."""
    take = read_bvh(BANDAI_TAKE)
    noisy, _ = C.angular_noise(take, 0.1, seed=0)
    out = tmp_path / "n.bvh"
    write_bvh(noisy, out, like=BANDAI_TAKE)
    cols, src = _bvh_table(BANDAI_TAKE)
    _, got = _bvh_table(out)
    for joint in take.skeleton.joint_names:
        k = _rot_cols(cols, joint)
        if len(k) != 3:
            continue
        order = "".join(cols[i][1][0] for i in k)
        a, b = src[:, k], got[:, k]
        turn = np.degrees(R.geodesic_angle(R.euler_to_quaternion(a, order), R.euler_to_quaternion(b, order)))
        near = turn < 90.0
        np.testing.assert_allclose(b[near], _nearest_triple(b[near], a[near]), atol=1e-5, err_msg=joint)


def _nearest_triple(b, a):
    """Of each row of ``b``'s equivalent triples (whole turns of each angle, the other middle-angle branch of a
    Tait-Bryan order), the one with the least sum of absolute differences from ``a``'s row: cell by cell."""
    out = []
    for x, ref in zip(b, a):
        cands = []
        for t in (x, np.array([x[0] + 180.0, 180.0 - x[1], x[2] + 180.0])):
            for turns in np.array(np.meshgrid(*[np.arange(-3, 4)] * 3)).T.reshape(-1, 3):
                cands.append(t + 360.0 * turns)
        cands = np.array(cands)
        out.append(cands[np.argmin(np.abs(cands - ref).sum(axis=1))])
    return np.array(out).reshape(b.shape)


def _hinged(tmp_path):
    """The bundled CMU start with LeftLeg declared as a hinge, ``CHANNELS 1 Xrotation`` (its X angle kept)."""
    lines = START_01_01.read_text().splitlines()
    at = [i for i, t in enumerate(lines) if "CHANNELS" in t][3]  # LeftLeg: columns 12-14 (Z Y X)
    lines[at] = lines[at].replace("CHANNELS 3 Zrotation Yrotation Xrotation", "CHANNELS 1 Xrotation")
    body = lines.index(next(t for t in lines if t.startswith("Frame Time"))) + 1
    for i in range(body, len(lines)):
        v = lines[i].split()
        lines[i] = " ".join(v[:12] + v[14:])
    path = tmp_path / "hinged.bvh"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_bvh_hinge_holds_only_its_axis(tmp_path):
    """A joint declaring one rotation channel holds only its angle about that axis: bvh_held_rotations is the
    rotation the file reads back as (a 30 deg turn about Z is gone), every other joint as given."""
    import dataclasses

    import mocapkit
    from mocapkit import rotations as R
    from mocapkit.io.euler_branches import bvh_held_rotations, partial_rotation_joints

    m = mocapkit.load(_hinged(tmp_path))
    j = m.skeleton.joint_names.index("LeftLeg")
    assert partial_rotation_joints(m.skeleton) == [j]
    rot = np.array(m.rotations)
    rot[10:20, j] = R.quaternion_multiply(rot[10:20, j], R.euler_to_quaternion(np.array([0.0, 0.0, 30.0]), "XYZ"))
    turned = dataclasses.replace(m, rotations=rot)
    with pytest.warns(UserWarning, match="10 rotations of LeftLeg .* up to 30 deg"):  # said, not silently dropped
        mocapkit.save(turned, tmp_path / "turned.bvh")
    back = np.array(mocapkit.load(tmp_path / "turned.bvh").rotations)
    held = bvh_held_rotations(turned)
    assert np.allclose(np.abs(np.sum(held * back, axis=-1)), 1.0, rtol=0, atol=1e-12)
    assert np.abs(np.sum(held[10:20, j] * rot[10:20, j], axis=-1)).min() < 0.99
    np.testing.assert_array_equal(np.delete(held, j, axis=1), np.delete(rot, j, axis=1))


def test_a_cleaning_written_to_a_bvh_hinge_records_what_the_file_holds(tmp_path):
    """Before 0.15.0, `clean` to a BVH with a one-channel joint recorded the denoised hinge's cleaned rotation
    (off its axis by up to 0.41 deg on this take with noise) while the file held only its X angle: the record,
    the report and the decisions said what the file did not hold. Now each changed cell's cleaned rotation is
    the one the file reads back as (as for an AMC bone of fewer dofs)."""
    import mocapkit
    from mocapkit.batch import clean_file
    from mocapkit.corrupt import corrupt

    m = mocapkit.load(_hinged(tmp_path))
    noisy = tmp_path / "noisy.bvh"
    mocapkit.save(corrupt(m, "noise", seed=3)[0], noisy)
    out = tmp_path / "clean.bvh"
    clean_file(noisy, out, steps=("denoise",))
    z = np.load(tmp_path / "clean.clean.npz")
    j = m.skeleton.joint_names.index("LeftLeg")
    assert z["changed"][:, j].any()
    written = np.array(mocapkit.load(out).rotations)[z["changed"]]
    assert np.allclose(np.abs(np.sum(z["cleaned_rotations"] * written, axis=-1)), 1.0, rtol=0, atol=1e-9)


def _noisy_hinged(tmp_path):
    import mocapkit
    from mocapkit.corrupt import corrupt

    m = mocapkit.load(_hinged(tmp_path))
    noisy = tmp_path / "noisy.bvh"
    mocapkit.save(corrupt(m, "noise", seed=3)[0], noisy)
    return m, noisy


def test_saving_a_cleaned_take_to_a_bvh_hinge_says_what_it_drops(tmp_path):
    """Before 0.15.0, ``mocapkit.save(mocapkit.clean(...).motion, "x.bvh")`` dropped the denoised hinge's turn about
    other axes without a word (60 rotations of LeftLeg, up to 0.41 deg, on this take with noise); now a warning
    says so, and a take put on the axes first (:func:`bvh_written`, as the commands do) saves without one, changing
    only those cells."""
    import warnings

    import mocapkit
    from mocapkit.io.euler_branches import bvh_written

    m, noisy = _noisy_hinged(tmp_path)
    res = mocapkit.clean(noisy, steps=("denoise",))
    with pytest.warns(UserWarning, match=r"60 rotations of LeftLeg .* up to 0.41 deg"):
        mocapkit.save(res.motion, tmp_path / "py.bvh")
    original = mocapkit.load(noisy)
    written = bvh_written(original, res.motion, tmp_path / "on_axes.bvh")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mocapkit.save(written, tmp_path / "on_axes.bvh")
    assert (tmp_path / "on_axes.bvh").read_bytes() == (tmp_path / "py.bvh").read_bytes()
    j = m.skeleton.joint_names.index("LeftLeg")
    same = np.all(np.asarray(res.motion.rotations) == np.asarray(original.rotations), axis=-1)
    np.testing.assert_array_equal(np.asarray(written.rotations)[same], np.asarray(original.rotations)[same])
    np.testing.assert_array_equal(np.delete(written.rotations, j, axis=1), np.delete(res.motion.rotations, j, axis=1))
    assert bvh_written(original, res.motion, tmp_path / "x.npz") is res.motion


def test_denoise_to_a_bvh_hinge_reports_what_the_file_holds(tmp_path):
    """`denoise` (as `fill` and `repair`) puts a hinge's changed rotations on its axis before it reports and writes:
    the mean change it prints is the file's, and the write says nothing is dropped."""
    import re
    import warnings

    import mocapkit
    from mocapkit.metrics import joint_angle_rms
    from tests.cli.helpers import run

    _, noisy = _noisy_hinged(tmp_path)
    out = tmp_path / "d.bvh"
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        code, stdout, err = run("denoise", str(noisy), "-o", str(out))
    assert code == 0, err
    said = float(re.search(r"mean change ([0-9.]+) deg RMS", stdout).group(1))
    assert said == round(joint_angle_rms(mocapkit.load(noisy), mocapkit.load(out), include_root=False), 2)


def test_an_amc_bone_of_fewer_dofs_is_put_on_its_dofs_and_a_save_says_what_it_drops(tmp_path):
    """An AMC bone with fewer than three ASF dofs (CMU 12's ``ltibia``: ``dof rx``) holds only its angles about them.
    Before 0.15.0 ``fill``, ``denoise`` and ``repair`` to an AMC reported from, and ``mocapkit.save`` wrote, a
    rotation turning such a bone about another axis, the file dropping that part without a word (``repair`` of
    CMU 12 / HDM05 bd with errors: 61 rotations of lhand, up to 0.01 deg); now :func:`bvh_written` puts the changed
    cells on the dofs (as ``clean`` does, :func:`mocapkit.cleaning.decisions.as_written`) and a save of a take
    not put on them warns how many and how much."""
    import warnings

    from mocapkit.io.asfamc import amc_held_rotations
    from mocapkit.io.euler_branches import bvh_written, off_axis_note, written_partial_joints

    m = read_amc(WALK, WALK_ASF)
    names = m.skeleton.joint_names
    assert {names[j] for j in written_partial_joints(m, "x.amc", WALK_ASF)} >= {"ltibia", "lradius", "lhand"}
    j = names.index("ltibia")
    rot = np.array(m.rotations)
    rot[10:20, j] = R.quaternion_multiply(rot[10:20, j], R.euler_to_quaternion(np.array([0.0, 0.0, 5.0]), "XYZ"))
    turned = dataclasses.replace(m, rotations=rot)
    with pytest.warns(UserWarning, match=r"10 rotations of ltibia \(fewer than three rotation dofs\) .* up to 5 deg"):
        mocapkit.save(turned, tmp_path / "py.amc", asf=WALK_ASF, copy_asf=False)
    written = bvh_written(m, turned, tmp_path / "on_dofs.amc", WALK_ASF, WALK)
    held = amc_held_rotations(turned)
    np.testing.assert_allclose(np.asarray(written.rotations)[10:20, j], held[10:20, j], rtol=0, atol=1e-12)
    keep = np.ones(rot.shape[:2], bool)
    keep[10:20, j] = False
    np.testing.assert_array_equal(np.asarray(written.rotations)[keep], np.asarray(m.rotations)[keep])  # bit for bit
    assert off_axis_note(written, tmp_path / "on_dofs.amc", WALK_ASF, WALK) is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mocapkit.save(written, tmp_path / "on_dofs.amc", asf=WALK_ASF, copy_asf=False)
    assert (tmp_path / "on_dofs.amc").read_bytes() == (tmp_path / "py.amc").read_bytes()  # the same file, now said


def test_one_layout_says_what_each_output_holds_and_an_npz_keeps_every_rotation(tmp_path):
    """:func:`written_layout` is the one place deciding which joints a file keeps only some rotation axes of and
    what it reads back as, for ``clean`` (``batch.clean_file``'s :func:`~mocapkit.cleaning.decisions.as_written`)
    and :func:`bvh_written` (``fill``, ``denoise``, ``repair``) alike. Before 0.16.0 each had its own copy,
    ``clean``'s choosing the BVH rule for any output not .amc (an .npz kept every rotation only because a second
    test left it out). An .npz keeps every rotation: nothing is put on axes for it, and ``clean`` to .npz records
    and writes the denoised hinge as cleaned (60 rotations of LeftLeg off its axis, up to 0.41 deg)."""
    from mocapkit.batch import clean_file
    from mocapkit.io.euler_branches import bvh_held_rotations, written_layout

    m, noisy = _noisy_hinged(tmp_path)
    j = m.skeleton.joint_names.index("LeftLeg")
    assert written_layout(m, "x.bvh") == ([j], bvh_held_rotations)
    assert written_layout(m, "x.npz") == ([], None)
    assert written_layout(read_bvh(START_01_01), "x.bvh") == ([], None)  # no hinge: a BVH holds every rotation
    walk = read_amc(WALK, WALK_ASF)
    joints, held = written_layout(walk, "x.amc", WALK_ASF, WALK)
    dofs = amc_dofs(walk.skeleton)
    assert joints == [k for k, d in enumerate(dofs) if 0 < sum(x[0] == "r" for x in d) < 3] and held is not None
    out = tmp_path / "clean.npz"
    clean_file(noisy, out, steps=("denoise",))
    z = np.load(tmp_path / "clean.clean.npz")
    written = np.asarray(mocapkit.load(out).rotations)
    np.testing.assert_array_equal(z["cleaned_rotations"], written[z["changed"]])  # what the record says is written
    leg = written[z["changed"][:, j], j]
    assert len(leg) == 60
    on_axis = bvh_held_rotations(dataclasses.replace(m, rotations=written))[z["changed"][:, j], j]
    assert np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(leg * on_axis, axis=-1)), 0, 1))).max() > 0.4  # kept off it


def test_the_off_axis_check_converts_only_the_bones_of_fewer_dofs(monkeypatch):
    """``mocapkit.save``'s check of an AMC (:func:`off_axis_note`) put every bone through the Euler round trip
    (29 of HDM05's 31, 0.2 s on a 9,760-frame take) where only those with fewer than three rotation dofs can lose
    anything (18 there). ``amc_held_rotations(..., joints=)`` converts only those, to the same numbers bit for
    bit; the others come back as given."""
    import mocapkit.io.asfamc as A
    from mocapkit.io.euler_branches import off_axis_note, written_partial_joints

    m = read_amc(WALK, WALK_ASF)
    few = written_partial_joints(m, "x.amc", WALK_ASF, WALK)
    assert 0 < len(few) < sum(any(x[0] == "r" for x in d) for d in amc_dofs(m.skeleton))
    every = A.amc_held_rotations(m)
    some = A.amc_held_rotations(m, joints=few)
    np.testing.assert_array_equal(some[:, few], every[:, few])
    np.testing.assert_array_equal(np.delete(some, few, axis=1), np.delete(np.asarray(m.rotations), few, axis=1))
    asked = []
    real = A.amc_held_rotations

    def spy(motion, dofs=None, joints=None):
        asked.append(None if joints is None else list(joints))
        return real(motion, dofs, joints)

    monkeypatch.setattr(A, "amc_held_rotations", spy)
    assert off_axis_note(m, "x.amc", WALK_ASF, WALK) is None
    assert asked == [few]


def test_repair_to_an_amc_reads_its_layout_once(tmp_path, monkeypatch):
    """`repair` to an AMC read the written layout (the ASF) twice, once to put the repaired bones on their dofs
    (:func:`bvh_written`) and again for the joints it counts; now once (:func:`written_layout`, handed to both).
    ``mocapkit.save`` reads it on its own for the writer and its check."""
    import traceback

    import mocapkit.io.amc_writer as W
    from tests.cli.helpers import run

    real, outside_save = W.file_dofs, []

    def spy(*args, **kwargs):
        stack = traceback.extract_stack()
        if stack[-2].filename.endswith("euler_branches.py") and "save" not in {f.name for f in stack}:
            outside_save.append(1)  # the layout read for repair's own write and count
        return real(*args, **kwargs)

    monkeypatch.setattr(W, "file_dofs", spy)
    code, out, err = run("repair", WALK, "-o", tmp_path / "r.amc", "--asf", WALK_ASF, "--context", "none")
    assert code == 0, err
    assert "wrote" in out and len(outside_save) == 1
