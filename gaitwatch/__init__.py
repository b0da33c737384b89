"""gaitwatch: markerless 3D gait and balance monitoring.

This small package holds what every part shares: the version and the binding conventions
(``gaitwatch.conventions``), the joint-trajectory container and its CSV format
(``gaitwatch.trajectory``), and readers of laboratory motion-capture files (``gaitwatch.mocap``).
The computation lives in ``tracker`` (video -> 3D poses) and ``gait`` (3D poses -> gait
parameters); everything with I/O beyond files lives in ``service``.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("gaitwatch")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
