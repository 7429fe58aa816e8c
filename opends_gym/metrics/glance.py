"""Eye-glance metrics from off-road glance intervals (ISO 15007-1; NHTSA 2013 guidelines).

Why: visual-manual distraction is judged by where the eyes are, not by the car's path.
ISO 15007-1 (measurement of driver visual behaviour) defines a glance as the time from
the moment the gaze starts moving towards a target until it starts moving away from it
(transition time included), and the summary measures: number of glances, glance duration,
total glance time. NHTSA's Visual-Manual Driver Distraction Guidelines (Federal Register
78(81), 26 April 2013, Docket NHTSA-2010-0053) judge a secondary task by the glances away
from the forward road scene: for at least 85 % of test participants the mean single
glance duration should be <= 2.0 s, no more than 15 % of glances longer than 2.0 s, and
the total eyes-off-road time (TEORT) for the task <= 12.0 s.

The input is what a driver model (or an eye tracker, after fixation-to-glance
aggregation) gives: a list of (start_s, end_s) intervals with the eyes off the road.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

# NHTSA 2013 Visual-Manual Driver Distraction Guidelines, acceptance criteria per task
NHTSA_MAX_MEAN_GLANCE_S = 2.0
NHTSA_LONG_GLANCE_S = 2.0
NHTSA_MAX_LONG_GLANCE_SHARE = 0.15
NHTSA_MAX_TEORT_S = 12.0


@dataclass(frozen=True)
class GlanceMetrics:
    """Summary of one participant's off-road glances over a task or an episode."""

    glance_count: int
    total_eyes_off_road_s: float  # TEORT: the sum of the off-road glance durations
    mean_glance_s: float  # NaN without glances
    max_glance_s: float  # 0 without glances
    long_glance_share: float  # share of glances longer than `long_glance_s` (NaN without glances)
    long_glance_s: float

    def meets_nhtsa(self) -> bool:
        """This participant's glances against NHTSA 2013's per-task criteria (mean single
        glance <= 2 s, <= 15 % of glances > 2 s, TEORT <= 12 s). NHTSA asks that 85 % of
        the test participants meet them; see `nhtsa_pass_share`."""
        mean_ok = self.glance_count == 0 or self.mean_glance_s <= NHTSA_MAX_MEAN_GLANCE_S
        share_ok = self.glance_count == 0 or self.long_glance_share <= NHTSA_MAX_LONG_GLANCE_SHARE
        return mean_ok and share_ok and self.total_eyes_off_road_s <= NHTSA_MAX_TEORT_S

    def as_dict(self, prefix: str = "glance_") -> dict[str, float]:
        return {
            f"{prefix}count": float(self.glance_count),
            f"{prefix}total_eyes_off_road_s": self.total_eyes_off_road_s,
            f"{prefix}mean_s": self.mean_glance_s,
            f"{prefix}max_s": self.max_glance_s,
            f"{prefix}long_share": self.long_glance_share,
        }


def glance_metrics(glances: Sequence[tuple[float, float]], long_glance_s: float = NHTSA_LONG_GLANCE_S) -> GlanceMetrics:
    """Glance count, total eyes-off-road time, mean and longest glance and the share of
    glances longer than `long_glance_s` (NHTSA's 2.0 s) from (start_s, end_s) intervals.

    Intervals must be finite, end >= start, and not overlap (one pair of eyes): a bad one
    raises ValueError naming its index."""
    durations: list[float] = []
    prev_end = -math.inf
    for i, item in enumerate(glances):
        try:
            start, end = float(item[0]), float(item[1])
        except (TypeError, ValueError, IndexError):
            raise ValueError(f"glance {i}: expected (start_s, end_s), got {item!r}") from None
        if not (math.isfinite(start) and math.isfinite(end)):
            raise ValueError(f"glance {i}: start and end must be finite, got ({start}, {end})")
        if end < start:
            raise ValueError(f"glance {i}: ends at {end} s before it starts at {start} s")
        if start < prev_end:
            raise ValueError(f"glance {i}: starts at {start} s before the previous glance ended at {prev_end} s")
        prev_end = end
        durations.append(end - start)
    n = len(durations)
    if n == 0:
        return GlanceMetrics(0, 0.0, math.nan, 0.0, math.nan, long_glance_s)
    total = sum(durations)
    return GlanceMetrics(
        glance_count=n,
        total_eyes_off_road_s=total,
        mean_glance_s=total / n,
        max_glance_s=max(durations),
        long_glance_share=sum(1 for d in durations if d > long_glance_s) / n,
        long_glance_s=long_glance_s,
    )


def nhtsa_pass_share(participants: Sequence[GlanceMetrics]) -> float:
    """Share of participants whose glances meet NHTSA 2013's criteria for one task; the
    task is acceptable when this is >= 0.85 (NaN without participants)."""
    if not participants:
        return math.nan
    return sum(1 for p in participants if p.meets_nhtsa()) / len(participants)
