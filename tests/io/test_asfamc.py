import numpy as np
import pytest

import mocapkit
from mocapkit.errors import MocapFormatError
from mocapkit.io.asfamc import find_asf, read_amc, read_asf
from mocapkit.motion import unit_scale_cm


def _rot(axis, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def naive_asf_fk(asf_path, amc_path, frames):
    """Bone start/end points from first principles (ASF spec): G_b = G_parent C_b M_b C_b^-1.

    Parses both files with plain Python; rotations are products of elementary matrices applied
    in the listed order (x first for "XYZ"/"rx ry rz"). Returns {frame: {bone: (start, end)}}.
    """
    bones, hier, root = {}, {}, {}
    section, cur = None, None
    for raw in open(asf_path, encoding="latin-1"):
        line = raw.split("#")[0].strip()
        if not line:
            continue
        if line.startswith(":"):
            section = line.split()[0]
            continue
        t = line.split()
        if section == ":root":
            root[t[0]] = t[1:]
        elif section == ":bonedata":
            if t[0] == "begin":
                cur = {"dof": []}
            elif t[0] == "end":
                bones[cur["name"]] = cur
            elif t[0] == "name":
                cur["name"] = t[1]
            elif t[0] == "direction":
                cur["dir"] = np.array([float(v) for v in t[1:4]])
            elif t[0] == "length":
                cur["len"] = float(t[1])
            elif t[0] == "axis":
                cur["axis"] = ([float(v) for v in t[1:4]], t[4].lower())
            elif t[0] == "dof":
                cur["dof"] = t[1:]
        elif section == ":hierarchy" and t[0] not in ("begin", "end"):
            hier[t[0]] = t[1:]

    def axis_matrix(vals, order):
        m = np.eye(3)
        for ax, v in zip(order, vals):  # x first: m = R_last ... R_first
            m = _rot(ax, v) @ m
        return m

    wanted = set(frames)
    data, f = {}, None
    for raw in open(amc_path, encoding="latin-1"):
        t = raw.split()
        if not t or t[0].startswith(("#", ":")):
            continue
        if len(t) == 1 and t[0].isdigit():
            f = int(t[0]) - 1
            continue
        if f in wanted:
            data.setdefault(f, {})[t[0]] = [float(v) for v in t[1:]]
    out = {}
    for f in frames:
        vals = data[f]
        r = vals["root"]
        order = [o.lower() for o in root["order"]]
        pos = np.array([r[order.index(a)] for a in ("tx", "ty", "tz")])
        rot_order = "".join(o[1] for o in order if o.startswith("r"))
        rvals = [r[order.index("r" + a)] for a in rot_order]
        c_root = axis_matrix([float(v) for v in root["orientation"]], root["axis"][0].lower())
        g_root = c_root @ axis_matrix(rvals, rot_order) @ c_root.T
        res = {}

        def visit(name, g_parent, start):
            b = bones[name]
            c = axis_matrix(*b["axis"])
            dofs = b["dof"]
            m = axis_matrix(vals.get(name, [0.0] * len(dofs)), "".join(d[1] for d in dofs)) if dofs else np.eye(3)
            g = g_parent @ c @ m @ c.T
            end = start + g @ (b["dir"] * b["len"])
            res[name] = (start, end)
            for ch in hier.get(name, []):
                visit(ch, g, end)

        for ch in hier["root"]:
            visit(ch, g_root, pos)
        out[f] = res
    return out


def check_against_oracle(m, asf, amc, frames):
    ref = naive_asf_fk(asf, amc, frames)
    p = m.global_positions(end_sites=True)
    names = m.skeleton.joint_names
    end_of = dict(zip(m.skeleton.end_site_parents.tolist(), range(m.num_joints, m.num_joints + 99)))
    size = np.ptp(m.skeleton.rest_positions(), axis=0).max()
    for f in frames:
        for j, name in enumerate(names[1:], start=1):
            start, end = ref[f][name]
            np.testing.assert_allclose(p[f, j], start, atol=1e-9 * size, err_msg=f"{amc} frame {f} {name}")
            if j in end_of:
                np.testing.assert_allclose(p[f, end_of[j]], end, atol=1e-9 * size)


SAMPLES = [("12_walk.amc", "12.asf"), ("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bd.asf"),
           ("HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk.asf")]


@pytest.mark.parametrize("amc,asf", SAMPLES)
def test_bundled_clips_match_the_oracle(amc, asf):
    path = mocapkit.samples.path(amc)
    m = mocapkit.load(path)
    assert find_asf(path).name == asf
    assert m.fps == 120.0 and m.num_joints == 31
    check_against_oracle(m, mocapkit.samples.path(asf), path, [0, m.num_frames // 2, m.num_frames - 1])


def test_every_amc_in_shared_data_loads_and_matches_the_oracle(shared_data):
    files = sorted(shared_data.rglob("*.amc"))
    assert len(files) >= 280
    for i, f in enumerate(files):
        m = mocapkit.load(f)
        assert m.num_frames > 0 and np.isfinite(m.rotations).all(), f.name
        if i % 10 == 0:  # the oracle is slow: every tenth clip, three frames each
            check_against_oracle(m, find_asf(f), f, [0, m.num_frames // 2, m.num_frames - 1])


def test_cmu_amc_equals_its_cgspeed_bvh_conversion(shared_data):
    amc = mocapkit.load(shared_data / "cmu_asfamc" / "01_01.amc")
    bvh = mocapkit.load(shared_data / "cmu_bvh" / "01_01.bvh")
    assert bvh.num_frames == amc.num_frames + 1  # the converter prepends a T-pose
    pa = amc.global_positions()
    pb = bvh.global_positions()[1:]
    # Same joint order (root/Hips, lhipjoint/LHipJoint, ...) and units: root-relative positions of the
    # legs and the spine up to the thorax agree to the BVH's 5 printed decimals. From the neck up the
    # converter moved the joints by a constant 2.06 units, so the comparison stops at the thorax.
    upto = amc.skeleton.index("thorax") + 1
    assert bvh.skeleton.joint_names[upto - 1] == "Spine1"
    ra, rb = pa - pa[:, :1], pb - pb[:, :1]
    np.testing.assert_allclose(ra[:, :upto], rb[:, :upto], atol=1e-4)


def test_channel_values_are_the_amc_numbers():
    path = mocapkit.samples.path("12_walk.amc")
    m = mocapkit.load(path)
    lines = path.read_text(encoding="latin-1").splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == "1")
    frame1 = {t.split()[0]: [float(v) for v in t.split()[1:]] for t in lines[start + 1 : start + 30]}
    names = m.channel_names()
    values = m.channel_values()[0]
    got = dict(zip(names, values))
    # lfemur: dof rx ry rz -> channels stored reversed (intrinsic Z Y X)
    assert got["lfemur.Xrotation"] == pytest.approx(frame1["lfemur"][0], abs=1e-6)
    assert got["lfemur.Yrotation"] == pytest.approx(frame1["lfemur"][1], abs=1e-6)
    assert got["lfemur.Zrotation"] == pytest.approx(frame1["lfemur"][2], abs=1e-6)
    assert got["ltibia.Xrotation"] == pytest.approx(frame1["ltibia"][0], abs=1e-6)
    assert got["root.Xposition"] == pytest.approx(frame1["root"][0], abs=1e-9)


def test_skeleton_units_and_limits():
    sk = read_asf(mocapkit.samples.path("12.asf"))
    assert sk.unit_cm == pytest.approx(2.54 / 0.45) and unit_scale_cm(sk) == pytest.approx(2.54 / 0.45)
    j = sk.index("lfemur")
    assert sk.joint_channels(j) == ("Zrotation", "Yrotation", "Xrotation")
    assert len(sk.limits[j]) == 3
    assert sk.num_end_sites >= 5


def _copy(tmp_path, name, new=None):
    dst = tmp_path / (new or name)
    dst.write_bytes(mocapkit.samples.path(name).read_bytes())
    return dst


def test_skeleton_resolution_rules(tmp_path):
    amc = _copy(tmp_path, "12_walk.amc", "07_01.amc")
    _copy(tmp_path, "12.asf", "07.asf")
    _copy(tmp_path, "12.asf", "08.asf")
    assert find_asf(amc).name == "07.asf"
    solo = tmp_path / "solo"
    solo.mkdir()
    amc2 = _copy(solo, "12_walk.amc", "walk.amc")
    _copy(solo, "12.asf", "subject.asf")
    assert find_asf(amc2).name == "subject.asf"
    none = tmp_path / "none"
    none.mkdir()
    amc3 = _copy(none, "12_walk.amc", "09_01.amc")
    with pytest.raises(MocapFormatError, match="09_01.amc.*09.asf"):
        mocapkit.load(amc3)
    m = read_amc(amc3, asf=mocapkit.samples.path("12.asf"), fps=60)
    assert m.fps == 60


def test_bad_amc_files(tmp_path):
    asf = mocapkit.samples.path("12.asf")
    text = mocapkit.samples.path("12_walk.amc").read_text(encoding="latin-1").splitlines()
    start = next(i for i, line in enumerate(text) if line.strip() == "1")

    def write(lines, name):
        p = tmp_path / name
        p.write_text("\n".join(lines) + "\n", encoding="latin-1")
        return p

    bad = list(text)
    bad[start + 3] = "tail 1 2 3"
    with pytest.raises(MocapFormatError, match=rf"unknown.amc:{start + 4}:.*tail"):
        read_amc(write(bad, "unknown.amc"), asf=asf)
    bad = list(text)
    bad[start + 2] = bad[start + 2].rsplit(" ", 1)[0]
    with pytest.raises(MocapFormatError, match=rf"few.amc:{start + 3}:.*values"):
        read_amc(write(bad, "few.amc"), asf=asf)
    bad = list(text)
    bad[start + 2] = bad[start + 2].split()[0] + " 1 x 3"
    with pytest.raises(MocapFormatError, match=rf"nonnum.amc:{start + 3}:.*non-numeric"):
        read_amc(write(bad, "nonnum.amc"), asf=asf)
    with pytest.raises(MocapFormatError, match="zero.amc.*no frames"):
        read_amc(write(text[:start], "zero.amc"), asf=asf)
    bad = list(text)
    nxt = next(i for i in range(start + 1, len(bad)) if bad[i].strip() == "2")
    bad[nxt] = "5"
    with pytest.raises(MocapFormatError, match=rf"gap.amc:{nxt + 1}:.*consecutive"):
        read_amc(write(bad, "gap.amc"), asf=asf)
    with pytest.raises(MocapFormatError, match="trunc.amc.*truncated"):
        read_amc(write(text[: nxt + 5], "trunc.amc"), asf=asf)


def test_amc_motions_round_trip_through_bvh_and_npz(tmp_path, shared_data):
    files = sorted(shared_data.rglob("*.amc"))[::25] + [mocapkit.samples.path("12_walk.amc")]
    for f in files:
        m = mocapkit.load(f)
        ref = m.global_positions(end_sites=True)
        size = np.ptp(ref.reshape(-1, 3), axis=0).max()
        for suffix in (".bvh", ".npz"):
            back = mocapkit.load(mocapkit.save(m, tmp_path / (f.stem + suffix)))
            got = back.global_positions(end_sites=True)
            tol = 1e-5 * size if suffix == ".bvh" else 0.0  # BVH holds 6 decimals; npz is exact
            np.testing.assert_allclose(got, ref, atol=tol, rtol=0, err_msg=f"{f.name} via {suffix}")


def test_prefix_must_end_at_a_boundary(tmp_path):
    amc = _copy(tmp_path, "12_walk.amc", "071_01.amc")
    _copy(tmp_path, "12.asf", "07.asf")
    _copy(tmp_path, "12.asf", "08.asf")
    with pytest.raises(MocapFormatError, match="071.asf"):
        find_asf(amc)
    dance = tmp_path / "dance"
    dance.mkdir()
    amc = _copy(dance, "12_walk.amc", "charleston1.amc")
    _copy(dance, "12.asf", "charleston.asf")
    _copy(dance, "12.asf", "lambada.asf")
    assert find_asf(amc).name == "charleston.asf"
