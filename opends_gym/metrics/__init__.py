"""Pure metric functions over arrays and event tables.

The same code scores a live episode (env `info`), a recorded drive (`opends-gym analyze`)
and a human session. Units are in the names; every tuning parameter is an argument.
"""

from .deviation import Completeness, DeviationResult, mean_deviation
from .headway import time_gap, time_headway, time_to_collision
from .lateral import lane_exceedances, sdlp
from .lct import LctSign, NormativeModel, lct_mdev, normative_path
from .reaction import brake_reaction_time, score_drt, summarize_reactions
from .stats import MeanCI, mean_ci
from .steering import reversal_rate

__all__ = [
    "Completeness",
    "DeviationResult",
    "LctSign",
    "MeanCI",
    "NormativeModel",
    "brake_reaction_time",
    "lane_exceedances",
    "lct_mdev",
    "mean_ci",
    "mean_deviation",
    "normative_path",
    "reversal_rate",
    "score_drt",
    "sdlp",
    "summarize_reactions",
    "time_gap",
    "time_headway",
    "time_to_collision",
]
