"""Pure metric functions over arrays and event tables.

The same code scores a live episode (env `info`), a recorded drive (`opends-gym analyze`)
and a human session. Units are in the names; every tuning parameter is an argument.
"""

from .deviation import Completeness, DeviationResult, mean_deviation
from .glance import GlanceMetrics, glance_metrics, nhtsa_pass_share
from .headway import car_following_summary, time_gap, time_headway, time_to_collision
from .lateral import SdlpResult, lane_exceedances, sdlp, sdlp_segments
from .lct import LctSign, NormativeModel, lct_mdev, normative_path
from .lct_iso import LctIsoScore, score_lct_iso
from .reaction import BrakeRtSummary, RtDistribution, brake_reaction_time, score_brake_trials, score_drt, summarize_reactions
from .stats import MeanCI, mean_ci
from .steering import reversal_rate, reversal_rates

__all__ = [
    "BrakeRtSummary",
    "Completeness",
    "DeviationResult",
    "GlanceMetrics",
    "LctIsoScore",
    "LctSign",
    "MeanCI",
    "NormativeModel",
    "RtDistribution",
    "SdlpResult",
    "brake_reaction_time",
    "car_following_summary",
    "glance_metrics",
    "lane_exceedances",
    "lct_mdev",
    "mean_ci",
    "mean_deviation",
    "nhtsa_pass_share",
    "normative_path",
    "reversal_rate",
    "reversal_rates",
    "score_brake_trials",
    "score_drt",
    "score_lct_iso",
    "sdlp",
    "sdlp_segments",
    "summarize_reactions",
    "time_gap",
    "time_headway",
    "time_to_collision",
]
