"""Clean optical marker captures: swapped labels, spikes and gaps.

One module per concept: ``rigid`` (donor frames, inter-marker distances),
``lowrank`` (Gløersen-Federolf PCA fill), ``gaps`` (self-validated average
of donor-frame and regression fills), ``constraints`` (soft inter-marker distance constraints), ``spikes``, ``swaps``, ``duplicates`` (a marker on
another's position), and ``clean`` (the pipeline and
its record, :func:`clean_markers`).
"""

from .constraints import enforce_distances, violation as constraint_violation
from .clean import STEPS, MarkerCleanResult, MarkerFix, clean_markers
from .duplicates import Duplicate, find_duplicates
from .gaps import GapFill, fill_gaps, gap_runs
from .lowrank import fill_lowrank
from .spikes import spike_mask
from .swaps import Swap, undo_swaps

__all__ = ["enforce_distances", "constraint_violation", "STEPS", "MarkerCleanResult", "MarkerFix", "clean_markers", "GapFill", "fill_gaps",
           "gap_runs", "fill_lowrank", "spike_mask", "Swap", "undo_swaps", "Duplicate", "find_duplicates"]
