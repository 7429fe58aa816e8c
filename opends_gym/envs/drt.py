"""Detection Response Task (ISO 17488) as a wrapper around any OpenDS env.

Why: the DRT measures cognitive load by how fast and how often a driver answers a
simple stimulus. A stimulus appears every 3-5 s (uniform, from the env's seeded RNG) for
1 s or until answered; a response 100-2500 ms after onset is a hit, < 100 ms premature.
The response is the `reaction` button of the `continuous_buttons` action type (or any
action whose `drt_response(action)` is true for custom spaces). Timing is in simulation
time at the physics rate, so a response is scored to the physics step.

Adds to the observation nothing (wrap with your own stimulus channel if the agent must see
it: `info["drt_stimulus_on"]` tells whether it is shown); adds info keys
`drt_stimulus_on` (0/1) and `drt_modality` (1 visual, 2 tactile, 3 auditory: ISO 17488's
three DRT variants; the wrapper's `modality` names it) and, in `episode_metrics`,
`drt_stimuli`, `drt_hits`, `drt_misses`, `drt_premature`, `drt_false_alarms` (presses
that answered no stimulus), `drt_hit_rate`, `drt_mean_rt_s`, `drt_median_rt_s`,
`drt_sd_rt_s` and `drt_modality`; `stimuli_presented` (the env's exposure count) adds the
DRT stimuli. The modality is a label for the analysis (which
stimulus a driver model must perceive): the wrapper shows nothing itself.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ..metrics.reaction import RtDistribution, score_drt

MODALITIES = {"visual": 1.0, "tactile": 2.0, "auditory": 3.0}  # ISO 17488: remote/head-mounted visual, tactile, auditory


class DetectionResponseTask(gym.Wrapper[Any, Any, Any, Any], gym.utils.RecordConstructorArgs):
    def __init__(
        self,
        env: gym.Env[Any, Any],
        min_interval_s: float = 3.0,
        max_interval_s: float = 5.0,
        stimulus_s: float = 1.0,
        response_index: int = 2,
        modality: str = "visual",
    ) -> None:
        gym.utils.RecordConstructorArgs.__init__(
            self,
            min_interval_s=min_interval_s,
            max_interval_s=max_interval_s,
            stimulus_s=stimulus_s,
            response_index=response_index,
            modality=modality,
        )
        if modality not in MODALITIES:
            raise ValueError(f"DetectionResponseTask modality must be one of {', '.join(MODALITIES)}, not {modality!r}")
        self.modality = modality
        super().__init__(env)
        self.min_interval_s = min_interval_s
        self.max_interval_s = max_interval_s
        self.stimulus_s = stimulus_s
        self.response_index = response_index
        self._held = False

    def _next_onset(self, now: float) -> float:
        return now + float(self._rng.uniform(self.min_interval_s, self.max_interval_s))

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        # the stimulus schedule comes from the env's seeded RNG: same seed, same schedule
        self._rng = np.random.default_rng(int(self.env.unwrapped.np_random.integers(0, 2**31 - 1)))
        self.onsets: list[float] = []
        self.responses: list[float] = []
        self._held = False
        self._pending = self._next_onset(0.0)
        info["drt_stimulus_on"] = 0.0
        info["drt_modality"] = MODALITIES[self.modality]
        return obs, info

    def _pressed(self, action: Any) -> bool:
        a = np.asarray(action).reshape(-1)
        down = bool(len(a) > self.response_index and a[self.response_index] > 0.0)
        pressed = down and not self._held
        self._held = down
        return pressed

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        t_before = float(self.env.unwrapped.world.t_s)  # type: ignore[attr-defined]
        pressed = self._pressed(action)
        obs, reward, terminated, truncated, info = self.env.step(action)
        t_now = float(info["sim_time_s"])
        if pressed:
            # the press happens on the first physics step of this policy step
            self.responses.append(t_before + float(self.env.unwrapped.world.dt_s))  # type: ignore[attr-defined]
        while self._pending <= t_now:
            self.onsets.append(self._pending)
            self._pending = self._next_onset(self._pending)
        last = self.onsets[-1] if self.onsets else -1e9
        answered = any(r >= last for r in self.responses) if self.onsets else False
        info["drt_stimulus_on"] = 1.0 if (t_now - last) < self.stimulus_s and not answered else 0.0
        info["drt_modality"] = MODALITIES[self.modality]
        if "episode_metrics" in info:
            m = info["episode_metrics"]
            m.update(self.drt_metrics())
            m["stimuli_presented"] = m.get("stimuli_presented", 0.0) + m["drt_stimuli"]  # exposure: the env's and the DRT's
        return obs, float(reward), terminated, truncated, info

    def drt_metrics(self) -> dict[str, float]:
        s = score_drt(self.onsets, self.responses)
        dist = RtDistribution.of(s.rts_s)
        return {
            "drt_stimuli": float(s.stimuli),
            "drt_hits": float(s.hits),
            "drt_misses": float(s.misses),
            "drt_premature": float(s.premature),
            "drt_hit_rate": s.hit_rate,
            "drt_mean_rt_s": s.mean_rt_s,
            "drt_false_alarms": float(s.false_alarms),
            "drt_median_rt_s": dist.median_s,
            "drt_sd_rt_s": dist.sd_s,
            "drt_modality": MODALITIES[self.modality],
        }
