"""Which takes the deep models serve, and how a take on another spelling of their skeleton is fed to them.

The shipped EBF and EBD (Mall et al. 2017) read the Euler degrees of
freedom of the Acclaim ASF skeleton of the CMU and HDM05 databases
(``lfemur.Zrotation`` ...). The same skeleton also comes spelled otherwise:
Bruce Hahne's CMU BVH conversions name its joints ``LeftUpLeg`` or
``LeftHip`` and give every joint three ``Zrotation Yrotation Xrotation``
channels in world-aligned frames, where the ASF has one to three degrees of
freedom in a per-bone ``axis`` frame.

:func:`served_by` is the one rule: a take is served **directly** when it has
the model's channels (any ASF/AMC of that skeleton), or has them among more
(a game rig with a weapon, twist or tail bone added: every joint of the
model by name, each with the model's rotation channels in the model's order
and hanging directly below another of the model's joints or the root, in
the model's order; the network reads and writes those joints alone and the
others are left to the caller's fallback, as a joint map leaves the joints
no role claims); **through a joint map**
when its rig family (:mod:`mocapkit.rigs`) plays every role the model's
joints play but a few it can do without (:data:`OPTIONAL_ROLES`: a trunk
segment here and there, palms, fingers, thumbs and toes, which HumanIK,
Mixamo, Biovision and game rigs often lack), with the same tree, Y up; otherwise not
at all, with the reason in words. Through a joint map, :func:`encode` gives
the model what an ASF take of the same pose gives it and :func:`decode`
maps the model's output back onto the take's joints:

1. the rotation from a mapped joint's model parent to the joint is the
   product ``L`` of the take's local rotations along the chain between them
   (joints the model does not know, e.g. ``LHipJoint``, stay in the chain);
2. a rig whose rest pose is not the Acclaim one (a bone further than
   :data:`SAME_REST_DEG` from the Acclaim direction: the 3dsMax release's
   arms hang down, an A-pose rig holds them at 45 deg; a subject's own
   calibration moves bones by a few degrees and is left as it is) is
   **retargeted**: each such bone gets the constant rotation ``A`` that
   turns the Acclaim rest bone onto the rig's (the shortest arc), and the
   rotation the model reads is ``A_parent^-1 L A``: the same pose on the
   Acclaim rest skeleton (the bone's world direction is kept; its twist
   about the bone is the shortest arc's);
3. ``M = C^-1 L C`` with ``C`` the Acclaim ``axis`` of the joint
   (:data:`ACCLAIM_AXES`, the same in every CMU and HDM05 ASF), and the
   degrees of freedom are ``M``'s Euler angles in the model's channel order,
   as :meth:`Motion.channel_values` reads an AMC, each joint's triple on the
   branch nearest its previous frame's (:func:`mocapkit.rotations.continuous_euler`,
   as :func:`channels.encode` reads a take: near gimbal lock the plain
   conversion's other branch would read as a 180-deg jump). A spine or neck segment
   the rig lacks (a three-segment spine has no middle one, a Biovision
   ``Hips, Chest, Chest2, Neck, Head`` trunk no lower back and lower neck)
   takes half of the turn between the mapped joints around it and the one
   below it the other half (``L = h h``); on the way back the two new
   halves make the new turn. Two lacking in a row are not served. Any other joint the rig lacks (palms,
   fingers, thumbs, toes) is shown to the network at its training mean,
   and its output is dropped; so is a joint whose channels never moved in
   the training takes (their spread at the normalisation floor, 1 deg: the
   Acclaim fingers, fixed at 7.125 deg in every CMU and HDM05 take), which
   the rig's joint keeps as it is (denoising smooths it with the
   fallback's filter): a HumanIK index finger bends, which the network
   never saw, and a channel tens of spreads from anything it learnt
   disturbs every channel it filters;
4. back: the model's new angles replace the degrees of freedom and the
   part of ``M`` they do not span (the other axes of a one- or two-dof
   joint) is kept, or smoothed by a function the caller gives, so a
   rotation the network leaves unchanged comes back as it was. Cells whose
   channels the network did not change, and every joint the model does not
   cover (the root, ``LHipJoint``, the fingers of richer rigs), are copied
   bit-identically from the take.

On the CMU 01_01 take, whose ASF/AMC and MotionBuilder-release BVH are both
at hand, the BVH's encoded channels equal the AMC's to 1e-4 degrees (the
AMC's printed precision) and denoising and gap filling give the same
rotations on both spellings.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ... import rigs
from ... import rotations as R
from ...motion import Motion, Skeleton
from .channels import ChannelLayout, encode as encode_direct, decode as decode_direct, layout_for
from .channels import root_angular_velocity, unwrap_degrees
from ...words import plural

__all__ = ["role_names_for", "ACCLAIM_AXES", "SAME_REST_DEG", "OPTIONAL_ROLES", "INFERRED", "Serving", "served_by", "restricted", "encode",
           "decode"]

#: The family a :class:`Serving` names for a rig of no known family whose roles its tree and rest pose show.
INFERRED = "inferred"

#: The Acclaim ``axis`` (degrees, order ``XYZ``, extrinsic) of each joint of the CMU/HDM05 ASF skeleton; every
#: ASF of both databases has these (up to 1e-13 degrees).
ACCLAIM_AXES: dict[str, tuple[float, float, float]] = {
    "lfemur": (0, 0, 20), "ltibia": (0, 0, 20), "lfoot": (-90, 0, 20), "ltoes": (-90, 0, 20),
    "rfemur": (0, 0, -20), "rtibia": (0, 0, -20), "rfoot": (-90, 0, -20), "rtoes": (-90, 0, -20),
    "lowerback": (0, 0, 0), "upperback": (0, 0, 0), "thorax": (0, 0, 0), "lowerneck": (0, 0, 0),
    "upperneck": (0, 0, 0), "head": (0, 0, 0),
    "lclavicle": (0, 0, 0), "lhumerus": (180, -30, -90), "lradius": (180, -30, -90), "lwrist": (0, 90, 90),
    "lhand": (0, 90, 90), "lfingers": (0, 90, 90), "lthumb": (-90, 45, 0),
    "rclavicle": (0, 0, 0), "rhumerus": (180, 30, 90), "rradius": (180, 30, 90), "rwrist": (0, -90, -90),
    "rhand": (0, -90, -90), "rfingers": (0, -90, -90), "rthumb": (-90, -45, 0),
}

# Rest direction of each Acclaim joint's bone (to its child along the role tree), CMU subject 12's ASF rounded
# (Y up, X to the subject's left, Z forward); a take's rest bones must lie within SAME_REST_DEG of them.
_ACCLAIM_BONES: dict[str, tuple[float, float, float]] = {
    "lfemur": (0.34, -0.94, 0), "ltibia": (0.34, -0.94, 0), "lfoot": (0.05, -0.13, 0.99), "ltoes": (0, 0, 1),
    "rfemur": (-0.34, -0.94, 0), "rtibia": (-0.34, -0.94, 0), "rfoot": (-0.05, -0.12, 0.99), "rtoes": (0, 0, 1),
    "lowerback": (-0.06, 0.98, -0.17), "upperback": (0.01, 1, 0.08), "thorax": (0.04, 0.99, 0.16),
    "lowerneck": (-0.01, 1, 0.07), "upperneck": (0.03, 0.98, -0.18), "head": (0.01, 1, -0.07),
    "lclavicle": (0.97, 0.21, -0.11), "lhumerus": (1, 0, 0), "lradius": (1, 0, 0), "lwrist": (1, 0, 0),
    "lhand": (1, 0, 0), "lfingers": (1, 0, 0), "lthumb": (0.71, 0, 0.71),
    "rclavicle": (-0.98, 0.13, -0.12), "rhumerus": (-1, 0, 0), "rradius": (-1, 0, 0), "rwrist": (-1, 0, 0),
    "rhand": (-1, 0, 0), "rfingers": (-1, 0, 0), "rthumb": (-0.71, 0, 0.71),
}

#: A take's rest bone within this angle (degrees) of the Acclaim one counts as the same rest pose; further, the
#: bone is retargeted (module docstring, step 2).
SAME_REST_DEG = 30.0

# the trunk's segments: one a rig lacks between two it has takes half of the turn between them (module docstring,
# step 3); a lacking palm does not: below it a Mixamo hand has a finger's own bend, which the Acclaim fingers never make
_SPLIT_ROLES = frozenset({"spine", "spine_mid", "chest", "neck", "neck_upper"})

#: Roles of model joints a rig may lack and still be served (module docstring, step 3): their absence leaves the
#: chains above and below them whole (a trunk segment only where the next one below it on the trunk is mapped).
OPTIONAL_ROLES = _SPLIT_ROLES | frozenset({"left_palm", "right_palm", "left_fingers", "right_fingers", "left_thumb",
                                           "right_thumb", "left_toe", "right_toe"})

# the child role whose direction is a joint's bone (the role tree's main chain)
_BONE_CHILD = {"pelvis": "spine", "spine": "spine_mid", "spine_mid": "chest", "chest": "neck", "neck": "neck_upper",
               "neck_upper": "head"}
for _s in ("left", "right"):
    _BONE_CHILD.update({f"{_s}_thigh": f"{_s}_shin", f"{_s}_shin": f"{_s}_foot", f"{_s}_foot": f"{_s}_toe",
                        f"{_s}_clavicle": f"{_s}_upper_arm", f"{_s}_upper_arm": f"{_s}_forearm",
                        f"{_s}_forearm": f"{_s}_hand", f"{_s}_hand": f"{_s}_palm", f"{_s}_palm": f"{_s}_fingers"})


@dataclass(frozen=True)
class Serving:
    """How a model serves a take (from :func:`served_by`; arrays over the model's joints, layout order).

    ``direct``: the take has the model's channels and no mapping is needed;
    where it has more joints than the model, ``joints[k]`` is the take joint
    of model joint ``k`` and ``others`` the take's rotating non-root joints
    the model does not cover (the caller's fallback smooths them). Otherwise
    ``joints[k]`` is the take joint playing model joint ``k`` (-1: the rig
    lacks it, see :data:`OPTIONAL_ROLES`); ``chains[k]`` the take joints whose
    local rotations make the rotation from model joint ``parent[k]`` (-1: the
    pelvis) to ``k``, top down, ending with ``joints[k]`` (empty for a lacking
    joint); ``pelvis_chain`` the take joints from the root to the pelvis;
    ``orders[k]`` the intrinsic Euler order of the model's channels; ``axes``
    (n, 4) the Acclaim axis frames; ``rest`` (n, 4) each joint's retargeting
    rotation ``A`` (identity where the rest bones agree); ``body`` (4,) the
    pelvis' (the rest body frame's turn, identity on a Y-up rig);
    ``shares[k]`` the lacking model joint between joint ``k`` and its mapped
    parent whose turn ``k``'s chain carries (-1: none); ``filler`` (C,) the
    channel values a joint the network reads at its means is shown as (the
    training means, degrees).
    """

    model: object
    family: str | None
    direct: bool
    joints: tuple[int, ...] = ()
    parent: tuple[int, ...] = ()
    chains: tuple[tuple[int, ...], ...] = ()
    pelvis_chain: tuple[int, ...] = ()
    orders: tuple[str, ...] = ()
    axes: np.ndarray | None = None
    rest: np.ndarray | None = None
    filler: np.ndarray | None = None
    body: np.ndarray | None = None
    shares: tuple[int, ...] = ()
    others: tuple[int, ...] = ()
    names: tuple[str, ...] = ()  # direct: the take's joint names as the model reads them, where they are not the
    # file's (its family's, a namespace set aside: mocapkit.rigs.family_names); () where they are the file's
    by_role: bool = False  # direct: ``names`` are the model's family's, read by role from another family's names
    # (role_names_for); the shipped models' rule (layouts.pick_served) takes such a model only when nothing else serves

    def take_name(self, skeleton: Skeleton, name: str) -> str:
        """The file's name in ``skeleton`` (the take's) of the joint the model calls ``name``."""
        return skeleton.joint_names[self.names.index(name)] if name in self.names else name

    @property
    def retargeted(self) -> tuple[int, ...]:
        """Indices of the model joints whose rest bone the rig holds otherwise (retargeted, step 2)."""
        if self.rest is None:
            return ()
        return tuple(int(k) for k in np.flatnonzero(np.abs(self.rest[:, 0]) < 1.0))

    @property
    def lacking(self) -> tuple[int, ...]:
        """Indices of the model joints the network reads at its training means: those the rig does not have, and
        those that never moved in the training takes (module docstring, step 3)."""
        return tuple(k for k, j in enumerate(self.joints) if j < 0)

    @property
    def layout(self) -> ChannelLayout:
        return self.model.layout

    def describe(self) -> str:
        """How the take is served, in words (for notes and messages)."""
        if self.direct:
            return "its own channels" + (f" ({plural(len(self.others), 'joint')} the model does not know left to the fallback"
                                         " filter)" if self.others else "")
        rig = "rig, its roles read from its tree and rest pose," if self.family == INFERRED else f"{self.family} rig"
        how = f"a joint map from the {rig} onto the Acclaim skeleton"
        extra = [f"{plural(len(self.retargeted), 'bone')} retargeted from its rest pose"] if self.retargeted else []
        extra += [f"{plural(len(self.lacking), 'joint')} held at the model's means"] if self.lacking else []
        return how + (f" ({'; '.join(extra)})" if extra else "")


def _acclaim_role(name: str) -> str | None:
    for role, names in rigs.FAMILIES["acclaim"].items():
        if name in names:
            return role
    return None


def _complete_order(order: str) -> str:
    """A 3-axis intrinsic order containing a 1- or 2-axis ``order`` (as :func:`rotations.quaternion_to_euler`)."""
    if len(order) == 3:
        return order
    missing = [a for a in "XYZ" if a not in order]
    return order[0] + missing[0] + order[1] if len(order) == 2 else order + missing[0] + missing[1]


def _chain(sk: Skeleton, top: int, j: int) -> tuple[int, ...] | None:
    """Joints from just below ``top`` down to ``j`` (top down); None when ``top`` is not above ``j``."""
    out = []
    a = j
    while a != top:
        if a < 0:
            return None
        out.append(a)
        a = int(sk.parents[a])
    return tuple(reversed(out))


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else None


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def _rest_bone(sk: Skeleton, rest: np.ndarray, found: dict[str, int], role: str, j: int) -> np.ndarray | None:
    """Unit rest direction of joint ``j``'s bone (``rest``: the rig's rest positions with end sites): towards
    the first joint down the role's main chain that the rig has and that lies apart from ``j`` (a lacking palm,
    or one at the wrist, passes to the fingers), else its first child or end site apart from it; None if none."""
    tips = []
    child = _BONE_CHILD.get(role)
    while child is not None:
        if child in found:
            tips.append(found[child])
        child = _BONE_CHILD.get(child)
    tips += list(sk.children(j)) + [sk.num_joints + int(e) for e in np.flatnonzero(sk.end_site_parents == j)]
    for tip in tips:
        bone = _unit(rest[tip] - rest[j])
        if bone is not None:
            return bone
    return None


def _body_frame(sk: Skeleton, found: dict[str, int]) -> np.ndarray:
    """The unit quaternion ``B`` turning the Acclaim rest body frame (X to the subject's left, Y up, Z forward)
    onto the rig's (up: pelvis to head; left: right thigh to left thigh, square to up); identity when the two lie
    within SAME_REST_DEG (a Y-up rig), or the rig gives no frame."""
    rest = sk.rest_positions(end_sites=True)
    up = _unit(rest[found["head"]] - rest[found["pelvis"]])
    side = rest[found["left_thigh"]] - rest[found["right_thigh"]]
    if up is None:
        return np.array([1.0, 0.0, 0.0, 0.0])
    left = _unit(side - np.dot(side, up) * up)
    if left is None:
        return np.array([1.0, 0.0, 0.0, 0.0])
    frame = np.stack([left, up, np.cross(left, up)], axis=1)  # columns: the images of Acclaim's X, Y, Z
    b = R.matrix_to_quaternion(frame)
    return b if np.degrees(2.0 * np.arccos(min(1.0, abs(float(b[0]))))) >= SAME_REST_DEG else np.array([1.0, 0.0, 0.0, 0.0])


def _rest_alignment(sk: Skeleton, found: dict[str, int], names, model_roles, parent) -> tuple[np.ndarray, np.ndarray]:
    """``(A (n, 4), B (4,))``: each model joint's retargeting rotation and the body frame's (:func:`_body_frame`).

    A joint inherits its model parent's ``A`` (the pelvis' is ``B``), so a
    chain turned at its top stays turned below it with the same twist; where
    the inherited turn leaves the Acclaim rest bone SAME_REST_DEG or more from
    the rig's (arms hanging down, an A pose), the shortest arc ``S`` between
    the two is added: ``A = S A_parent``. A joint the rig lacks, or one with
    no bone to compare, keeps its parent's.
    """
    rest = sk.rest_positions(end_sites=True)
    body = _body_frame(sk, found)
    A = np.empty((len(names), 4))
    done = np.zeros(len(names), dtype=bool)

    def align(k: int) -> np.ndarray:
        if not done[k]:
            up = body if parent[k] < 0 else align(parent[k])
            A[k] = up
            j = found.get(model_roles[k])
            bone = None if j is None else _rest_bone(sk, rest, found, model_roles[k], j)
            if bone is not None:
                want = np.asarray(_ACCLAIM_BONES[names[k]], dtype=np.float64)
                want = R.quaternion_rotate(up, want / np.linalg.norm(want))
                if _angle_deg(want, bone) >= SAME_REST_DEG:
                    A[k] = R.quaternion_multiply(R.shortest_arc(want, bone), up)
            done[k] = True
        return A[k]

    for k in range(len(names)):
        align(k)
    return A, body


def _direct(model, sk: Skeleton, names: tuple[str, ...] = (), by_role: bool = False) -> Serving | str:
    """``model`` serving ``sk`` directly, its joints read under ``names`` (``Serving.names``; the file's own where
    empty): with exactly the model's channels, or with them among more joints (:func:`_own_joints`, the others
    left alone: ``Serving.others``); else :func:`_own_joints`' reason."""
    layout = model.layout
    read = dataclasses.replace(sk, joint_names=tuple(names)) if names else sk
    if layout_for(read, layout.representation).names == layout.names:
        return Serving(model, rigs.rig_family(sk), True, names=tuple(names), by_role=by_role)
    joints = _own_joints(read, layout)
    if isinstance(joints, str):
        return joints
    others = tuple(j for j in range(1, sk.num_joints) if j not in set(joints) and sk.rotation_order(j))
    return Serving(model, rigs.rig_family(sk), True, joints=joints, others=others, names=tuple(names),
                   by_role=by_role)


def served_by(motion_or_skeleton, model) -> Serving | str:
    """Whether ``model`` (a :class:`DeepModel`) serves the take: a :class:`Serving`, or the reason it does not.

    The one rule every command and the cleaning pipeline apply. A take with
    exactly the model's channels (an ASF/AMC take of the skeleton it was
    trained on) is served directly; so is one that has them among more
    joints (:func:`_own_joints`: each model joint by name with the model's
    channels, below another model joint or the root, in the model's order),
    whose other joints the network leaves alone (``Serving.others``); both
    also by the names of the take's rig family with its namespace set aside
    (:func:`mocapkit.rigs.family_names`: ``mixamorig:UpperLeg_L`` is the Bandai
    Namco model's ``UpperLeg_L``). An
    Euler model of the Acclaim skeleton also serves a take whose rig family (:func:`mocapkit.rigs.rig_family`)
    plays every role its joints play, each below the joint of its parent
    role, in the Acclaim rest pose (the CMU BVH conversions of the
    MotionBuilder-friendly release), or may lack a few of them
    (:data:`OPTIONAL_ROLES`: HumanIK and Mixamo rigs), in the Acclaim rest
    pose or retargeted from another (the 3dsMax-friendly release's arms hang
    down; module docstring); a rig of no known family through the roles its
    tree and rest pose show (:func:`mocapkit.rigs.roles_by_topology`; the
    family is then :data:`INFERRED`). Anything else: a one-line reason naming
    what is missing or different.
    """
    sk = getattr(motion_or_skeleton, "skeleton", motion_or_skeleton)
    layout = model.layout
    have = layout_for(sk, layout.representation)
    own = _direct(model, sk)
    if not isinstance(own, str):
        return own
    if rigs.family_prefix(sk):  # a namespace (Character1_Hips): the family's names serve
        bare = _direct(model, sk, rigs.family_names(sk))
        if not isinstance(bare, str):
            return bare
    renamed = role_names_for(sk, layout)
    if isinstance(renamed, tuple):  # the model's rig family under another family's names: read by role
        by_role = _direct(model, sk, renamed, by_role=True)
        if not isinstance(by_role, str):
            return by_role
        own = f"{by_role}, its joints read by role as the model's"
    trained = f"the model was trained on a skeleton with {layout.num_channels} {layout.representation} channels"
    model_roles = [_acclaim_role(n) for n in layout.joints]
    if layout.representation != "euler" or None in model_roles:
        same_count = have.num_channels == layout.num_channels
        if own.startswith("no joint ") and (same_count or renamed):  # renamed: why reading by role did not serve
            return (f"the model's joint names differ from this rig's ({own}{renamed}); "
                    f"train a model on this rig with `mocapkit train`")
        counts = "as many as this one has, but other ones" if same_count else f"and this one has {have.num_channels}"
        return f"{trained} {counts} ({own}); train a model on this rig with `mocapkit train`"
    family = rigs.rig_family(sk)
    found = rigs.roles(sk) if family is not None else rigs.roles_by_topology(sk)
    if found is None:
        return (f"{trained}, the Acclaim rig, and no joint map is known for this one, whose joints are "
                f"{', '.join(sk.joint_names[:4])}, ... (no known names, and its tree and rest pose do not show "
                f"its limbs and sides plainly); train a model on this rig with `mocapkit train`")
    family = family or INFERRED
    lacking = [n for n, r in zip(layout.joints, model_roles) if r not in found and r not in OPTIONAL_ROLES]
    if lacking:
        return (f"{trained}, the Acclaim rig; this {family} rig has no joint for {len(lacking)} of its "
                f"{len(layout.joints)} joints: {', '.join(lacking[:4])}{', ...' if len(lacking) > 4 else ''}; "
                f"train a model on this rig with `mocapkit train`")
    return _map(model, sk, family, found, model_roles)


def role_names_for(sk: Skeleton, layout: ChannelLayout) -> tuple[str, ...] | str:
    """``sk``'s joint names with each joint that plays a role of the model's joints (:mod:`mocapkit.rigs`) named as
    the model names it, the others as they are: a model trained on one rig family's names (the Bandai Namco pair:
    ``Hips``, ``UpperLeg_L`` ...) then reads the same rig under another family's (Unreal's ``pelvis``,
    ``thigh_l`` ...) as it reads its own. Where the model's joints are not all names of one family other than the
    Acclaim one (which is served through its joint map), or ``sk`` has no known family or lacks a role: the reason,
    in words, starting with "; " (appended to the names that differ)."""
    model_family = next((f for f, table in rigs.FAMILIES.items() if f != "acclaim"
                         and all(any(n in names for names in table.values()) for n in layout.joints)), None)
    family = rigs.rig_family(sk)
    if model_family is None or family is None or family == model_family:
        return ""
    table = rigs.FAMILIES[model_family]
    role_of = {n: r for r, names in table.items() for n in names if n in set(layout.joints)}
    found = rigs.roles(sk)
    lacking = [n for n in layout.joints if role_of.get(n) not in found]
    if lacking:
        return (f"; read by role, this {family} rig has no joint for {', '.join(lacking[:4])}"
                f"{', ...' if len(lacking) > 4 else ''}")
    names = list(sk.joint_names)
    for n in layout.joints:
        names[found[role_of[n]]] = n
    if len(set(names)) < len(names):
        return f"; read by role, this {family} rig would have two joints of one name"
    return tuple(names)


def _own_joints(sk: Skeleton, layout: ChannelLayout) -> tuple[int, ...] | str:
    """The take joints of the model's joints (layout order) where ``sk`` holds the model's channels among more
    joints (:func:`served_by`'s direct rule), else what differs, in words: a model joint the rig lacks, one that
    hangs below a joint the model does not know (then its rotation is relative to another frame than the model's),
    or other channels or another order of the model's joints."""
    index = {n: j for j, n in enumerate(sk.joint_names)}
    lacking = [n for n in layout.joints if n not in index or index[n] == 0]
    if lacking:
        return f"no joint {', '.join(lacking[:4])}{', ...' if len(lacking) > 4 else ''} below the root"
    ids = [index[n] for n in layout.joints]
    known = set(ids) | {0}
    for n, j in zip(layout.joints, ids):
        p = int(sk.parents[j])
        if p not in known:
            return f"its {n} hangs below {sk.joint_names[p]}, which the model has no channels for"
    have = layout_for(_restricted_skeleton(sk, sorted(known)), layout.representation)
    if have.names != layout.names:
        return _difference(layout, have) if set(have.names) != set(layout.names) else "its joints in another order"
    return tuple(ids)


def _restricted_skeleton(sk: Skeleton, keep: list[int]) -> Skeleton:
    """``sk`` on the joints ``keep`` (sorted, the root first, each one's parent among them): names, offsets, file
    channels and axis frames of those joints; no end sites."""
    new = {j: k for k, j in enumerate(keep)}
    return Skeleton(tuple(sk.joint_names[j] for j in keep), np.array([-1] + [new[int(sk.parents[j])] for j in keep[1:]]),
                    sk.offsets[keep], channels=None if sk.channels is None else tuple(sk.channels[j] for j in keep),
                    axes=None if sk.axes is None else sk.axes[keep], unit_cm=sk.unit_cm)


def restricted(motion: Motion, joints) -> Motion:
    """``motion`` on the root and ``joints`` alone (take indices whose parents are among them or the root): the
    rotations (F, n + 1, 4), root trajectory and file channels of those joints, for a model that knows only them."""
    keep = sorted({0} | {int(j) for j in joints})
    return Motion(skeleton=_restricted_skeleton(motion.skeleton, keep), rotations=motion.rotations[:, keep],
                  root_positions=motion.root_positions, fps=motion.fps, name=motion.name,
                  translations=None if motion.translations is None else motion.translations[:, keep])


def _difference(layout: ChannelLayout, have: ChannelLayout) -> str:
    missing = [n for n in layout.names if n not in set(have.names)]
    extra = [n for n in have.names if n not in set(layout.names)]
    return f"missing {missing[:4]}" if missing else f"unexpected {extra[:4]}"


def _role_above(role: str, known) -> str | None:
    """The nearest role above ``role`` (:data:`mocapkit.rigs.PARENT_ROLE`) that is in ``known`` or is the pelvis."""
    up = rigs.PARENT_ROLE.get(role)
    while up is not None and up not in known and up != "pelvis":
        up = rigs.PARENT_ROLE.get(up)
    return up


def _map(model, sk: Skeleton, family: str, found: dict[str, int], model_roles: list[str]) -> Serving | str:
    layout = model.layout
    pelvis = found["pelvis"]
    index = {r: k for k, r in enumerate(model_roles) if r in found}
    joints, parent, chains, orders = [], [], [], []
    for k, (name, role) in enumerate(zip(layout.joints, model_roles)):
        orders.append("".join(c.split(".")[1][0] for c in layout.names if c.split(".")[0] == name))
        up = _role_above(role, index)
        parent.append(-1 if up in (None, "pelvis") else index[up])
        if role not in found:  # an optional joint the rig lacks
            joints.append(-1)
            chains.append(())
            continue
        top = found["pelvis"] if up in (None, "pelvis") else found[up]
        chain = _chain(sk, top, found[role])
        if chain is None:
            return (f"this {family} rig's joint {sk.joint_names[found[role]]} does not hang below "
                    f"{sk.joint_names[top]} as {name} does in the Acclaim rig; train a model on this rig with "
                    f"`mocapkit train`")
        cols = [i for i, c in enumerate(layout.names) if c.split(".")[0] == name]
        if np.all(np.asarray(model.net.std, dtype=np.float64)[cols] <= 1.0):  # never moved in training: held
            joints.append(-1)
            chains.append(())
            continue
        joints.append(found[role])
        chains.append(chain)
    rest, body = _rest_alignment(sk, found, layout.joints, model_roles, parent)
    roles_index = {r: k for k, r in enumerate(model_roles)}
    shares = []
    for k, role in enumerate(model_roles):  # one lacking model joint right above a mapped one: it carries its turn
        up = _role_above(role, roles_index)
        m = roles_index.get(up, -1) if joints[k] >= 0 and up in _SPLIT_ROLES else -1
        shares.append(m if m >= 0 and joints[m] < 0 and m not in shares else -1)
    alone = [layout.joints[k] for k, r in enumerate(model_roles) if r in _SPLIT_ROLES and r not in found and k not in shares]
    if alone:
        return (f"the model was trained on the Acclaim rig, whose trunk has six segments; this {family} rig lacks "
                f"{', '.join(alone)} with no mapped segment right below to share the turn with; train a model on this "
                f"rig with `mocapkit train`")
    axes = np.stack([R.euler_to_quaternion(np.array(ACCLAIM_AXES[n], dtype=np.float64), "xyz") for n in layout.joints])
    filler = np.asarray(model.net.mean, dtype=np.float64).reshape(-1)
    return Serving(model, family, False, tuple(joints), tuple(parent), tuple(chains), _chain(sk, -1, pelvis),
                   tuple(orders), axes, rest, filler, body, tuple(shares))


def _product(rot: np.ndarray, chain: tuple[int, ...]) -> np.ndarray:
    """(F, 4): the product of the local rotations ``rot[:, chain]`` top down."""
    q = rot[:, chain[0]]
    for j in chain[1:]:
        q = R.quaternion_multiply(q, rot[:, j])
    return q


def _conj(a: np.ndarray, q: np.ndarray) -> np.ndarray:
    """a q a^-1."""
    return R.quaternion_multiply(R.quaternion_multiply(a, q), R.quaternion_conjugate(a))


def _retargeted(local: np.ndarray, s: Serving, k: int) -> np.ndarray:
    """``A_parent^-1 L A_k``: the rotation ``local`` (F, 4) of the rig's chain to model joint ``k`` as the Acclaim
    rest skeleton has it (module docstring, step 2); ``local`` itself where neither bone is retargeted."""
    a_k = s.rest[k]
    a_p = s.rest[s.parent[k]] if s.parent[k] >= 0 else s.body
    if a_p[0] != 1.0:
        local = R.quaternion_multiply(R.quaternion_conjugate(a_p), local)
    if a_k[0] != 1.0:
        local = R.quaternion_multiply(local, a_k)
    return local


def _unretargeted(local: np.ndarray, s: Serving, k: int) -> np.ndarray:
    """The inverse of :func:`_retargeted`: ``A_parent L A_k^-1``."""
    a_k = s.rest[k]
    a_p = s.rest[s.parent[k]] if s.parent[k] >= 0 else s.body
    if a_p[0] != 1.0:
        local = R.quaternion_multiply(a_p, local)
    if a_k[0] != 1.0:
        local = R.quaternion_multiply(local, R.quaternion_conjugate(a_k))
    return local


def _half(q: np.ndarray) -> np.ndarray:
    """(F, 4) the rotation about the same axis by half the angle (``h h = q``)."""
    return R.quaternion_exp(0.5 * R.quaternion_log(q))


def _dof_rotations(motion: Motion, s: Serving) -> np.ndarray:
    """(F, n, 4): each model joint's rotation M in its Acclaim axis frame (identity for a joint the rig lacks,
    half the turn below it for one a mapped joint's chain carries)."""
    rot = motion.rotations
    out = np.tile(np.array([1.0, 0.0, 0.0, 0.0]), (motion.num_frames, len(s.joints), 1))
    shares = s.shares or (-1,) * len(s.joints)
    for k, chain in enumerate(s.chains):
        if not chain:
            continue
        local = _retargeted(_product(rot, chain), s, k)
        m = shares[k]
        if m >= 0:
            local = _half(local)
            out[:, m] = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(s.axes[m]), local), s.axes[m])
        out[:, k] = R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(s.axes[k]), local), s.axes[k])
    return out


def _pelvis_rotation(motion: Motion, s: Serving) -> np.ndarray:
    """(F, 4) the pelvis' world rotation as the Acclaim rest skeleton has it (turned by the body frame)."""
    q = _product(motion.rotations, s.pelvis_chain)
    return q if s.body[0] == 1.0 else R.quaternion_multiply(q, s.body)


def _full_angles(m: np.ndarray, order: str) -> tuple[np.ndarray, str]:
    """Euler angles (F, 3), degrees, of M (F, 4) in the 3-axis order completing ``order``; the dofs sit at
    ``order``'s axes. Each frame's triple is the one nearest the frame before's
    (:func:`mocapkit.rotations.continuous_euler`): one branch, as :func:`channels.encode` reads a joint, so a
    joint near gimbal lock does not jump by 180 deg where the plain conversion changes branch."""
    full = _complete_order(order)
    return R.continuous_euler(R.quaternion_to_euler(m, full), full), full


def encode(motion: Motion, serving: Serving) -> tuple[np.ndarray, np.ndarray]:
    """(values (F, C), context (F, 3)) the model reads for ``motion``: its degrees (unwrapped) and root omega.

    Direct serving is :func:`channels.encode` (of :func:`restricted` to the model's joints where the take has
    more). Through a joint map the
    values are the Acclaim degrees of freedom of each mapped joint (module
    docstring) and the context is the pelvis' angular velocity in its own
    frame (rad/s). A NaN rotation anywhere on a joint's chain gives NaN
    channels for it; a joint the rig lacks gives half the turn below it
    (module docstring, step 3), or at a chain's end its channels' training
    means at every frame.
    """
    if serving.direct:
        motion = _model_named(motion, serving)
        return encode_direct(restricted(motion, serving.joints) if serving.joints else motion, serving.layout)
    ctx = root_angular_velocity(_pelvis_rotation(motion, serving), motion.fps)
    return _channels(_dof_rotations(motion, serving), serving), ctx


def _model_named(motion: Motion, serving: Serving) -> Motion:
    """``motion`` with its joints named as ``serving`` reads them (:attr:`Serving.names`: the family's names, a
    namespace set aside), the same arrays; ``motion`` itself where they are the file's."""
    if not serving.names:
        return motion
    return dataclasses.replace(motion, skeleton=dataclasses.replace(motion.skeleton, joint_names=serving.names))


def _channels(m: np.ndarray, serving: Serving) -> np.ndarray:
    """(F, C) the model's channels (degrees, unwrapped) from the joints' rotations ``m`` (F, n, 4)."""
    cols = []
    c = 0
    carried = set(serving.shares) - {-1}
    for k, order in enumerate(serving.orders):
        if serving.joints[k] < 0 and k not in carried:  # a joint the rig lacks: the network sees its training mean
            cols += [np.full(len(m), serving.filler[c + i]) for i in range(len(order))]
            c += len(order)
            continue
        ang, full = _full_angles(m[:, k], order)
        cols += [ang[:, full.index(a)] for a in order]
        c += len(order)
    return unwrap_degrees(np.stack(cols, axis=1))


def _bridge(angles: np.ndarray) -> np.ndarray:
    """(F, K) angle columns in degrees with their NaN runs filled: linear between the unwrapped observed samples on
    either side, held at the take's ends; a column with no observed sample stays NaN."""
    out = np.array(angles, dtype=np.float64)
    t = np.arange(len(out))
    for c in range(out.shape[1]):
        miss = np.isnan(out[:, c])
        if not miss.any() or miss.all():
            continue
        seen = np.flatnonzero(~miss)
        vals = np.degrees(np.unwrap(np.radians(out[seen, c])))
        out[miss, c] = np.interp(t[miss], seen, vals)
    return out


def decode(values: np.ndarray, like: Motion, serving: Serving, keep: np.ndarray | None = None,
           residual=None) -> Motion:
    """A Motion like ``like`` whose model-covered rotations come from the model's ``values`` (F, C) in degrees.

    Direct serving is :func:`channels.decode` (onto the model's joints alone where the take has more; the
    others are copied). Through a joint map, each
    mapped joint's new rotation keeps the part of its Acclaim rotation the
    degrees of freedom do not span, and is written back through its chain
    (joints on the chain that the model does not cover keep their rotation).
    A cell is copied bit-identically from ``like`` where ``keep`` (F, J) is
    True, where the joint is not mapped, and where the model left every one
    of its channels exactly as :func:`encode` gave them. ``residual``: an
    optional function applied to each joint's residual angles (F, 3 - dofs),
    degrees unwrapped along time, before they are recombined (the denoiser
    smooths them: the network cannot see them).
    """
    if serving.direct and serving.joints:  # the model's joints among more: written back onto them alone
        part = restricted(_model_named(like, serving), serving.joints)
        keep_part = None if keep is None else np.asarray(keep, dtype=bool)[:, sorted({0, *serving.joints})]
        out = decode_direct(values, part, serving.layout, keep=keep_part)
        rot = np.array(like.rotations)
        rot[:, list(serving.joints)] = out.rotations[:, [part.skeleton.index(n) for n in serving.layout.joints]]
        return dataclasses.replace(like, rotations=rot)
    if serving.direct:
        out = decode_direct(values, _model_named(like, serving), serving.layout, keep=keep)
        return dataclasses.replace(out, skeleton=like.skeleton) if serving.names else out
    values = np.asarray(values, dtype=np.float64)
    F = like.num_frames
    if values.shape != (F, serving.layout.num_channels):
        raise ValueError(f"values: expected shape ({F}, {serving.layout.num_channels}), got {values.shape}")
    m = _dof_rotations(like, serving)
    before = _channels(m, serving)
    rot = np.array(like.rotations)
    same = np.ones((F, like.skeleton.num_joints), dtype=bool)
    shares = serving.shares or (-1,) * len(serving.joints)
    carried = set(shares) - {-1}
    new_local, changed = {}, {}
    c = 0
    for k, order in enumerate(serving.orders):  # each joint's new Acclaim rotation and where it changed
        n = len(order)
        new, old = values[:, c:c + n], before[:, c:c + n]
        c += n
        if serving.joints[k] < 0 and k not in carried:  # the output for a joint the rig lacks has nowhere to go
            continue
        changed[k] = ~np.all((new == old) | (np.isnan(new) & np.isnan(old)), axis=1)
        ang, full = _full_angles(m[:, k], order)
        rest_axes = [full.index(a) for a in full if a not in order]
        if rest_axes:  # a missing cell has no residual of its own: the observed ones on either side, interpolated
            ang[:, rest_axes] = _bridge(ang[:, rest_axes])
        ang = np.nan_to_num(ang)  # a joint missing throughout: its rotation is the dofs alone
        if residual is not None and rest_axes:
            r0 = ang[:, rest_axes]
            r1 = residual(unwrap_degrees(r0))
            changed[k] |= np.any(np.abs(((r1 - r0) + 180.0) % 360.0 - 180.0) > 0.0, axis=1)
            ang[:, rest_axes] = r1
        for i, a in enumerate(order):
            ang[:, full.index(a)] = (new[:, i] + 180.0) % 360.0 - 180.0
        new_local[k] = _conj(serving.axes[k], R.euler_to_quaternion(ang, full))
    for k, j in enumerate(serving.joints):
        if j < 0:
            continue
        p, moved = new_local[k], changed[k]
        if shares[k] >= 0:  # the two halves make the chain's turn
            p = R.quaternion_multiply(new_local[shares[k]], p)
            moved = moved | changed[shares[k]]
        p = _unretargeted(p, serving, k)
        chain = serving.chains[k]
        if len(chain) > 1:
            above = _product(like.rotations, chain[:-1])
            p = R.quaternion_multiply(R.quaternion_conjugate(above), p)
        ref = like.rotations[:, j]
        flip = np.sum(p * np.nan_to_num(ref), axis=-1, keepdims=True) < 0.0
        p = np.where(flip, -p, p)
        rot[:, j] = np.where(moved[:, None], p, ref)
        same[:, j] = ~moved
    if keep is not None:
        same |= np.asarray(keep, dtype=bool)
    rot = np.where(same[..., None], like.rotations, rot)
    return dataclasses.replace(like, rotations=rot)
