"""Pictures a person looks at: channel plots, the MDM heat map (PNG) and the self-contained HTML report."""

from .plots import plot_channels, plot_mdm

__all__ = ["plot_channels", "plot_mdm"]
