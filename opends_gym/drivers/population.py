"""A population of virtual participants: per-driver parameters drawn from published data.

Why: a study's power analysis and its effect sizes are only as good as the spread between
its participants. `sample_population(n, seed)` draws `n` drivers whose perception-response
stages, gaze, steering, lane-change and car-following parameters vary as people's do; a
`ParticipantDriver` (`participant.py`) drives with one of them under a load condition.

Each parameter's distribution is in `DISTRIBUTIONS`, with where its centre comes from:
a published value (the source is named) or, where no study reports the quantity itself,
"fitted": chosen so that the simulated attentive population meets the published outcome in
`literature.csv` (docs/calibration.md shows model and literature side by side). Load effects
are never parameters: the visual-manual and cognitive conditions switch on mechanisms (a
glance process, a task holding response selection) whose parameters are drawn here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Literal

import numpy as np

LOADS = ("baseline", "visual_manual", "cognitive")
POPULATION_SEED = 2026  # the population `participant:ID` specs index into


@dataclass(frozen=True)
class Dist:
    """A between-participant distribution: log-normal (`lognormal`) or normal, with its
    mean and SD in the parameter's units, clipped to [lo, hi]; `source` says where the
    centre comes from."""

    kind: Literal["lognormal", "normal"]
    mean: float
    sd: float
    lo: float
    hi: float
    source: str

    def draw(self, rng: np.random.Generator) -> float:
        if self.sd <= 0.0:
            x = self.mean
        elif self.kind == "lognormal":
            s2 = math.log(1.0 + (self.sd / self.mean) ** 2)
            x = float(rng.lognormal(math.log(self.mean) - 0.5 * s2, math.sqrt(s2)))
        else:
            x = float(rng.normal(self.mean, self.sd))
        return min(self.hi, max(self.lo, x))


@dataclass(frozen=True)
class ParticipantParams:
    """One virtual driver. Times in seconds, lengths in metres; see `DISTRIBUTIONS`."""

    id: int
    # a response to a discrete stimulus: detect -> select (single channel) -> move
    detect_s: float  # sensory detection and perception of a stimulus in view
    select_s: float  # response selection (the central, one-at-a-time stage)
    press_s: float  # finger press of a button
    foot_s: float  # foot from the accelerator to the brake pedal
    recognise_s: float  # extra time to make sense of an event one was not told to expect
    rt_cv: float  # trial-to-trial coefficient of variation of each stage
    sensory_memory_s: float  # a stimulus gone longer than this before selection is lost
    # lane keeping
    steer_gain: float  # multiplies the Stanley steering law (1 = the rule driver's)
    lateral_noise_m: float  # SD of the error in the perceived lateral position
    lateral_noise_tau_s: float  # its correlation time
    steer_noise: float  # SD of motor noise on the steering input (1 = full lock)
    # lane changes and speed
    lane_change_s: float  # duration of a one-lane change
    speed_gain: float  # multiplies the rule driver's pedal gains
    time_headway_s: float  # preferred time gap to a lead car
    # gaze while driving (every load): scanning glances to mirrors and instruments
    scan_per_min: float
    scan_glance_s: float
    # a visual-manual secondary task (visual_manual load)
    task_glance_s: float  # mean off-road glance to the task
    task_glance_sd_s: float
    on_road_glance_s: float  # mean glance back to the road between task glances
    task_episode_s: float  # mean length of one task item (several glances)
    task_gap_s: float  # mean time between task items
    manual_op_s: float  # response selection for one manual entry (end of each task glance)
    # a cognitive secondary task (cognitive load): it holds response selection
    cog_busy: float  # fraction of time a cognitive operation holds the selection stage
    cog_op_s: float  # mean length of one cognitive operation
    # (appended last, with defaults, so that the earlier parameters' draws are unchanged)
    # reading a lane-change sign: a saccade to it and a fixation that reads it, then a choice
    # among the lanes (response selection grows by `choice_bit_s` per bit, Hick-Hyman)
    sign_read_s: float = 0.45
    choice_bit_s: float = 0.15
    # on-road scanning away from the road centre (the roadside, the far road, other lanes);
    # the lane position is sampled (its perceived error corrected) only with the eyes on the
    # road centre, so these glances, like the mirror glances, let the error grow
    road_scan_per_min: float = 12.0
    road_scan_s: float = 0.8


_SRC_GREEN = "fitted: expected brake PRT 0.70-0.75 s (Green 2000)"
_SRC_DRT = "fitted: baseline DRT RT (ISO 17488; Stojmenova & Sodnik 2018)"
DISTRIBUTIONS: dict[str, Dist] = {
    "detect_s": Dist("lognormal", 0.12, 0.02, 0.07, 0.25, _SRC_DRT),
    "select_s": Dist("lognormal", 0.17, 0.045, 0.08, 0.40, _SRC_DRT),
    "press_s": Dist("lognormal", 0.08, 0.015, 0.04, 0.15, _SRC_DRT),
    "foot_s": Dist("lognormal", 0.35, 0.07, 0.18, 0.65, _SRC_GREEN),
    "recognise_s": Dist("lognormal", 0.50, 0.15, 0.15, 1.20, "fitted: unexpected brake PRT ~1.25 s vs 0.70-0.75 s expected (Green 2000)"),
    "rt_cv": Dist("normal", 0.25, 0.05, 0.10, 0.40, "assumed"),
    "sensory_memory_s": Dist("normal", 0.30, 0.05, 0.15, 0.50, "assumed: iconic/echoic persistence of a few hundred ms"),
    "steer_gain": Dist("normal", 0.9, 0.1, 0.6, 1.1, "assumed: at most the rule driver's gains (higher oscillates)"),
    "lateral_noise_m": Dist("lognormal", 0.20, 0.06, 0.06, 0.45, "fitted: SDLP 0.15-0.30 m (sdlp_baseline, unverified)"),
    "lateral_noise_tau_s": Dist("normal", 2.0, 0.4, 1.0, 3.5, "assumed"),
    "steer_noise": Dist("lognormal", 0.002, 0.0008, 0.0005, 0.006, "assumed"),
    "lane_change_s": Dist("lognormal", 4.6, 1.5, 2.5, 10.0, "Toledo & Zohar 2007: mean 4.6 s (unverified); between-driver SD assumed"),
    "speed_gain": Dist("normal", 1.0, 0.15, 0.6, 1.5, "assumed"),
    "time_headway_s": Dist("lognormal", 1.32, 0.45, 0.6, 3.0, "freeway followers: mean 1.32 s, SD 0.52 s (semi-Poisson headways)"),
    "scan_per_min": Dist("normal", 6.0, 2.0, 1.0, 12.0, "assumed: mirror/instrument glances a few per minute"),
    "scan_glance_s": Dist("lognormal", 0.5, 0.12, 0.25, 1.0, "assumed"),
    "task_glance_s": Dist("lognormal", 1.2, 0.3, 0.6, 2.5, "Liang, Horrey & Hoffman 2014: mean off-road glance 1.2-1.5 s"),
    "task_glance_sd_s": Dist("lognormal", 0.5, 0.1, 0.2, 1.0, "assumed"),
    "on_road_glance_s": Dist("lognormal", 0.8, 0.2, 0.4, 1.6, "Liang, Horrey & Hoffman 2014: on-road glances 0.5-1.0 s while multitasking"),
    "task_episode_s": Dist("lognormal", 8.0, 2.0, 3.0, 15.0, "assumed"),
    "task_gap_s": Dist("lognormal", 4.0, 1.0, 1.5, 8.0, "assumed"),
    "manual_op_s": Dist("lognormal", 0.15, 0.04, 0.05, 0.30, "assumed"),
    "cog_busy": Dist("normal", 0.37, 0.08, 0.05, 0.60, "fitted: DRT RT +90-135 ms under a 1-back task (Young, Hsieh & Seaman 2013)"),
    "cog_op_s": Dist("lognormal", 0.60, 0.15, 0.25, 1.20, "fitted: as cog_busy"),
    "sign_read_s": Dist(
        "lognormal", 0.45, 0.08, 0.25, 0.80, "assumed: a saccade (latency ~0.2 s) and a reading fixation (~0.25 s) to a roadside sign"
    ),
    "choice_bit_s": Dist("lognormal", 0.15, 0.04, 0.05, 0.30, "assumed: Hick-Hyman law, ~0.15 s per bit (Hyman 1953; unverified)"),
    "road_scan_per_min": Dist(
        "normal", 12.0, 3.0, 4.0, 24.0, "assumed: with the mirror glances about 20-25 % of gaze off the road centre without a task"
    ),
    "road_scan_s": Dist("lognormal", 0.8, 0.2, 0.4, 1.6, "assumed: as road_scan_per_min"),
}


def draw_participant(participant_id: int, seed: int = POPULATION_SEED) -> ParticipantParams:
    """Participant `participant_id` of the population `seed`: its own seeded stream, so
    participant 7 is the same whether 8 or 800 are drawn."""
    if participant_id < 0:
        raise ValueError(f"participant id must be >= 0, got {participant_id}")
    rng = np.random.default_rng([int(seed), int(participant_id), 0x5EED])
    values = {name: DISTRIBUTIONS[name].draw(rng) for name in (f.name for f in fields(ParticipantParams)) if name != "id"}
    return ParticipantParams(id=participant_id, **values)


def sample_population(n: int, seed: int = POPULATION_SEED) -> list[ParticipantParams]:
    """`n` participants (ids 0..n-1) of the population `seed`; deterministic."""
    if n < 0:
        raise ValueError(f"population size must be >= 0, got {n}")
    return [draw_participant(i, seed) for i in range(n)]
