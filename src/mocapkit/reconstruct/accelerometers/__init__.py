"""Full-body motion from four accelerometers (Tautges 2012, chapter 3; Tautges et al. 2011).

Four 3-D accelerometers on the lower arms and legs, next to the wrists and
ankles (:func:`mocapkit.features.default_sensors`, Fig. 3.3), drive a
data-driven synthesis from a :class:`~mocapkit.database.MotionDatabase`, in
three parts, one module each:

1. :mod:`.knowledge` — the knowledge base (sec. 3.3, :func:`knowledge_base`):
   simulated readings of every database frame, indexed for kNN search, with
   the poses, root-frame velocities and accelerations and root motion the
   synthesis needs.
2. :mod:`.synthesis` — search and synthesis (secs. 3.4-3.6,
   :class:`AccelerometerReconstructor`, :func:`reconstruct`): the online lazy
   neighbourhood graph over the nearest readings of each sample, then the
   weighted mean pose of its best paths (by default) or the pose that
   minimises eq. 3.4 in the weighted-PCA space of the neighbours.
3. :mod:`.kernels` — the energy of eq. 3.4 with the square-root kernel priors
   and its minimiser (numba, with a numpy twin).

Recordings of real sensors are read and written as CSV by
:mod:`mocapkit.io.readings`.

Examples
--------
>>> import mocapkit
>>> from mocapkit import samples
>>> from mocapkit.database import MotionDatabase
>>> from mocapkit.features import virtual_accelerometers
>>> db = MotionDatabase.build([samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")], fps=25,
...                           mirror=True, progress=False, executor="serial")
>>> test = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(25)
>>> out = reconstruct(virtual_accelerometers(test), db, fps=25)
>>> out.num_frames == test.num_frames, out.fps
(True, 25.0)
"""

from .knowledge import KnowledgeBase, clear_cache, database_up, knowledge_base, open_knowledge_base, save_knowledge_base
from .synthesis import (
    DEFAULTS,
    AccelerometerReconstructor,
    Pose,
    check_params,
    anti_alias_filter,
    default_k,
    motion_of_poses,
    path_weights,
    reconstruct,
    reconstruct_mahalanobis,
    reconstruct_nearest_neighbor,
    regression_pose,
    unwrap_rotvecs,
    weighted_pca,
)

__all__ = [
    "DEFAULTS",
    "check_params",
    "default_k",
    "anti_alias_filter",
    "path_weights",
    "unwrap_rotvecs",
    "weighted_pca",
    "regression_pose",
    "KnowledgeBase",
    "knowledge_base",
    "clear_cache",
    "database_up",
    "save_knowledge_base",
    "open_knowledge_base",
    "Pose",
    "AccelerometerReconstructor",
    "reconstruct",
    "reconstruct_nearest_neighbor",
    "reconstruct_mahalanobis",
    "motion_of_poses",
]
