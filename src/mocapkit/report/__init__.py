"""Pictures a person looks at: channel plots now; the MDM heat map and HTML viewer later."""

from .plots import plot_channels

__all__ = ["plot_channels"]
