"""mocapkit: clean and reconstruct human motion-capture data.

>>> import mocapkit
>>> m = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
>>> m.skeleton.joint_names[:3]
('Hips', 'LHipJoint', 'LeftHip')
"""

from . import rotations, samples
from .errors import MocapError, MocapFormatError, SkeletonError
from .io import load, save
from .motion import Motion, Skeleton, concatenate

__version__ = "0.1.0"

__all__ = [
    "Motion",
    "Skeleton",
    "MocapError",
    "MocapFormatError",
    "SkeletonError",
    "load",
    "save",
    "concatenate",
    "rotations",
    "samples",
]
