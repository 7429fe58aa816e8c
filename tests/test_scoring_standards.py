"""Scoring that follows the standards (ISO 26022, SAE J2944, ISO 17488, ISO 15007 / NHTSA
2013, reversal rate, car following, brake trials) against hand-computed cases."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.drivers.episodes import run_episode
from opends_gym.drivers.rule import RuleDriver, RuleParams
from opends_gym.envs.drt import DetectionResponseTask
from opends_gym.metrics import LctSign, NormativeModel
from opends_gym.metrics.glance import glance_metrics, nhtsa_pass_share
from opends_gym.metrics.headway import FollowingCriterion, car_following_summary
from opends_gym.metrics.lateral import sdlp_segments
from opends_gym.metrics.lct_iso import CORRECT, MISSED, WRONG_LANE, score_lct_iso
from opends_gym.metrics.reaction import RtDistribution, score_brake_trials, score_drt
from opends_gym.metrics.steering import reversal_rate, reversal_rates

CENTRES = [3.5, 0.0, -3.5]  # lane 0 left (+y), lane 1 middle, lane 2 right
MODEL = NormativeModel(start_before_sign_m=30.0, length_per_lane_m=40.0)


def test_glance_metrics_and_nhtsa_criteria() -> None:
    g = glance_metrics([(0.0, 1.5), (3.0, 5.5), (10.0, 10.5)])
    assert (g.glance_count, g.total_eyes_off_road_s, g.mean_glance_s, g.max_glance_s) == (3, 4.5, 1.5, 2.5)
    assert g.long_glance_share == pytest.approx(1 / 3)
    assert not g.meets_nhtsa()  # a third of the glances over 2 s (NHTSA allows 15 %)
    ok = glance_metrics([(0.0, 1.0), (2.0, 3.5)])
    assert ok.meets_nhtsa() and ok.total_eyes_off_road_s == 2.5
    many = glance_metrics([(3.0 * k, 3.0 * k + 1.9) for k in range(7)])  # 13.3 s off the road
    assert many.total_eyes_off_road_s == pytest.approx(13.3) and not many.meets_nhtsa()
    assert nhtsa_pass_share([g, ok, ok, many]) == 0.5
    none = glance_metrics([])
    assert none.glance_count == 0 and none.total_eyes_off_road_s == 0.0 and math.isnan(none.mean_glance_s)
    with pytest.raises(ValueError, match=r"glance 1: starts at 1\.0 s before the previous glance ended at 1\.5 s"):
        glance_metrics([(0.0, 1.5), (1.0, 2.0)])
    with pytest.raises(ValueError, match="glance 0: ends"):
        glance_metrics([(2.0, 1.0)])


def test_drt_false_alarms_premature_and_hits() -> None:
    # onsets 1, 5, 9 s; presses: before any stimulus, 50 ms after onset (premature), a hit,
    # a second press for the answered stimulus, and a hit for the third stimulus
    s = score_drt([1.0, 5.0, 9.0], [0.5, 1.05, 1.6, 1.9, 9.5])
    assert (s.stimuli, s.hits, s.misses, s.premature, s.false_alarms) == (3, 2, 1, 1, 2)
    assert s.hit_rate == pytest.approx(2 / 3) and s.rts_s == pytest.approx((0.6, 0.5))
    assert s.mean_rt_s == pytest.approx(0.55)


def _short_lct(**kw: Any) -> gym.Env[Any, Any]:
    return gym.make("OpenDS/LaneChangeTest-v0", signs=3, lead_in_m=100.0, lead_out_m=200.0, **kw)


def test_drt_reports_its_modality() -> None:
    env = DetectionResponseTask(_short_lct(), modality="tactile")
    _, info = env.reset(seed=0)
    assert info["drt_modality"] == 2.0
    _, _, _, _, info = env.step(np.zeros(2, dtype=np.float32))
    assert info["drt_modality"] == 2.0 and env.drt_metrics()["drt_modality"] == 2.0
    assert env.drt_metrics()["drt_false_alarms"] == 0.0
    with pytest.raises(ValueError, match="modality must be one of visual, tactile, auditory, not 'smell'"):
        DetectionResponseTask(_short_lct(), modality="smell")


def test_brake_trials_validity_window_and_misses() -> None:
    t = np.round(np.arange(0.0, 10.01, 0.1), 10)
    acc = np.full(len(t), 0.5)
    brake = np.zeros(len(t))
    acc[(t >= 2.4) & (t < 4.5)] = 0.0  # trial 1: gas off at 2.4 s, brake from 2.6 s
    brake[(t >= 2.6) & (t < 4.0)] = 0.5
    acc[(t >= 4.8) & (t < 5.6)] = 0.0  # trial 2: already braking when the stimulus comes
    brake[(t >= 4.9) & (t < 5.5)] = 0.5
    acc[t >= 8.3] = 0.0  # trial 3: gas off at 8.3 s, brakes only at 9.8 s (beyond 1.5 s)
    brake[t >= 9.8] = 0.5
    trials, s = score_brake_trials(t, acc, brake, [2.0, 5.0, 8.0], max_window_s=1.5)
    assert [tr.valid for tr in trials] == [True, False, True]
    assert [tr.responded for tr in trials] == [True, False, False]
    assert trials[0].brake_onset_s == pytest.approx(0.52)  # 0.1 crossed a fifth of the way from 2.5 to 2.6 s
    assert (s.trials, s.invalid, s.responses, s.misses, s.miss_rate) == (3, 1, 1, 1, 0.5)
    assert s.rt.n == 1 and s.rt.mean_s == pytest.approx(0.52)  # the miss is counted, not averaged in
    assert s.release.mean_s == pytest.approx(0.35)  # 0.4 s and 0.3 s
    d = RtDistribution.of([0.4, 0.5, 0.6, 0.7])
    assert (d.n, d.mean_s, d.median_s) == (4, pytest.approx(0.55), pytest.approx(0.55))
    assert d.sd_s == pytest.approx(math.sqrt(0.05 / 3))
    assert (d.p15_s, d.p85_s) == (pytest.approx(0.445), pytest.approx(0.655))


def test_car_following_uses_both_speeds() -> None:
    t = np.arange(4.0) * 10.0  # samples 10 s apart: one stretch of following lasts 0 s
    gap = np.array([20.0, 20.0, 10.0, np.inf])
    follower = np.array([20.0, 10.0, 20.0, 20.0])
    lead = np.array([20.0, 20.0, 10.0, np.nan])  # equal speeds, lead faster, closing at 10 m/s, no lead
    s = car_following_summary(t, gap, follower, lead, criterion=FollowingCriterion(max_relative_speed_mps=100.0, min_duration_s=0.0))
    assert s["lead_share"] == 0.75 and s["following_share"] == 0.75
    assert s["thw_mean_s"] == pytest.approx(3.5 / 3) and s["thw_min_s"] == 0.5  # 1.0, 2.0, 0.5 s
    assert s["thw_below_1s_share"] == pytest.approx(1 / 3) and s["thw_below_2s_share"] == pytest.approx(2 / 3)
    assert s["ttc_min_s"] == 1.0  # only the closing sample has a finite TTC: 10 m / 10 m/s
    assert s["ttc_below_1.5s_share"] == pytest.approx(1 / 3) and s["ttc_below_3s_share"] == pytest.approx(1 / 3)
    alone = car_following_summary(t[:3], np.full(3, np.inf), np.full(3, 20.0), np.full(3, np.nan))
    assert alone["lead_share"] == 0.0 and math.isnan(alone["thw_mean_s"]) and alone["ttc_min_s"] == math.inf


def test_time_headway_only_while_car_following() -> None:
    """A hand-built drive whose steady following has THW 1.5 s: standing behind a stopped
    lead, a lead 200 m ahead, the lead pulling away and a 10 s stretch of close following
    are no car following (metrics.headway.FOLLOWING) and leave the mean at 1.5 s."""
    parts = [  # (seconds, gap m, ego m/s, lead m/s)
        (20.0, 30.0, 20.0, 20.0),  # following at 30 m and 72 km/h: THW 1.5 s, for 20 s
        (5.0, 5.0, 0.2, 0.0),  # stopped behind the stopped lead: gap / speed would be 25 s
        (5.0, 60.0, 10.0, 20.0),  # the lead pulls away (relative speed 10 m/s)
        (10.0, 10.0, 20.0, 20.0),  # THW 0.5 s, but for 10 s only: not a car-following episode
        (5.0, 200.0, 20.0, 20.0),  # the lead far ahead
        (16.0, 30.0, 20.0, 20.0),  # THW 1.5 s again, 16 s
    ]
    dt = 0.1
    gap, ego, lead = (np.concatenate([np.full(round(part[0] / dt), part[k]) for part in parts]) for k in (1, 2, 3))
    t = np.arange(len(gap)) * dt
    s = car_following_summary(t, gap, ego, lead)
    assert s["thw_mean_s"] == pytest.approx(1.5) and s["thw_min_s"] == pytest.approx(1.5)
    assert s["following_share"] == pytest.approx(36.0 / 61.0)
    assert s["thw_below_2s_share"] == 1.0 and s["thw_below_1s_share"] == 0.0
    assert s["lead_share"] == 1.0 and s["ttc_below_3s_share"] == 0.0
    naive = np.mean(gap / ego)  # every sample with a lead: what thw_mean_s was before
    assert naive > 3.0


def test_sdlp_fixed_segments_exclusion_and_valid_fraction() -> None:
    t = np.arange(21.0)
    y = np.where(np.arange(21) % 2 == 0, 0.1, -0.1)
    y[10:20] = np.where(np.arange(10) % 2 == 0, 0.2, -0.2)
    y[10:12] = 5.0  # an instructed lane change: excluded
    y[12] = np.nan  # a dropout: invalid
    exclude = np.zeros(21, dtype=bool)
    exclude[10:12] = True
    r = sdlp_segments(t, y, exclude, segment_length=10.0, min_valid_fraction=0.85)
    assert [(s.start, s.end) for s in r.segments] == [(0.0, 10.0), (10.0, 20.0)]  # t = 20 s starts a partial one
    first, second = r.segments
    assert first.sdlp_m == pytest.approx(0.1) and first.valid_fraction == 1.0
    assert second.valid_fraction == pytest.approx(7 / 8)  # 7 valid of the 8 not excluded
    assert second.sdlp_m == pytest.approx(math.sqrt(0.04 - (0.2 / 7) ** 2))  # three +0.2, four -0.2
    assert r.sdlp_m == pytest.approx((first.sdlp_m + second.sdlp_m) / 2)
    assert r.excluded_fraction == pytest.approx(2 / 21)
    strict = sdlp_segments(t, y, exclude, segment_length=10.0, min_valid_fraction=0.9)
    assert math.isnan(strict.segments[1].sdlp_m) and strict.segments[1].valid_fraction == pytest.approx(7 / 8)
    assert strict.sdlp_m == pytest.approx(0.1) and strict.segments_valid == 1
    none = sdlp_segments(t, np.full(21, np.nan), segment_length=10.0)
    assert math.isnan(none.sdlp_m) and none.valid_fraction == 0.0


def test_reversal_rates_three_gaps_on_lane_keeping_only() -> None:
    fs = 60.0
    t = np.arange(0.0, 80.0, 1 / fs)
    steer = 3.0 * np.sin(2 * np.pi * 0.25 * t)  # 6 deg peak to peak: 2 reversals per cycle at 0.5 and 2 deg
    change = (t >= 30.0) & (t < 50.0)
    steer[change] += 30.0 * np.sin(np.pi * (t[change] - 30.0) / 20.0)  # a 30 deg lane-change sweep
    rates = reversal_rates(steer, fs, ~change)
    assert rates[0.5] == pytest.approx(30.0, abs=3.0) and rates[2.0] == pytest.approx(30.0, abs=3.0)
    assert rates[10.0] == 0.0  # the lane change's sweep is not a reversal of lane keeping
    assert reversal_rate(steer, fs, gap_deg=10.0) > 0.0  # counted over the whole drive, it would be
    assert all(math.isnan(v) for v in reversal_rates(steer, fs, np.zeros(len(t), dtype=bool)).values())


def _lct_drive(y_of_d: Any, steer_of_d: Any) -> tuple[np.ndarray, ...]:
    d = np.arange(0.0, 301.0)
    return d, d / 10.0, np.array([y_of_d(x) for x in d]), np.array([steer_of_d(x) for x in d])


def test_lct_iso_segments_exclude_lead_in_and_split_phases() -> None:
    """Signs at 100 m (lane 1 -> 0) and 200 m (0 -> 1), readable 40 m ahead: segments 60-160 m
    and 160-260 m; normative changes 70-110 m and 170-210 m. The driver follows the normative
    path exactly, except 1 m off during the lead-in and 0.5 m off from 111 to 159 m."""
    signs = [LctSign(100.0, 1, 0), LctSign(200.0, 0, 1)]

    def y(x: float) -> float:
        norm = 0.0 if x < 70 else 3.5 * min(1.0, (x - 70) / 40) if x < 170 else 3.5 * (1 - min(1.0, (x - 170) / 40))
        return norm + (1.0 if x < 50 else 0.5 if 111 <= x <= 159 else 0.0)

    def steer(x: float) -> float:  # a brief twitch towards the new lane, then the steering that moves the car
        return 3.0 if 61 <= x <= 62 else 5.0 if 65 <= x <= 72 else -3.0 if x == 162 else -5.0 if 168 <= x <= 175 else 0.0

    d, t, yy, ss = _lct_drive(y, steer)
    s = score_lct_iso(d, t, yy, ss, signs, CENTRES, 1, MODEL, visibility_m=40.0)
    assert [x.result for x in s.signs] == [CORRECT, CORRECT]
    assert s.scored_m == 200.0  # 60 to 260 m: the lead-in's 1 m offset is not scored
    keep_area = 0.25 + 48 * 0.5 + 0.25  # ramps at 110-111 and 159-160 m, 0.5 m from 111 to 159 m
    assert s.signs[0].mdev_lane_keeping_m == pytest.approx(keep_area / 50)
    assert s.signs[0].mdev_lane_change_m == pytest.approx(0.0, abs=1e-12)
    assert s.signs[1].mdev_m == pytest.approx(0.0, abs=1e-12)
    assert s.mdev_m == pytest.approx(keep_area / 200)
    assert s.mdev_lane_keeping_m == pytest.approx(keep_area / 100) and s.mdev_lane_change_m == pytest.approx(0.0, abs=1e-12)
    # steering onset at 65 and 168 m (the car is 10 % over at 74 and 174 m; the twitches at
    # 61 and 162 m moved nothing): 5 m and 8 m after the signs became readable, at 10 m/s
    assert [x.latency_s for x in s.signs] == [pytest.approx(0.5), pytest.approx(0.8)]
    out = s.as_dict()
    assert out["iso_correct"] == 2 and out["iso_mean_latency_s"] == pytest.approx(0.65)


def test_lct_iso_wrong_lane_and_missed_change() -> None:
    """The driver goes right (lane 2) at the first sign instead of left, then stays there."""
    signs = [LctSign(100.0, 1, 0), LctSign(200.0, 0, 1)]
    d, t, yy, ss = _lct_drive(lambda x: 0.0 if x < 80 else -3.5, lambda x: -5.0 if 75 <= x <= 85 else 0.0)
    s = score_lct_iso(d, t, yy, ss, signs, CENTRES, 1, MODEL, visibility_m=40.0)
    assert [x.result for x in s.signs] == [WRONG_LANE, MISSED]
    assert [x.settled_lane for x in s.signs] == [2, 2]
    assert all(math.isnan(x.latency_s) for x in s.signs)  # it never steered towards the instructed lane
    assert (s.as_dict()["iso_wrong_lane"], s.as_dict()["iso_missed"]) == (1.0, 1.0)
    short = score_lct_iso(d[:200], t[:200], yy[:200], ss[:200], signs, CENTRES, 1, MODEL, visibility_m=40.0)
    assert len(short.signs) == 1  # the second segment (to 260 m) was not completed: not scored


def _drive(env: gym.Env[Any, Any], driver: RuleDriver) -> dict[str, float]:
    obs, info = env.reset(seed=0)
    driver.reset(env, 0)
    while True:
        obs, _, term, trunc, info = env.step(driver.act(obs, info))
        if term or trunc:
            return dict(info["episode_metrics"])


def test_lct_env_iso26022_scoring_option() -> None:
    on_time = _drive(_short_lct(scoring="iso26022"), RuleDriver())
    assert on_time["iso_signs_scored"] == 3 and on_time["iso_correct"] == 3
    assert on_time["iso_wrong_lane"] == 0 and on_time["iso_missed"] == 0
    assert 0.0 < on_time["iso_mean_latency_s"] < 2.0
    assert on_time["sdlp_j2944_excluded_fraction"] > 0.0  # the instructed changes are left out
    late = _drive(_short_lct(scoring="iso26022"), RuleDriver(RuleParams(lane_change_start_before_sign_m=5.0)))
    assert late["iso_mean_latency_s"] > on_time["iso_mean_latency_s"] + 1.0  # 25 m later at 60 km/h: 1.5 s
    assert late["iso_mdev_lane_change_m"] > on_time["iso_mdev_lane_change_m"]
    plain = _drive(_short_lct(), RuleDriver())
    assert "iso_mdev_m" not in plain and plain["mdev_basic_m"] == on_time["mdev_basic_m"]  # old keys unchanged
    with pytest.raises(ValueError, match="scoring must be one of default, iso26022, not 'iso'"):
        _short_lct(scoring="iso")


class _GlancingDriver(RuleDriver):
    """The rule driver with a glance record, as a driver model with a glance process keeps it."""

    def reset(self, env: gym.Env[Any, Any], seed: int) -> None:
        super().reset(env, seed)
        self.glances: list[tuple[float, float]] = []

    def act(self, obs: Any, info: dict[str, Any]) -> Any:
        t = float(info["sim_time_s"])
        if t >= 5.0 and len(self.glances) < 2 and (not self.glances or t >= self.glances[-1][1] + 3.0):
            self.glances.append((t, t + (2.5 if self.glances else 1.0)))
        return super().act(obs, info)


def test_episode_loop_adds_the_glance_metrics_of_a_glancing_driver() -> None:
    glancing = run_episode(_short_lct(max_episode_s=20.0), _GlancingDriver(), seed=0).metrics
    assert glancing["glance_count"] == 2 and glancing["glance_total_eyes_off_road_s"] == pytest.approx(3.5)
    assert glancing["glance_max_s"] == pytest.approx(2.5) and glancing["glance_long_share"] == 0.5
    assert "glance_count" not in run_episode(_short_lct(max_episode_s=1.0), RuleDriver(), seed=0).metrics
