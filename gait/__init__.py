"""Gait analysis on 3D joint trajectories: events, parameters, balance, transfers, falls, risk.

Pure computation on :class:`gaitwatch.trajectory.Trajectory` arrays; no I/O beyond the readers
of the two input formats.
"""

from gait.analysis import GaitConfig, analyse
from gait.result import GaitReport

__all__ = ["GaitConfig", "GaitReport", "analyse"]
