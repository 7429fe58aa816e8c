"""`OpenDS/BrakeReaction-v0`: brake reactions to a lead vehicle and to signs."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..metrics.reaction import brake_reaction_time, score_brake_trials
from ..sim.triggers.reactions import ReactionResult
from ..task import DrivingTask
from .platoon import PlatoonConfig, ThreeVehiclePlatoonEnv
from .platoon_core import Stimulus
from .platoon_task import BRAKE_STIMULI, build_platoon_task


@dataclass(frozen=True)
class BrakeReactionConfig(PlatoonConfig):
    speed_kmh: float = 70.0
    stimuli: int = 9
    action: str = "continuous"
    reward_ttc_weight: float = 1.0
    reward_sign_reaction: float = 10.0


class BrakeReactionEnv(ThreeVehiclePlatoonEnv):
    """Brake reaction test: follow a leading car (kept 20-50 m ahead) at ~70 km/h and brake
    when (a) its brake light comes on, (b) it brakes hard (emergency brake to a stop), or
    (c) a "Brake" sign is revealed over the lane (an OpenDS brake reaction timer: slow to
    <= 40 km/h and hold 1 s within 7 s). Stimuli alternate in a seeded order
    (`opends_gym.envs.platoon_task`).

    ## Action space
    Default `continuous`: Box(-1, 1, (2,)): [steering (+ left), pedal (+ gas, - brake)].

    ## Observation space
    `kinematics` plus the platoon stimulus slots (lead gap, relative speed, brake light,
    turn signal; the follower slots stay 0) and `brake_sign_visible`.

    ## Reward
    The platoon test's (progress, band deviation, lead-car stimulus reactions, collisions,
    leaving the road; see `ThreeVehiclePlatoonEnv`) plus `reward_sign_reaction` (10) per
    correct and minus it per failed or missed brake-sign reaction (slowing to 40 km/h costs
    more progress than a reward of 1 would repay), and time-to-collision shaping
    (`reward_ttc_weight` = 1: -(1 - TTC / 3 s) per step while the TTC to the lead car is
    under `reward_ttc_threshold_s` = 3 s), which teaches a policy to open the gap before
    the lead's emergency brake rather than learn the collision penalty only after crashing.

    ## Episode end
    Terminated at the end of the track, on a collision (`on_collision="terminate"`, the
    default; `recover`, the study default, puts the car back at rest behind the lead car
    instead, see `opends_gym.envs.collision`), off the road (`on_road_exit`) or when drawing
    level with the lead car (`end_when_past_lead`); truncated after `max_episode_s`.

    ## Info
    `OpenDSEnv`'s keys; `episode_metrics` adds the platoon stimulus measures for the
    lead-car stimuli, the brake-sign timer results (`BrakeSign_n`, `BrakeSign_correct`,
    `BrakeSign_misses`, `BrakeSign_mean_rt_s`; `BrakeSign_reset`: signs met only because a
    reset put the car at rest, not counted as correct; `BrakeSign_unscored`: signs revealed
    that no timer scored, as when the car was below the timer's start speed) and, over all lead-car stimuli, the mean
    accelerator-release time and brake-onset time after stimulus onset
    (`accelerator_release_s`, `brake_onset_s`; the latter is the brake reaction time).
    Scored as trials (`metrics.reaction.score_brake_trials`): `brake_trials`,
    `brake_trials_invalid` (foot not on the accelerator, or on the brake, at onset),
    `brake_responses`, `brake_misses` (no brake onset within 5 s, counted),
    `brake_miss_rate`, and the distribution of the responses' brake onset times
    `brake_rt_mean_s`, `brake_rt_median_s`, `brake_rt_sd_s`, `brake_rt_p15_s`,
    `brake_rt_p85_s`, plus `brake_release_mean_s` (accelerator release).

    ## Version history
    v0: initial release.
    """

    config_class = BrakeReactionConfig
    stimulus_names = ThreeVehiclePlatoonEnv.stimulus_names + ("brake_sign_visible",)
    with_follower = False

    def _make_task(self) -> DrivingTask:
        # the platoon geometry from this env's options, without a follower and with brake stimuli
        return build_platoon_task(replace(self.geometry(), follower=False, kinds=BRAKE_STIMULI), name="brakeReaction")

    def _setup(self) -> None:
        super()._setup()
        self._signs = [objs[0] for oid, objs in self.world.objects.by_id.items() if oid.endswith("_Sign")]
        self._shown: set[str] = set()  # brake signs revealed this episode

    def _reset_task(self, options: dict[str, Any] | None) -> None:
        super()._reset_task(options)
        self._shown = set()

    def _task_info(self, info: dict[str, Any]) -> None:
        super()._task_info(info)
        self._shown.update(o.id for o in self._signs if o.visible)

    def _stimuli_presented(self) -> int:
        """The lead car's stimuli started plus the brake signs revealed (scored or not: a
        sign revealed while the car is slower than the timer's start speed, e.g. just after a
        reset, is shown but OpenDS's `BrakeReactionTimer` does not time it; see
        `BrakeSign_unscored`). (The native batch loads `_shown` into its template.)"""
        return super()._stimuli_presented() + len(self._shown)

    def _stimulus(self) -> list[float]:
        z = self.world.ego.state.z
        visible = any(o.visible and o.position[2] < z for o in self._signs)
        return super()._stimulus() + [1.0 if visible else 0.0]

    def _reward(self, info: dict[str, Any]) -> float:
        r = super()._reward(info)
        bonus = self.config.reward_sign_reaction  # type: ignore[attr-defined]
        if info["reaction_result"] == 1:
            r += bonus
        elif info["reaction_result"] < 0:
            r -= bonus
        return r

    def _episode_metrics(self) -> dict[str, float]:
        out = super()._episode_metrics()
        tr = self.trace
        reset_t = [e.t_s for e in self.world.events.since(0) if e.kind == "reset"]
        reactions = getattr(self.world.triggers, "reactions", ())
        out.update(brake_metrics(tr.col("t_s"), tr.col("accelerator"), tr.col("brake"), self.platoon.state.stimuli, reactions, reset_t,
                                 len(self._shown)))  # fmt: skip
        return out


def brake_metrics(t_s: np.ndarray, accelerator: np.ndarray, brake: np.ndarray, stimuli: Sequence[Stimulus],
                  all_reactions: Iterable[ReactionResult], reset_t: Sequence[float], shown: int) -> dict[str, float]:  # fmt: skip
    """`BrakeReactionEnv`'s own episode metrics (the brake sign timers' results and the brake
    trials of the lead car's brake stimuli) from an episode's trace columns, its stimuli, its
    reaction results, the times of its resets and the number of brake signs revealed (a
    function: the native batch scores its episodes with it too)."""
    out: dict[str, float] = {}
    reactions = [r for r in all_reactions if r.group == "BrakeSign"]
    # a sign "obeyed" because a reset put the car at rest is no reaction of the driver
    by_reset = [r for r in reactions if r.result == 1 and any(r.start_t_s <= t <= r.t_s for t in reset_t)]
    correct = [r for r in reactions if r.result == 1 and r not in by_reset]
    rts = [r.reaction_time_s for r in correct]
    out["BrakeSign_n"] = float(len(reactions))
    out["BrakeSign_correct"] = float(len(correct))
    out["BrakeSign_reset"] = float(len(by_reset))
    out["BrakeSign_unscored"] = float(max(0, shown - len(reactions)))
    out["BrakeSign_misses"] = float(sum(1 for r in reactions if r.result == -2))
    out["BrakeSign_mean_rt_s"] = float(np.mean(rts)) if rts else math.nan
    releases, onsets = [], []
    for st in stimuli:
        if st.kind in ("brakeLight", "emergencyBrake"):
            b = brake_reaction_time(t_s, accelerator, brake, st.onset_s)
            releases.append(b.accelerator_release_s)
            onsets.append(b.brake_onset_s)
    finite = [v for v in onsets if math.isfinite(v)]
    out["accelerator_release_s"] = float(np.nanmean(releases)) if any(math.isfinite(v) for v in releases) else math.nan
    out["brake_onset_s"] = float(np.mean(finite)) if finite else math.nan
    onsets = [st.onset_s for st in stimuli if st.kind in ("brakeLight", "emergencyBrake")]
    _, summary = score_brake_trials(t_s, accelerator, brake, onsets)
    rt = summary.rt
    out.update({
        "brake_trials": float(summary.trials),
        "brake_trials_invalid": float(summary.invalid),
        "brake_responses": float(summary.responses),
        "brake_misses": float(summary.misses),
        "brake_miss_rate": summary.miss_rate,
        "brake_rt_mean_s": rt.mean_s,
        "brake_rt_median_s": rt.median_s,
        "brake_rt_sd_s": rt.sd_s,
        "brake_rt_p15_s": rt.p15_s,
        "brake_rt_p85_s": rt.p85_s,
        "brake_release_mean_s": summary.release.mean_s,
    })  # fmt: skip
    return out
