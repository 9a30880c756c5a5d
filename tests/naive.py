"""Slow, obvious reference implementations used as test oracles.

Nothing here uses mocapkit: files are parsed with plain string splitting and
kinematics is done with 4x4 homogeneous matrices built from elementary
rotation matrices, one frame and one joint at a time.
"""

from __future__ import annotations

import math

import numpy as np


# -- BVH --------------------------------------------------------------------------


def _rot_x(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


_ELEMENTARY = {"X": _rot_x, "Y": _rot_y, "Z": _rot_z}


def naive_bvh_parse(path):
    """Parse a BVH file the simple way.

    Returns
    -------
    joints : list of dict
        In file order: ``name``, ``parent`` (index or -1), ``offset`` (3 floats),
        ``channels`` (list of names as written).
    end_sites : list of (parent index, offset)
        In file order.
    frames : list of list of float
        One list of channel values per frame line.
    frame_time : float
    """
    with open(path, encoding="utf-8", errors="replace") as fh:
        text = fh.read()
    head, _, motion = text.partition("MOTION")
    tokens = head.split()
    joints: list[dict] = []
    end_sites: list[tuple[int, list[float]]] = []
    stack: list[object] = []  # joint index, or "end" for an End Site block
    current = None
    i = 0
    while i < len(tokens):
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            parent = next((s for s in reversed(stack) if s != "end"), -1) if stack else -1
            joints.append({"name": tokens[i + 1], "parent": parent, "offset": [0.0, 0.0, 0.0], "channels": []})
            current = len(joints) - 1
            i += 2
        elif t == "End":
            end_sites.append((stack[-1], [0.0, 0.0, 0.0]))
            current = "end"
            i += 2
        elif t == "{":
            stack.append(current)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "OFFSET":
            off = [float(tokens[i + 1]), float(tokens[i + 2]), float(tokens[i + 3])]
            if stack[-1] == "end":
                end_sites[-1] = (end_sites[-1][0], off)
            else:
                joints[stack[-1]]["offset"] = off
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            joints[stack[-1]]["channels"] = tokens[i + 2 : i + 2 + n]
            i += 2 + n
        else:
            i += 1
    lines = motion.splitlines()
    frame_time = None
    frames = []
    for line in lines:
        s = line.strip()
        if not s:
            continue
        if s.startswith("Frames"):
            continue
        if s.startswith("Frame Time"):
            frame_time = float(s.split(":")[1])
            continue
        frames.append([float(x) for x in s.split()])
    return joints, end_sites, frames, frame_time


def naive_bvh_fk(path, frames) -> np.ndarray:
    """Global positions of joints then end sites, (len(frames), J + E, 3), by 4x4 matrices.

    Per frame and joint: the local transform is a translation (the OFFSET, with
    each axis that has a position channel replaced by that channel's value)
    times the product of elementary rotations in channel order (intrinsic:
    ``Zrotation Yrotation Xrotation`` gives ``Rz @ Ry @ Rx``); the global
    transform is the parent's global transform times the local one.
    """
    joints, end_sites, data, _ = naive_bvh_parse(path)
    out = []
    for f in frames:
        row = data[f]
        col = 0
        globals_: list[np.ndarray] = []
        for joint in joints:
            t = list(joint["offset"])
            rot = np.eye(3)
            for ch in joint["channels"]:
                value = row[col]
                col += 1
                axis = ch[0].upper()
                if ch.lower().endswith("position"):
                    t["XYZ".index(axis)] = value
                else:
                    rot = rot @ _ELEMENTARY[axis](value)
            local = np.eye(4)
            local[:3, :3] = rot
            local[:3, 3] = t
            parent = joint["parent"]
            g = local if parent < 0 else globals_[parent] @ local
            globals_.append(g)
        pos = [g[:3, 3] for g in globals_]
        for parent, off in end_sites:
            tr = np.eye(4)
            tr[:3, 3] = off
            pos.append((globals_[parent] @ tr)[:3, 3])
        out.append(np.array(pos))
    return np.array(out)


# -- ASF/AMC ----------------------------------------------------------------------


def _extrinsic(angles_deg, axes: str) -> np.ndarray:
    """Rotation matrix applying elementary rotations in the listed order (x first for "xyz").

    Each later rotation multiplies from the left: "xyz" gives Rz @ Ry @ Rx.
    """
    m = np.eye(3)
    for value, axis in zip(angles_deg, axes):
        m = _ELEMENTARY[axis.upper()](value) @ m
    return m


def naive_asf_parse(path) -> dict:
    """Parse an ASF file with plain string handling (Latin-1, any line ends, # comments).

    Returns
    -------
    dict
        ``length`` (the ``:units length`` value, 1.0 if absent), ``radians``
        (bool), ``root`` (dict of ``order``, ``axis``, ``position``,
        ``orientation`` as token lists), ``bones`` (name -> dict with
        ``direction`` (3,), ``length``, ``axis`` (3 angles), ``axis_order``,
        ``dof`` list), ``children`` (name -> list of child bone names in file order).
    """
    with open(path, encoding="latin-1", newline=None) as fh:
        lines = fh.read().splitlines()
    out = {"length": 1.0, "radians": False, "root": {}, "bones": {}, "children": {}}
    section = None
    bone = None
    for raw in lines:
        line = raw.split("#")[0].strip()
        if not line:
            continue
        tokens = line.split()
        if line.startswith(":"):
            section = tokens[0]
            continue
        if section == ":units":
            if tokens[0] == "length":
                out["length"] = float(tokens[1])
            elif tokens[0] == "angle":
                out["radians"] = tokens[1].lower() == "rad"
        elif section == ":root":
            out["root"][tokens[0]] = tokens[1:]
        elif section == ":bonedata":
            if tokens[0] == "begin":
                bone = {"dof": [], "axis": [0.0, 0.0, 0.0], "axis_order": "xyz"}
            elif tokens[0] == "end":
                out["bones"][bone["name"]] = bone
            elif tokens[0] == "name":
                bone["name"] = tokens[1]
            elif tokens[0] == "direction":
                bone["direction"] = np.array([float(t) for t in tokens[1:4]])
            elif tokens[0] == "length":
                bone["length"] = float(tokens[1])
            elif tokens[0] == "axis":
                bone["axis"] = [float(t) for t in tokens[1:4]]
                bone["axis_order"] = tokens[4].lower()
            elif tokens[0] == "dof":
                bone["dof"] = [t.lower() for t in tokens[1:]]
        elif section == ":hierarchy" and tokens[0] not in ("begin", "end"):
            out["children"].setdefault(tokens[0], []).extend(tokens[1:])
    return out


def naive_amc_parse(path, only=None) -> tuple[list[dict], bool]:
    """Parse an AMC file: a list of frames, each ``{bone name: [values]}``, and whether it is in radians.

    With ``only`` (a set of 0-based frame indices) the other frames are left as empty dicts.
    """
    with open(path, encoding="latin-1", newline=None) as fh:
        lines = fh.read().splitlines()
    frames: list[dict] = []
    radians = False
    keep = True
    for raw in lines:
        tokens = raw.split()
        if not tokens or tokens[0].startswith("#"):
            continue
        if tokens[0].startswith(":"):
            radians = radians or tokens[0].upper() == ":RADIANS"
            continue
        if len(tokens) == 1 and tokens[0].isdigit():
            keep = only is None or len(frames) in only
            frames.append({})
            continue
        if keep:
            frames[-1][tokens[0]] = [float(t) for t in tokens[1:]]
    return frames, radians


def naive_asfamc_fk(asf_path, amc_path, frames) -> list[dict]:
    """Bone start and end points of the given AMC frames, from the ASF definition.

    One bone at a time with 3x3 matrices: the axis frame ``C`` of a bone is the
    extrinsic rotation of its ``axis`` angles in the stated order, its motion
    ``M`` the extrinsic rotation of the AMC values in ``dof`` order; the
    global rotation is ``G = G_parent @ C @ M @ C^T``, the bone starts where
    its parent ends (bones on the root: at the root position plus ``G_root``
    applied to the root ``position``) and ends at ``start + G @ (direction * length)``.
    The root's ``C`` comes from ``orientation`` in the ``:root axis`` order,
    its position and ``M`` from the AMC root values read by ``order``.

    Returns
    -------
    list of dict, one per requested frame
        ``"root"`` -> position (3,), and each bone name -> ``(start, end)``,
        in ASF length units.
    """
    asf = naive_asf_parse(asf_path)
    data, amc_radians = naive_amc_parse(amc_path, only=set(frames))
    to_deg = (lambda v: [math.degrees(x) for x in v]) if asf["radians"] else (lambda v: list(v))
    amc_deg = (lambda v: [math.degrees(x) for x in v]) if amc_radians else (lambda v: list(v))
    root = asf["root"]
    order = [t.lower() for t in root.get("order", ["TX", "TY", "TZ", "RX", "RY", "RZ"])]
    root_axis = root.get("axis", ["XYZ"])[0].lower()
    orientation = to_deg([float(t) for t in root.get("orientation", [0, 0, 0])])
    position = np.array([float(t) for t in root.get("position", [0, 0, 0])])
    c_root = _extrinsic(orientation, root_axis)
    results = []
    for f in frames:
        values = data[f]
        rv = values.get("root", [0.0] * len(order))
        translation = np.zeros(3)
        rot_values, rot_axes = [], ""
        for name, v in zip(order, rv):
            if name[0] == "t":
                translation["xyz".index(name[1])] = v
            else:
                rot_values.append(v)
                rot_axes += name[1]
        g_root = c_root @ _extrinsic(amc_deg(rot_values), rot_axes) @ c_root.T
        res = {"root": translation}

        def visit(name, g_parent, start):
            bone = asf["bones"][name]
            c = _extrinsic(to_deg(bone["axis"]), bone["axis_order"])
            dof = bone["dof"]
            m = _extrinsic(amc_deg(values.get(name, [0.0] * len(dof))), "".join(d[1] for d in dof))
            g = g_parent @ c @ m @ c.T
            end = start + g @ (bone["direction"] * bone["length"])
            res[name] = (start, end)
            for child in asf["children"].get(name, []):
                visit(child, g, end)

        for child in asf["children"]["root"]:
            visit(child, g_root, translation + g_root @ position)
        results.append(res)
    return results


# -- DTW --------------------------------------------------------------------------
#
# Full-matrix dynamic time warping written out cell by cell. Conventions shared
# with mocapkit.search.dtw: query frame n (rows), database frame m (columns);
# ties between predecessors go to the first of (diagonal, database step, query
# step) with the smallest value; classic steps (1,1), (0,1), (1,0) with unit
# weights; Tautges steps (1,1) and (1,2) weight 1, (2,1) weight 2.

_INF = float("inf")


def naive_local_cost(query, data) -> np.ndarray:
    """C[n, m] = Euclidean distance, summing squares feature by feature; inf for non-finite rows."""
    query = [[float(v) for v in row] for row in np.asarray(query, dtype=float)]
    data = [[float(v) for v in row] for row in np.asarray(data, dtype=float)]
    out = np.empty((len(query), len(data)))
    for n, q in enumerate(query):
        for m, x in enumerate(data):
            if not all(math.isfinite(v) for v in q) or not all(math.isfinite(v) for v in x):
                out[n, m] = _INF
                continue
            acc = 0.0
            for a, b in zip(q, x):
                t = a - b
                acc = acc + t * t
            out[n, m] = math.sqrt(acc)
    return out


def _naive_prepare(C, clip_ids, exclude):
    C = [[float(v) for v in row] for row in np.asarray(C, dtype=float)]
    M, N = len(C), len(C[0]) if C else 0
    for m in range(N):
        if exclude is not None and exclude[m]:
            for n in range(M):
                C[n][m] = _INF
    clip = [0] * N if clip_ids is None else [int(v) for v in clip_ids]
    first = [m == 0 or clip[m] != clip[m - 1] for m in range(N)]
    usable = [any(C[n][m] < _INF for n in range(M)) for m in range(N)]
    return C, M, N, first, usable


def naive_subsequence_dtw_matrix(C, clip_ids=None, steps="classic", exclude=None):
    """Subsequence DTW accumulated cost matrix over a local cost matrix C (M, N).

    Returns ``(D, pred)``: D as an (M, N) array and, for every cell, the chosen
    predecessor cell ``(n', m')`` or None (a path start, or an infinite cell).
    Clip starts: classic allows only (n-1, m) -> (n, m), Tautges makes D infinite
    for n > 0. A Tautges (1, 2) step needs m-2, m-1, m in one clip and m-1 usable
    (not excluded and not infinite for every query frame).
    """
    C, M, N, first, usable = _naive_prepare(C, clip_ids, exclude)
    D = [[_INF] * N for _ in range(M)]
    pred = [[None] * N for _ in range(M)]
    for m in range(N):
        for n in range(M):
            c = C[n][m]
            if n == 0:
                D[n][m] = c
                continue
            # (predecessor, value compared), in tie order; classic compares D(pred)
            # and adds C afterwards, Tautges compares D(pred) + weight * C
            cands = []
            if steps == "classic":
                if not first[m]:
                    cands.append(((n - 1, m - 1), D[n - 1][m - 1]))
                    cands.append(((n, m - 1), D[n][m - 1]))
                cands.append(((n - 1, m), D[n - 1][m]))
            else:
                if first[m]:
                    continue
                cands.append(((n - 1, m - 1), D[n - 1][m - 1] + c))
                if m >= 2 and not first[m - 1] and usable[m - 1]:
                    cands.append(((n - 1, m - 2), D[n - 1][m - 2] + c))
                if n >= 2:
                    cands.append(((n - 2, m - 1), D[n - 2][m - 1] + 2.0 * c))
            best, val = None, _INF
            for p, v in cands:
                if best is None or v < val:
                    best, val = p, v
            if steps == "classic":
                val = c + val
            D[n][m] = val
            pred[n][m] = best if val < _INF else None
    return np.array(D, dtype=float).reshape(M, N), pred


def naive_backtrack(pred, n, m):
    """The path (list of (query frame, database frame)) that ends in cell (n, m)."""
    path = [(n, m)]
    while pred[n][m] is not None:
        n, m = pred[n][m]
        path.append((n, m))
    return path[::-1]


def naive_dtw(C, steps="classic"):
    """Global DTW over a local cost matrix C (n, m), from (0, 0) to (n-1, m-1).

    Returns ``(cost, path)``; path is a list of (i, j), empty when the cost is inf.
    A Tautges (1, 2) step may not skip a column that is infinite in every row.
    """
    C, M, N, _, usable = _naive_prepare(C, None, None)
    D = [[_INF] * N for _ in range(M)]
    pred = [[None] * N for _ in range(M)]
    for i in range(M):
        for j in range(N):
            c = C[i][j]
            if i == 0 and j == 0:
                D[i][j] = c
                continue
            cands = []
            if steps == "classic":
                if i >= 1 and j >= 1:
                    cands.append(((i - 1, j - 1), D[i - 1][j - 1]))
                if j >= 1:
                    cands.append(((i, j - 1), D[i][j - 1]))
                if i >= 1:
                    cands.append(((i - 1, j), D[i - 1][j]))
            else:
                if i >= 1 and j >= 1:
                    cands.append(((i - 1, j - 1), D[i - 1][j - 1] + c))
                    if j >= 2 and usable[j - 1]:
                        cands.append(((i - 1, j - 2), D[i - 1][j - 2] + c))
                    if i >= 2:
                        cands.append(((i - 2, j - 1), D[i - 2][j - 1] + 2.0 * c))
            best, val = None, _INF
            for p, v in cands:
                if best is None or v < val:
                    best, val = p, v
            if steps == "classic":
                val = c + val
            D[i][j] = val
            pred[i][j] = best if val < _INF else None
    cost = D[M - 1][N - 1]
    if not cost < _INF:
        return _INF, []
    return cost, naive_backtrack(pred, M - 1, N - 1)


def naive_k_best(C, clip_ids=None, steps="classic", exclude=None, k=1, max_overlap=0):
    """The k best matches by the full matrix: ends sorted by (cost, index), greedy non-overlap.

    Returns a list of (start, end, cost, path) with path from backtracking.
    """
    D, pred = naive_subsequence_dtw_matrix(C, clip_ids, steps, exclude)
    M, N = D.shape
    ends = sorted((D[M - 1, m], m) for m in range(N) if D[M - 1, m] < _INF)
    out = []
    for cost, e in ends:
        if len(out) >= k:
            break
        path = naive_backtrack(pred, M - 1, e)
        s = path[0][1]
        if all(min(e, e2) - max(s, s2) + 1 <= max_overlap for s2, e2, _, _ in out):
            out.append((s, e, cost, path))
    return out


# -- Aristidou et al. 2018, appendix: constrained word DTW, by exhaustive path enumeration -------------


def word_dtw_enumerate(C, min_width=11, max_run=3):
    """Every admissible path of the appendix's constrained DTW, enumerated; the slow oracle.

    Paths start at (0, 0), step (1, 0), (0, 1) or (1, 1), never take more
    than ``max_run`` consecutive non-diagonal steps in one direction, and stop
    the first time they reach the last row or the last column; the end must
    have matched at least ``min_width`` frames of the other word. For every end
    cell the path of least summed cost is kept; the result is the smallest
    mean cost (sum / cells) over end cells, with that end cell.
    """
    C = np.asarray(C, dtype=float)
    N, M = C.shape
    best_sum = {}  # end cell -> (sum, length)

    def walk(i, j, total, length, last, run):
        total += C[i, j]
        length += 1
        if i == N - 1 or j == M - 1:
            ok = (i == N - 1 and j >= min_width - 1) or (j == M - 1 and i >= min_width - 1)
            if ok and ((i, j) not in best_sum or total < best_sum[(i, j)][0]):
                best_sum[(i, j)] = (total, length)
            return
        for di, dj, kind in ((1, 1, "d"), (0, 1, "h"), (1, 0, "v")):
            r = run + 1 if kind == last and kind != "d" else (1 if kind != "d" else 0)
            if kind != "d" and r > max_run:
                continue
            walk(i + di, j + dj, total, length, kind, r)

    walk(0, 0, 0.0, 0, "d", 0)
    if not best_sum:
        return np.inf, -1, -1
    (i, j), (s, n) = min(best_sum.items(), key=lambda kv: kv[1][0] / kv[1][1])
    return s / n, i, j


def group_pose_distance_naive(a, b, members, drop):
    """Eq. 1 between two poses (m, 4): sum of squared half-angles over ``members`` minus the ``drop`` largest."""
    terms = []
    for k in members:
        d = min(abs(float(np.dot(a[k], b[k]))), 1.0)
        terms.append(np.arccos(d) ** 2)
    terms.sort()
    return float(sum(terms[: len(terms) - drop])) if drop else float(sum(terms))


def naive_local_minima_knn(dist, tgt, k, exclude_center=None, half=7):
    """Section 3.3 by the letter: per source word, the ``k`` smallest local minima of its distance function.

    ``dist`` (W, T) over target starts ``tgt`` (T,); neighbours are compared
    only across consecutive starts; a minimum is ``<=`` its left and ``<`` its
    right neighbour; minima within ``half`` frames of ``exclude_center[w]`` are
    then dropped. Returns, per row, a list of (value, index) ascending, ties
    to the earlier index.
    """
    out = []
    for w in range(dist.shape[0]):
        d = [float(x) for x in dist[w]]
        minima = []
        for t in range(len(d)):
            left = d[t - 1] if t > 0 and tgt[t] == tgt[t - 1] + 1 else math.inf
            right = d[t + 1] if t + 1 < len(d) and tgt[t + 1] == tgt[t] + 1 else math.inf
            if exclude_center is not None and abs(int(tgt[t]) - int(exclude_center[w])) <= half:
                continue
            if math.isfinite(d[t]) and d[t] <= left and d[t] < right:
                minima.append((d[t], t))
        out.append(sorted(minima)[:k])
    return out


# -- the gap prior's noise estimates and gap ends, one channel and one gap at a time -------------------------------


def naive_mad_noise(d) -> float:
    """The white-noise variance of second differences ``d`` (n,): their median absolute deviation as a standard
    deviation, squared, over 6."""
    return (1.4826 * float(np.median(np.abs(d - np.median(d))))) ** 2 / 6.0


def naive_clean_channels(x, miss, reading, share):
    """Per channel with a gap, by its own frames: whether the noise of its second differences at the quarter of its
    moving frames where ``reading`` bends least is at most ``share`` of the mean square ``x - reading``."""
    clean = np.zeros(x.shape[1], dtype=bool)
    if len(x) < 8:
        return clean
    ok3 = ~(miss[2:] | miss[1:-1] | miss[:-2])
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    bend = np.abs(reading[2:] - 2.0 * reading[1:-1] + reading[:-2])
    for c in np.flatnonzero(miss.any(axis=0)):
        ok = ok3[:, c]
        if ok.sum() < 8:
            continue
        r = x[~miss[:, c], c] - reading[~miss[:, c], c]
        total = float(np.mean(r * r))
        b, d = bend[ok, c], d2[ok, c]
        moving = d != 0.0
        if moving.sum() < 8:
            clean[c] = not moving.any()
            continue
        b, d = b[moving], d[moving]
        clean[c] = naive_mad_noise(d[b <= np.quantile(b, 0.25)]) <= share * total
    return clean


def naive_raw_weight(x, reading, miss, least):
    """Per channel: ``1 - noise / (noise + smoothing error)`` from its own observed frames, 0 below ``least``."""
    w = np.zeros(x.shape[1])
    ok3 = ~(miss[2:] | miss[1:-1] | miss[:-2])
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    for c in range(x.shape[1]):
        r = (x - reading)[~miss[:, c], c]
        d = d2[ok3[:, c], c]
        if len(r) < 8 or len(d) < 8:
            continue
        total = float(np.mean(r * r))
        w[c] = 1.0 if total <= 0.0 else float(np.clip(1.0 - naive_mad_noise(d) / total, 0.0, 1.0))
    return np.where(w >= least, w, 0.0)


def naive_end_slope(x, miss) -> float:
    """The first difference of the observed samples going away from a gap's end, their median where the first
    four's two second differences disagree; 0 with fewer than two."""
    n = 0
    while n < min(len(x), 4) and not miss[n]:
        n += 1
    if n < 2:
        return 0.0
    d = np.diff(np.asarray(x[:n], dtype=np.float64))
    if n < 4:
        return float(d[0])
    dd = np.diff(d)
    if abs(dd[0] - dd[1]) <= 0.5 * (abs(dd[0]) + abs(dd[1])):
        return float(d[0])
    return float(np.median(d))


def naive_anchor_ends(out, x, reading, miss, fps, clean, w, meets_reading, hermite_s, hermite_max_s):
    """Each gap of each channel in turn: a ramp by ``w`` between the offsets at its ends, then on a ``clean``
    channel's gap of at most ``hermite_max_s`` the cubic Hermite curve through its end samples, weighted
    ``exp(-d / hermite_s)`` at ``d`` seconds from the nearer end. In place."""
    F = len(x)
    for c in np.flatnonzero(miss.any(axis=0)):
        if w[c] <= 0.0:
            continue
        edges = np.diff(np.concatenate([[0], miss[:, c].astype(np.int8), [0]]))
        for s, e in zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()):
            if meets_reading:
                f0 = reading[s - 1, c] if s > 0 else None
                f1 = reading[e, c] if e < F else None
            elif e - s >= 2:
                f0, f1 = 2.0 * out[s, c] - out[s + 1, c], 2.0 * out[e - 1, c] - out[e - 2, c]
            else:
                f0 = f1 = out[s, c]
            d0 = x[s - 1, c] - f0 if s > 0 else None
            d1 = x[e, c] - f1 if e < F else None
            if d0 is None and d1 is None:
                continue
            d0 = d1 if d0 is None else d0
            d1 = d0 if d1 is None else d1
            t = (np.arange(s, e) - (s - 1)) / float(e - s + 1)
            out[s:e, c] += w[c] * ((1.0 - t) * d0 + t * d1)
            if clean[c] and s > 0 and e < F and e - s <= hermite_max_s * fps:
                va = -naive_end_slope(x[:s, c][::-1], miss[:s, c][::-1])
                vb = naive_end_slope(x[e:, c], miss[e:, c])
                a, b, n = x[s - 1, c], x[e, c], e - s
                u = (np.arange(n) + 1.0) / (n + 1.0)
                h = n + 1.0
                cubic = ((2 * u**3 - 3 * u**2 + 1) * a + (u**3 - 2 * u**2 + u) * h * va + (-2 * u**3 + 3 * u**2) * b
                         + (u**3 - u**2) * h * vb)
                k = np.exp(-(np.minimum(np.arange(n) + 1.0, n - np.arange(n)) / fps) / hermite_s)
                out[s:e, c] = k * cubic + (1.0 - k) * out[s:e, c]
