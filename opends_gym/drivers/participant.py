"""A virtual participant: one driver model whose parameters vary between people.

Why: studies need drivers that differ as people do and that are distracted by the same
mechanisms as people, so that an effect on a metric comes out of the mechanism and not out
of a number put in for that metric. The mechanisms:

* **Responses to discrete stimuli** (a lane-change sign, a lead car's brake light, a brake
  sign, a turn signal, a DRT stimulus) pass three stages: detection (`detect_s`, only while
  the stimulus can be sensed: a stimulus in the forward view needs the eyes on the road, a
  tactile DRT does not), response selection (`select_s`) and movement (`press_s` for a
  button, `foot_s` from accelerator to brake; the accelerator is released when selection
  ends). Response selection is a single channel (Pashler 1994's central bottleneck, the
  psychological refractory period): a response waits while the channel is held by another
  response or by a secondary task's operation. A transient stimulus whose selection cannot
  start within `sensory_memory_s` of its end is lost (a miss). An event the driver was not
  told to expect (`instructed=False`) needs `recognise_s` more to be made sense of
  (Green 2000: expectancy roughly doubles brake reaction time). A lane-change sign is read
  first (`sign_read_s`: a saccade to the roadside sign and a fixation on it) and names one
  of the road's lanes, so its selection is a choice that takes `choice_bit_s` longer per
  bit (the Hick-Hyman law).
* **Gaze**: at every load the driver scans mirrors and instruments (`scan_per_min` brief
  glances) and, on the road, the scene away from its centre (`road_scan_per_min`, the
  roadside, the far road); starting a glance is a voluntary act that needs the selection
  channel free.
  During an off-road glance the driver acts on the **stale percept** from when the eyes left
  the road (the steering is held, the car drifts, forward stimuli go unseen) and corrects
  when the eyes return.
* **Visual-manual load**: a secondary task of items (`task_episode_s`, gaps `task_gap_s`)
  done in off-road glances (`task_glance_s`) alternating with glances back to the road
  (`on_road_glance_s`); each task glance ends with a manual entry that holds the selection
  channel for `manual_op_s`. Glances are deferred during a lane change.
* **Cognitive load**: no glances away; a task (an n-back, a conversation) holds the
  selection channel for operations of `cog_op_s` a fraction `cog_busy` of the time. Every
  response then waits longer (DRT, brake, lane-change initiation alike) and scanning glances
  that fall in a busy moment are not made, so the gaze concentrates on the road ahead
  (Engström, Johansson & Östlund 2005; Victor, Harbluk & Engström 2005).
* **Control**: lane keeping, an automatic skill that never waits for the selection channel,
  by the rule driver's Stanley law (`steer_gain`) on a perceived lateral position with a
  slowly varying error that grows all the time and is corrected (correlation time
  `lateral_noise_tau_s`) only while the eyes are on the road centre: its SD is
  `lateral_noise_m` at the participant's own road-centre share without a task, lower when a
  cognitive task suppresses scanning, higher with glances to a secondary task; motor noise
  (`steer_noise`); lane changes along a smooth (half-cosine) path lasting `lane_change_s` for
  one lane (a sign-cued change is cut short only where it would run past the point at which
  the next sign can be read); while the eyes are away the held wheel wanders (the
  motor noise accumulates, uncorrected, until the eyes return); speed and car following by the
  rule driver's controllers with `speed_gain` and the participant's `time_headway_s` (in a
  platoon task, clipped to the task's distance band unless `keep_band=False`).

Each random process (response jitter, lateral and motor noise, scanning, the cognitive
task, the visual-manual task) draws from its own stream seeded by the episode seed, the
participant and the load: as with a person, each drive has its own noise, so a study's
within-participant differences and its power analysis carry trial-to-trial noise.
`common_noise=True` leaves the load out of the seeds (common random numbers): a participant
then meets the same noise under every load and a load's effect is its mechanism's alone,
with the same expectation and less variance; the calibration (`calibration.py`) uses it.

The rule driver (`rule.py`) stays the perfect reference; this is the human one.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..control.controllers import stanley_steering
from .distracted import DistractionParams, GlanceProcess, _lognormal
from .intent import Intent, to_action
from .percept import Percept, find_drt, perceive
from .percept import evolve as replace  # dataclasses.replace, faster (the hot path of a study)
from .population import LOADS, ParticipantParams
from .rule import RuleDriver, RuleParams, start_engine

MANOEUVRE_OFFSET_M = 0.5  # a lane change is under way while the plan is this far from its end
# a sign-cued change (LCT) lasts the participant's own `lane_change_s` unless that would
# carry it past where the next sign can be read: on a track with a `geometry` (the LCT) at
# its shortest sign spacing less the visibility distance, else this far past the sign
FINISH_AFTER_SIGN_M = 100.0
# a lane change the driver is timed on (OpenDS's LaneChangeReactionTimer, which also wants a
# minimum steering angle) is made swiftly: at most this long per lane (an assumption; the rule
# driver's reaction change is 20 m per lane, 1.2 s at 60 km/h)
REACTION_LANE_CHANGE_S = 2.0
PRESS_HOLD_S = 0.15  # how long a button is held down
STANDSTILL_GAP_M = 2.0
BRAKE_NEED = 0.02
# a platoon task's band (20-35 m in the TVPT) spans its centre +-25 %: a participant told to
# keep it follows at its own time headway clipped to that span
BAND_SHARE = 0.25  # the speed controller calls for the brake below this pedal
VISUAL_DRT = ("visual", "remote", "rdrt", "hdrt", "head-mounted")


class CentralChannel:
    """The single response-selection channel, shared by responses and a secondary task's
    operations (alternating idle and busy spells, exponential, busy a fraction `busy`)."""

    def __init__(self, rng: np.random.Generator, busy: float, op_s: float) -> None:
        self.rng = rng
        self.busy = busy
        self.op_s = op_s
        self.free_at = 0.0  # reserved by responses until then
        self.op_start = math.inf
        self.op_end = -math.inf
        if busy > 0.0:
            self.op_start = self._idle(0.0)
            self.op_end = self.op_start + float(rng.exponential(op_s))

    def _idle(self, now: float) -> float:
        return now + float(self.rng.exponential(self.op_s * (1.0 - self.busy) / self.busy))

    def _advance(self, t: float) -> None:
        while self.op_end <= t and self.busy > 0.0:
            self.op_start = self._idle(self.op_end)
            self.op_end = self.op_start + float(self.rng.exponential(self.op_s))

    def busy_at(self, t: float) -> bool:
        self._advance(t)
        return t < self.free_at or self.op_start <= t < self.op_end

    def acquire(self, ready: float, duration: float) -> float:
        """Reserve the channel for `duration` from the first free moment at or after
        `ready`; returns when the selection starts. A task operation due meanwhile waits."""
        start = max(ready, self.free_at)
        self._advance(start)
        if self.op_start <= start < self.op_end:
            start = self.op_end
            self._advance(start)
        end = start + duration
        if self.op_start < end:  # the task's next operation waits for this selection
            length = self.op_end - self.op_start
            self.op_start, self.op_end = end, end + length
        self.free_at = end
        return start


class ParticipantDriver:
    """`ParticipantDriver(env, params, load, seed)`; drive with `act(obs, info)` (or
    `act(obs)`), restart with `reset(seed)` or `reset(env, seed)` (the agent interface of
    `drivers.agents`). `glances` lists the (start_s, end_s) of every off-road glance of the
    episode so far, in simulation time."""

    def __init__(
        self,
        env: Any = None,
        params: ParticipantParams | None = None,
        load: str = "baseline",
        seed: int = 0,
        *,
        instructed: bool = True,
        drt_modality: str | None = None,
        keep_band: bool = True,
        common_noise: bool = False,
    ) -> None:
        if load not in LOADS:
            raise ValueError(f"unknown load {load!r}; use one of {', '.join(LOADS)}")
        if params is None:
            from .population import draw_participant

            params = draw_participant(0)
        self.params = params
        self.load = load
        self.instructed = instructed
        self.keep_band = keep_band
        self.common_noise = common_noise
        self.drt_modality = drt_modality
        self.name = f"participant:{params.id}:{load}"
        self.env: Any = env
        self._seed = seed
        if env is not None:
            self.reset(env, seed)

    # ------------------------------------------------------------------ episode
    def reset(self, env: Any = None, seed: int | None = None) -> None:
        """`reset(seed)` or `reset(env, seed)`: a new episode (the same seed, the same drive)."""
        if env is not None and not hasattr(env, "unwrapped"):
            env, seed = None, int(env)
        if env is not None:
            self.env = env
        if self.env is None:
            raise ValueError("ParticipantDriver needs an env: ParticipantDriver(env, params) or reset(env, seed)")
        self._seed = int(seed) if seed is not None else self._seed
        p = self.params
        # one stream per process (see the module docstring on `common_noise`)
        self.rng = self._stream(0xD71E)  # response jitter
        self._lat_rng = self._stream(0x1A7E)  # perceived-position error and motor noise
        self._scan_rng = self._stream(0x5CA2)  # scanning glances
        self._road_scan_until = -math.inf
        self._next_road_scan = self._road_scan_gap(0.0)
        self._f0 = self._centre_share()
        rule_params = RuleParams(
            throttle_kp=RuleParams.throttle_kp * p.speed_gain,
            brake_kp=RuleParams.brake_kp * p.speed_gain,
            speed_ki=RuleParams.speed_ki * p.speed_gain,
            idm_time_gap_s=p.time_headway_s,
        )
        self.rule = RuleDriver(rule_params)
        self.rule.reset(self.env, self._seed)
        cognitive = self.load == "cognitive"
        self.channel = CentralChannel(self._stream(0xC06), p.cog_busy if cognitive else 0.0, p.cog_op_s)
        self.task: GlanceProcess | None = None
        if self.load == "visual_manual":
            duty = p.task_episode_s / (p.task_episode_s + p.task_gap_s)
            dp = DistractionParams(
                duty_cycle=duty,
                task_episode_s=p.task_episode_s,
                glance_mean_s=p.task_glance_s,
                glance_sd_s=p.task_glance_sd_s,
                on_road_glance_s=p.on_road_glance_s,
            )
            self.task = GlanceProcess(dp, self._stream(0x7A5C))
        self.drt = find_drt(self.env)
        modality = self.drt_modality or str(getattr(self.drt, "modality", "tactile"))
        self.drt_visual = modality.lower() in VISUAL_DRT
        base: Any = self.env.unwrapped
        self._dt = float(base.world.dt_s)
        self._lane_w = float(getattr(base.guide, "lane_width_m", 3.75) or 3.75)
        g = getattr(base, "geometry", None)
        spacing, seen_at = getattr(g, "spacing_min_m", None), getattr(g, "visibility_m", None)
        self._finish_after_sign_m = FINISH_AFTER_SIGN_M
        if spacing is not None and seen_at is not None:  # (a next sign readable already: end by this one)
            self._finish_after_sign_m = max(0.0, float(spacing - seen_at))
        self._lanes = len(getattr(base.guide, "lane_laterals_m", ()) or ()) or 1
        # gaze
        self._next_scan = self._scan_gap(0.0)
        self._scan_until = -math.inf
        self._off = False
        self._off_since = 0.0
        self._on_since = 0.0
        self._closed: list[tuple[float, float]] = []
        self._last_t: float | None = None
        self._task_was_off = False
        # percepts
        self._stale: Percept | None = None
        self._noise = 0.0
        # stimuli: the values acted on, and the responses under way
        self._ack: dict[str, Any] = {}
        self._pending: dict[str, tuple[Any, float, float]] = {}  # channel -> (value, release_t, due_t)
        self._drt_seen = 0
        self._drt_waiting: list[float] = []  # onsets not yet seen (visual DRT, eyes away)
        self._drt_due: list[float] = []
        self._press_until = -math.inf
        self._plan: tuple[float, float, float, float] | None = None  # from, to, t0, duration
        self._foot_on_brake = False
        self._brake_pending: tuple[float, float] | None = None  # (accelerator released, brake reached)
        self._last_pedal = 0.0
        self._drift = 0.0

    @property
    def glances(self) -> list[tuple[float, float]]:
        """(start_s, end_s) of each off-road glance so far (one still going ends now)."""
        if self._off and self._last_t is not None and self._last_t > self._off_since:
            return [*self._closed, (self._off_since, self._last_t)]
        return list(self._closed)

    # ------------------------------------------------------------------ helpers
    def _stream(self, tag: int) -> np.random.Generator:
        load = [] if self.common_noise else [LOADS.index(self.load)]
        return np.random.default_rng([self._seed, self.params.id, tag, *load])

    def _centre_share(self) -> float:
        """The share of time the eyes are on the road centre with no secondary task (the
        participant's own scanning): the lane-position error is calibrated at this share."""
        p = self.params
        return max(0.3, 1.0 - (p.scan_per_min * p.scan_glance_s + p.road_scan_per_min * p.road_scan_s) / 60.0)

    def _road_scan_gap(self, now: float) -> float:
        rate = self.params.road_scan_per_min / 60.0
        return now + float(self._scan_rng.exponential(1.0 / rate)) if rate > 0 else math.inf

    def _jit(self, mean: float) -> float:
        return _lognormal(self.rng, mean, self.params.rt_cv * mean)

    def _scan_gap(self, now: float) -> float:
        rate = self.params.scan_per_min / 60.0
        return now + float(self._scan_rng.exponential(1.0 / rate)) if rate > 0 else math.inf

    def _gaze(self, t: float, may_look_away: bool) -> bool:
        """Whether the eyes are off the road now (advancing the glance processes)."""
        task_off = self.task.eyes_off_road(t, may_look_away) if self.task is not None else False
        if self._task_was_off and not task_off:  # a task glance ended with a manual entry
            self.channel.acquire(t, self._jit(self.params.manual_op_s))
        self._task_was_off = task_off
        p = self.params
        if t >= self._next_scan and t >= self._scan_until:
            length = _lognormal(self._scan_rng, p.scan_glance_s, 0.3 * p.scan_glance_s)  # (drawn either way: common streams)
            if may_look_away and not task_off and not self.channel.busy_at(t):
                self._scan_until = t + length
            self._next_scan = self._scan_gap(t)
        if t >= self._next_road_scan and t >= self._road_scan_until:
            # a glance across the road scene away from its centre: voluntary too, so it is
            # not made while the channel is busy (gaze concentration under cognitive load)
            length = _lognormal(self._scan_rng, p.road_scan_s, 0.3 * p.road_scan_s)
            if not task_off and not self.channel.busy_at(t):
                self._road_scan_until = t + length
            self._next_road_scan = self._road_scan_gap(t)
        return task_off or t < self._scan_until

    def _respond(
        self, t_det: float, movement_s: float, lost_after: float = math.inf, recognise: bool = False, read_choices: int = 0
    ) -> tuple[float, float] | None:
        """(selection end, movement end) of a response to a stimulus detected at `t_det`, or
        None when the stimulus is lost before selection can start. `read_choices` > 0: the
        stimulus is a sign to be read (`sign_read_s`) naming one of that many responses, whose
        selection takes `choice_bit_s` longer per bit (the Hick-Hyman law)."""
        p = self.params
        ready = t_det + self._jit(p.detect_s) + (self._jit(p.recognise_s) if recognise else 0.0)
        if read_choices > 0:
            ready += self._jit(p.sign_read_s)
        select = self._jit(p.select_s + p.choice_bit_s * math.log2(max(read_choices, 1)))
        if self.channel.busy_at(ready) or ready < self.channel.free_at:
            probe = max(ready, self.channel.free_at)
            if self.channel.op_start <= probe < self.channel.op_end:
                probe = self.channel.op_end
            if probe > lost_after:
                return None
        start = self.channel.acquire(ready, select)
        end = start + select
        return end, end + (self._jit(movement_s) if movement_s > 0 else 0.0)

    # ------------------------------------------------------------------ acting
    def act(self, obs: Any, info: dict[str, Any] | None = None) -> Any:
        env = self.env
        now = perceive(env)  # (the DRT is read from its wrapper, by modality)
        start_engine(env, now)
        t = now.t_s
        dt = 0.0 if self._last_t is None else max(0.0, t - self._last_t)
        settled = self._plan is None or t >= self._plan[2] + self._plan[3]
        off = self._gaze(t, settled and abs(now.heading_error_rad) < 0.05)
        if off and not self._off:
            self._off_since = t
        if not off and self._off:
            self._closed.append((self._off_since, t))
            self._on_since = t
        self._off = off
        self._last_t = t
        # perceived lateral position: a slowly varying error that grows all the time and is
        # corrected (decays, correlation time `lateral_noise_tau_s`) only while the eyes are
        # on the road centre, where the lane is sampled: an Ornstein-Uhlenbeck process whose
        # SD is `lateral_noise_m` at the participant's own share of road-centre gaze without a
        # task (`_f0`) and scales with sqrt(f0 / share): gaze concentration under cognitive
        # load lowers it, glances away raise it (Victor, Harbluk & Engstrom 2005)
        p = self.params
        if dt > 0:
            centre = not off and t >= self._road_scan_until
            a = math.exp(-dt / p.lateral_noise_tau_s) if centre else 1.0
            q = p.lateral_noise_m * math.sqrt(2.0 * self._f0 * dt / p.lateral_noise_tau_s)
            self._noise = a * self._noise + q * float(self._lat_rng.normal())
        if off:
            if self._stale is None:
                self._stale = replace(now, lateral_m=now.lateral_m + self._noise)
            road = self._stale
        else:
            self._stale = None
            road = replace(now, lateral_m=now.lateral_m + self._noise)
        self._stimuli(now, t, off)
        self._drt_step(t, off)
        seen = self._seen(road, t)
        steer = self._steer(seen, t if not off else road.t_s)
        pedal = self._pedal(seen, t)
        press = t < self._press_until
        intent = self.rule.decide(seen) if (seen.aim is not None or seen.contre is not None) else None
        if intent is None:
            intent = Intent(
                steering=steer,
                pedal=pedal,
                reaction=press,
                target_lateral_m=seen.target_lateral_m,
                target_speed_mps=seen.brake_to_mps if seen.brake_to_mps is not None else seen.cruise_mps,
            )
        else:
            intent = replace(intent, reaction=press)
        noise = float(self._lat_rng.normal(0.0, p.steer_noise))
        # with the eyes away the held wheel wanders: the motor noise accumulates unseen
        self._drift = self._drift + noise if off else 0.0
        intent = replace(intent, steering=max(-1.0, min(1.0, intent.steering + noise + self._drift)))
        return to_action(env, intent)

    _CHANNELS = ("target_lateral_m", "press_reaction")

    def _stimuli(self, now: Percept, t: float, off: bool) -> None:
        """Schedule a response to each change of a forward-view stimulus the eyes see."""
        for ch in self._CHANNELS:
            value = getattr(now, ch)
            if ch not in self._ack:  # the state at the start needs no response
                self._ack[ch] = value if ch != "press_reaction" else False
                continue
            pend = self._pending.get(ch)
            if value == self._ack[ch]:
                if pend is not None and ch != "press_reaction":
                    del self._pending[ch]
                continue
            if off or (pend is not None and pend[0] == value):
                continue
            if ch == "press_reaction" and not value:
                continue
            if ch == "press_reaction":
                r = self._respond(t, self.params.press_s)
            else:  # a new lane: read off a sign (LCT, reaction test) naming one of the lanes
                r = self._respond(t, 0.0, read_choices=self._lanes if now.lane_change_pending else 0)
            if r is not None:
                self._pending[ch] = (value, r[0], r[1])
        for ch, (value, _, due) in list(self._pending.items()):
            if t + self._dt >= due:
                del self._pending[ch]
                if ch == "press_reaction":
                    self._press_until = t + PRESS_HOLD_S
                    self._ack[ch] = False
                else:
                    self._ack[ch] = value

    def _drt_step(self, t: float, off: bool) -> None:
        drt = self.drt
        if drt is None:
            return
        onsets = getattr(drt, "onsets", [])
        while self._drt_seen < len(onsets):
            self._drt_waiting.append(float(onsets[self._drt_seen]))
            self._drt_seen += 1
        shown = float(getattr(drt, "stimulus_s", 1.0))
        keep = []
        for onset in self._drt_waiting:
            if self.drt_visual and off:
                if t - onset < shown:
                    keep.append(onset)
                continue  # (gone unseen: a miss)
            t_det = onset if not self.drt_visual else max(onset, self._on_since)
            if t_det >= onset + shown:
                continue
            r = self._respond(t_det, self.params.press_s, lost_after=onset + shown + self.params.sensory_memory_s)
            if r is not None:
                self._drt_due.append(r[1])
        self._drt_waiting = keep
        due = sorted(self._drt_due)
        if due and t + self._dt >= due[0] and t >= self._press_until + self._dt:
            self._press_until = t + PRESS_HOLD_S
            due.pop(0)
        self._drt_due = due

    def _seen(self, road: Percept, t: float) -> Percept:
        """The road percept with the stimuli the driver has responded to."""
        seen = replace(road, target_lateral_m=self._ack.get("target_lateral_m", road.target_lateral_m))
        if seen.lead is not None and seen.follow_gap_m is not None:
            gap = STANDSTILL_GAP_M + self.params.time_headway_s * max(seen.lead.speed_mps, 0.0)
            if self.keep_band:  # told to keep the task's distance band: the preference within it
                gap = min(max(gap, (1.0 - BAND_SHARE) * seen.follow_gap_m), (1.0 + BAND_SHARE) * seen.follow_gap_m)
            seen = replace(seen, follow_gap_m=gap)
        return seen

    def _steer(self, p: Percept, t: float) -> float:
        target = p.target_lateral_m
        if self._plan is None:
            self._plan = (target, target, t, 0.0)
        b = self._plan[1]
        if abs(target - b) > 1e-6:  # a new lane to be in: plan a lane change from here
            here = self._plan_at(t)[0]
            lanes = abs(target - here) / self._lane_w
            dur = self._jit(self.params.lane_change_s) * math.sqrt(max(lanes, 0.05))
            if p.sign_distance_m is not None:  # a deadline: the sign
                dur = min(dur, (p.sign_distance_m + self._finish_after_sign_m) / max(p.speed_mps, 1.0))
            elif p.lane_change_pending:  # a timed reaction (OpenDS reaction test): a swift change
                dur = min(dur, REACTION_LANE_CHANGE_S * math.sqrt(max(lanes, 0.05)))
            self._plan = (here, target, t, dur)
        lat, slope_t = self._plan_at(t)
        heading = math.atan2(slope_t, max(p.speed_mps, 1.0))
        raw = stanley_steering(p.heading_error_rad, heading, p.lateral_m, lat, p.speed_mps, p.yaw_rate_radps)
        return max(-1.0, min(1.0, self.params.steer_gain * raw))

    def _plan_at(self, t: float) -> tuple[float, float]:
        """The planned lateral position and its rate (m/s) at `t`."""
        assert self._plan is not None
        a, b, t0, dur = self._plan
        if dur <= 0.0 or t >= t0 + dur:
            return b, 0.0
        u = max(0.0, (t - t0) / dur)
        return a + (b - a) * 0.5 * (1.0 - math.cos(math.pi * u)), (b - a) * 0.5 * math.pi * math.sin(math.pi * u) / dur

    def _pedal(self, p: Percept, t: float) -> float:
        """The rule driver's speed control, except that braking is a discrete response: when
        the controller calls for the brake (a brake light, a brake sign, a closing gap), the
        foot stays where it was until selection ends, leaves the accelerator, and reaches the
        brake `foot_s` later. An event the driver was not told to expect (`instructed=False`)
        needs `recognise_s` more (Green 2000)."""
        raw = self.rule._pedal(p)
        if raw >= -BRAKE_NEED:
            # a brake need this small is met by coasting: the foot eases off the accelerator
            # but stays on it (the car coasts with the pedal in its dead travel, `pedal_map`)
            self._foot_on_brake = False
            self._brake_pending = None
            self._last_pedal = max(raw, self.rule.pedals.coast_throttle(p.speed_mps))
            return self._last_pedal
        if self._foot_on_brake:
            return raw
        if self._brake_pending is None:
            r = self._respond(t, self.params.foot_s, recognise=not self.instructed)
            self._brake_pending = r if r is not None else (t, t + self.params.foot_s)
        release, due = self._brake_pending
        if t + self._dt >= due:
            self._foot_on_brake = True
            self._brake_pending = None
            return raw
        return 0.0 if t + self._dt >= release else self._last_pedal
