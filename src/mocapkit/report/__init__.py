"""Pictures a person looks at: channel plots now; the MDM heat map and HTML viewer later."""

from .plots import plot_channels, plot_mdm

__all__ = ["plot_channels", "plot_mdm"]
