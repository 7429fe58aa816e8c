"""Every corpus task runs like a driver would drive it: it loads, the rule driver drives it
for 60 s of simulated time without a collision, a head-on standstill or leaving its road,
and lanes are known wherever the task defines them (issue 17, item 3)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the env ids)
from opends_gym.drivers.rule import RuleDriver
from opends_gym.task import load_task

from .conftest import CORPUS, DRIVES, corpus_task_dirs

TASKS = [*corpus_task_dirs(), DRIVES / "Countryside"]
# the lanes each task defines: X-band road/lane (ReactionTest), Gen B road segments
# (MotorwayTask, TVPT, Idealtest2), OpenDRIVE (init_drive); the others have none
LANES_DEFINED = {"ReactionTest", "MotorwayTask", "ThreeVehiclePlatooningTask", "Idealtest2", "init_drive"}


def _drive(task: Path, seconds: float = 60.0) -> tuple[dict[str, float], list[str]]:
    """Drive `task` with the rule driver; the episode metrics and what went wrong."""
    env = gym.make("OpenDS/DrivingTask-v0", task=str(task), policy_hz=4.0, max_episode_s=seconds, terminate_on_collision=False)
    base = env.unwrapped
    driver = RuleDriver()
    obs, info = env.reset(seed=0)
    driver.reset(env, 0)
    problems: list[str] = []
    while True:
        obs, _, terminated, truncated, info = env.step(driver.act(obs, info))
        w = base.world
        s = w.ego.state
        if w.traffic is not None and abs(s.u) < 0.3 and w.t_s > 5.0:  # stopped: not facing an oncoming car
            fx, fz = -math.sin(s.yaw), -math.cos(s.yaw)
            for i in range(len(w.traffic.ids)):
                dx, dz = float(w.traffic.positions[i, 0]) - s.x, float(w.traffic.positions[i, 2]) - s.z
                ahead, across = dx * fx + dz * fz, abs(-dx * fz + dz * fx)
                facing = math.cos(float(w.traffic.yaw[i]) - s.yaw) < -0.5
                if w.traffic.enabled[i] and 0.0 < ahead < 15.0 and across < 2.5 and facing:
                    problems.append(f"head-on standstill before {w.traffic.ids[i]} at {w.t_s:.1f} s")
        if terminated or truncated:
            break
    metrics = dict(info["episode_metrics"])
    env.close()
    return metrics, problems


@pytest.mark.parametrize("task", TASKS, ids=lambda p: p.name)
def test_rule_driver_drives_every_task_for_a_minute(task: Path) -> None:
    m, problems = _drive(task)
    assert m["duration_s"] == pytest.approx(60.0, abs=0.5)
    assert m["collisions"] == 0, f"{task.name}: {m['collisions']} collision(s)"
    assert problems == []
    assert m["off_road_s"] == 0.0, f"{task.name} left its road for {m['off_road_s']} s"
    assert m["lanes_known"] == float(task.name in LANES_DEFINED)
    assert m["distance_m"] > 100.0  # it drove (engine started, not stuck)
    assert m["mean_abs_lateral_offset_m"] < 1.0


def _episode(env: gym.Env) -> dict[str, float]:  # type: ignore[type-arg]
    """One episode with the rule driver; its episode metrics."""
    driver = RuleDriver()
    obs, info = env.reset(seed=0)
    driver.reset(env, 0)
    while True:
        obs, _, terminated, truncated, info = env.step(driver.act(obs, info))
        if terminated or truncated:
            return dict(info["episode_metrics"])


def _with_engine_off(tmp_path: Path) -> Path:
    dst = tmp_path / "MotorwayTask"
    shutil.copytree(CORPUS / "opends-cts" / "MotorwayTask", dst)
    f = dst / "scenario.xml"
    f.write_text(f.read_text().replace("<engineOn>true</engineOn>", "<engineOn>false</engineOn>", 1))
    return dst


def test_rule_driver_turns_the_key_when_the_engine_is_off(tmp_path: Path) -> None:
    task = _with_engine_off(tmp_path)
    assert load_task(task).scenario.driver.car.engine.engine_on is False
    env = gym.make("OpenDS/DrivingTask-v0", task=str(task), policy_hz=4.0, max_episode_s=10.0)
    obs, info = env.reset(seed=0)
    idle = np.array([0.0, 1.0], dtype=np.float32)
    for _ in range(8):  # full throttle, engine off: the car stays put (OpenDS: no drive force)
        obs, _, _, _, info = env.step(idle)
    assert info["speed_kmh"] < 0.5
    driver = RuleDriver()
    driver.reset(env, 0)
    for _ in range(16):
        obs, _, _, _, info = env.step(driver.act(obs, info))
    assert env.unwrapped.world.ego.powertrain.state.engine_on and info["speed_kmh"] > 10.0
    env.close()


def test_a_recorded_drive_that_turns_the_key_replays_exactly(tmp_path: Path) -> None:
    from opends_gym.record import RecordDrive
    from opends_gym.record.replay import replay

    env = RecordDrive(
        gym.make("OpenDS/DrivingTask-v0", task=str(_with_engine_off(tmp_path)), policy_hz=4.0, max_episode_s=4.0), tmp_path / "d.mcap"
    )
    m = _episode(env)
    assert m["distance_m"] > 5.0  # the key was turned: it drove
    result = replay(env.paths[0])
    env.close()
    assert result.ok, result.mismatch


def test_motorway_ego_starts_at_the_scene_pose_and_joins_the_right_lane() -> None:
    """OpenDS puts the MotorwayTask car at its scene pose (a slip road of the 3-D model, where
    the task paints its white start line) facing -Z; the guide joins it to the right-hand
    motorway lane (x = -1.88, traffic towards +Z) and knows both lanes."""
    env = gym.make("OpenDS/DrivingTask-v0", task=str(CORPUS / "opends-cts" / "MotorwayTask"))
    _, info = env.reset(seed=0)
    base = env.unwrapped
    s = base.world.ego.state
    assert (s.x, s.z) == pytest.approx((-91.2, -1218.0)) and s.yaw == pytest.approx(0.0)
    g = base.guide
    assert g.source == "segments" and g.lanes_known and g.join_s_m > 80.0
    assert info["lanes_known"] is False  # on the slip-road curve: the lanes there are not the task's
    assert g.lane_laterals_m == pytest.approx((0.0, 3.79), abs=0.01)
    assert g.locate(-1.88, -1000.0).lateral_m == pytest.approx(0.0, abs=1e-6)
    assert g.locate(1.91, -1000.0).lane_index == 1  # the left lane, towards +Z
    assert abs(g.locate(-1.88, -1000.0).heading_rad) == pytest.approx(math.pi)  # facing +Z
    assert g.locate(s.x, s.z).lateral_m == pytest.approx(0.0, abs=1e-6)  # on its road at the start
    driver = RuleDriver()
    driver.reset(env, 0)
    obs = None
    for _ in range(300):  # on the motorway within 30 s: the lanes are the task's from there on
        obs, _, _, _, info = env.step(driver.act(obs, info))
        if info["lanes_known"]:
            break
    assert info["lanes_known"] and abs(base.world.ego.state.x + 1.88) < 1.0
    env.close()


def test_countryside_ego_starts_heading_as_the_real_drive_log() -> None:
    """OpenDS's Car.setRotation negates the scene's heading: the Countryside scene says +132
    deg, and the real 2019 drive logs start at the quaternion of -132 deg."""
    task = load_task(DRIVES / "Countryside")
    log = (DRIVES / "drives" / "2019_01_04-11_26_07" / "carData.txt").read_text().splitlines()
    row = next(line for line in log if line[:1].isdigit()).split(":")
    qy, qw = float(row[5]), float(row[7])
    assert math.degrees(task.start_pose.yaw_rad) == pytest.approx(-132.0, abs=1e-6)
    assert math.degrees(2.0 * math.atan2(qy, qw)) % 360.0 == pytest.approx(math.degrees(task.start_pose.yaw_rad) % 360.0, abs=0.1)


def test_opendrive_task_knows_its_curved_lanes() -> None:
    env = gym.make("OpenDS/DrivingTask-v0", task=str(CORPUS / "opends2023-annegretj" / "init_drive"))
    _, info = env.reset(seed=0)
    g = env.unwrapped.guide
    assert g.source == "opendrive" and info["lanes_known"] and len(g.lane_laterals_m) >= 2
    od = env.unwrapped.world.road.opendrive
    for s_m in (100.0, 400.0, 900.0):  # the start lane's centre along the road
        x, z, _ = od.lane_center("s000", -1, s_m)
        p = g.locate(x, z)
        assert abs(p.lateral_m) < 0.2 and p.lane_index == g.lane_laterals_m.index(0.0)
    env.close()


# ---------------------------------------------------------------------------- Gen A 4.x autopilot


def _autopilot_task(tmp_path: Path, start: str = "ap_3") -> Path:
    """The Countryside drive task with a Gen A 4.x driver autopilot: its own inline
    <wayPoints> (car1a's path, renamed) and a <startWayPoint> naming one of them, the form
    OpenDS's ScenarioLoader.getAutoPilotFollowBoxSettings reads."""
    dst = tmp_path / "Countryside"
    shutil.copytree(DRIVES / "Countryside", dst)
    f = dst / "scenario.xml"
    text = f.read_text()
    a = text.index('<vehicle id="car1a">')
    points = text[text.index("<wayPoints>", a) : text.index("</wayPoints>", a) + len("</wayPoints>")]
    points = points.replace('id="WayPoint_', 'id="ap_')
    block = (
        "<autoPilot><enabled>true</enabled><curveTension>0.05</curveTension><pathIsCycle>false</pathIsCycle>"
        f"<pathIsVisible>false</pathIsVisible>{points}<startWayPoint>{start}</startWayPoint></autoPilot>"
    )
    end = text.index("</car>")
    f.write_text(text[:end] + block + text[end:])
    return dst


def test_autopilot_inline_waypoints_load_and_start_the_ego(tmp_path: Path) -> None:
    task = load_task(_autopilot_task(tmp_path))
    ap = task.scenario.driver.car.auto_pilot
    assert ap is not None and ap.enabled and ap.start_way_point == "ap_3"
    assert [w.id for w in ap.way_points][:3] == ["ap_1", "ap_2", "ap_3"] and len(ap.way_points) == 20
    assert ap.way_points[0].speed_mps == pytest.approx(70.0 / 3.6) and ap.curve_tension == 0.05
    p3, p4 = ap.way_points[2].translation_m, ap.way_points[3].translation_m
    assert p3 is not None and p4 is not None
    # OpenDS's FollowBox puts the car on its start waypoint, heading for the next one
    assert task.start_pose.position_m == p3
    dx, dz = p4[0] - p3[0], p4[2] - p3[2]
    assert task.start_pose.yaw_rad == pytest.approx(math.atan2(-dx, -dz))


def test_autopilot_start_waypoint_must_be_one_of_its_own(tmp_path: Path) -> None:
    from opends_gym.task.errors import TaskError

    with pytest.raises(TaskError, match=r"scenario\.xml:\d+ <startWayPoint>: .*'WayPoint_3'"):
        load_task(_autopilot_task(tmp_path, start="WayPoint_3"))


def test_rule_driver_follows_the_autopilot_route(tmp_path: Path) -> None:
    env = gym.make("OpenDS/DrivingTask-v0", task=str(_autopilot_task(tmp_path)), policy_hz=4.0, max_episode_s=15.0)
    g = env.unwrapped.guide
    assert g.source == "autopilot" and not g.lanes_known
    ap = env.unwrapped.task.scenario.driver.car.auto_pilot
    for w in ap.way_points[3:8]:  # every waypoint after the start lies on the route
        assert abs(g.locate(w.translation_m[0], w.translation_m[2]).lateral_m) < 0.05
    m = _episode(env)
    assert m["collisions"] == 0 and m["off_road_s"] == 0.0 and m["distance_m"] > 100.0
    assert m["mean_abs_lateral_offset_m"] < 0.5
    env.close()


def test_run_json_episodes_report_lanes_and_road() -> None:
    import json
    import os
    import subprocess
    import sys

    def run_json(*argv: str) -> dict:
        """`opends-gym run ... --json` in its own process (in-process CLI output once reached
        pytest's global capture instead of capsys in a parallel run: see test_data)."""
        env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
        cmd = [sys.executable, "-m", "opends_gym.cli.main", "run", *argv, "--json"]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        return json.loads(proc.stdout)["episodes"][0]

    task = str(CORPUS / "opends-cts" / "MotorwayTask")
    episode = run_json(task, "--agent", "rule", "--max-seconds", "30", "--env-arg", "policy_hz=4")
    assert episode["lanes_known"] is True and episode["off_road_s"] == 0.0
    assert 0.0 < episode["mean_abs_lateral_offset_m"] < 1.0  # the slip road's curve is driven, not perfectly
    assert run_json(str(CORPUS / "opends-cts" / "ConTReTask"), "--max-seconds", "2")["lanes_known"] is False


# ---------------------------------------------------------------------------- loader scan


@pytest.mark.parametrize("task", TASKS, ids=lambda p: p.name)
def test_no_element_of_a_real_task_is_ignored(task: Path) -> None:
    """The scan of issue 17: every element the real tasks use is read (nothing is dropped
    with an "unknown element ... ignored" warning)."""
    ignored = [str(w) for w in load_task(task).warnings if "ignored" in str(w)]
    assert ignored == []


@pytest.mark.parametrize("task", [t for t in corpus_task_dirs() if t.name != "ThreeVehiclePlatooningTask"], ids=lambda p: p.name)
def test_real_tasks_match_their_own_schemas(task: Path) -> None:
    load_task(task, strict=True)


def test_tvpt_is_refused_only_by_its_schemas_misspelt_displacement() -> None:
    """OpenDS-CTS's scenario.xsd declares the engine's <displacement> as "displacement " (with a
    space), so its own TVPT task cannot validate; lenient loading reads the value."""
    from opends_gym.task.errors import TaskError

    task = CORPUS / "opends-cts" / "ThreeVehiclePlatooningTask"
    assert 'name="displacement "' in (CORPUS / "opends-cts" / "Schema" / "scenario.xsd").read_text()
    with pytest.raises(TaskError, match=r"scenario\.xml:\d+ <displacement>"):
        load_task(task, strict=True)
    assert load_task(task).scenario.driver.car.engine.displacement_m3 > 0.0


# ---------------------------------------------------------------------------- the lead


def _lead_world(guide: object, objects: list[tuple[float, float, float, float]], pedestrians: int = 0) -> object:
    """A world whose ego is at the route's start and whose traffic is `objects`: (metres ahead
    along the route, metres left of it, yaw relative to the route, speed m/s); the last
    `pedestrians` of them are pedestrians."""
    from types import SimpleNamespace

    g: object = guide
    start = g.polyline.point_at(0.0)  # type: ignore[attr-defined]
    pos, yaw = [], []
    for ahead, left, rel, _ in objects:
        x, z, h = g.polyline.point_at(ahead)  # type: ignore[attr-defined]
        pos.append((x - left * math.cos(h), 0.0, z + left * math.sin(h)))
        yaw.append(h + rel)
    n = len(objects)
    traffic = SimpleNamespace(
        ids=tuple(f"o{i}" for i in range(n)),
        enabled=np.ones(n, dtype=bool),
        positions=np.array(pos),
        yaw=np.array(yaw),
        speed=np.array([o[3] for o in objects]),
        half_extents=np.full((n, 2), 2.0),
        brake_light=np.zeros(n, dtype=bool),
        turn_signal=np.zeros(n, dtype=np.int64),
    )
    ego = SimpleNamespace(state=SimpleNamespace(x=start[0], y=0.0, z=start[1], yaw=start[2]), spec=SimpleNamespace(length_m=4.4))
    scenario = SimpleNamespace(vehicles=(None,) * (n - pedestrians), pedestrians=(None,) * pedestrians)
    return SimpleNamespace(traffic=traffic, ego=ego, task=SimpleNamespace(scenario=scenario))


def test_lead_is_only_a_car_ahead_in_the_lane_moving_its_way() -> None:
    from opends_gym.drivers.percept import route_lead

    env = gym.make("OpenDS/DrivingTask-v0", task=str(CORPUS / "opends-cts" / "MotorwayTask"))
    g = env.unwrapped.guide
    s0 = g.join_s_m + 50.0  # on the motorway, right lane
    oncoming = (s0 + 30.0, 0.0, math.pi, 15.0)
    other_lane = (s0 + 20.0, 3.79, 0.0, 20.0)
    behind = (s0 - 20.0, 0.0, 0.0, 20.0)
    ahead = (s0 + 40.0, 0.0, 0.0, 20.0)
    shifted = [(a - s0, left, rel, v) for a, left, rel, v in (oncoming, other_lane, behind, ahead)]
    w = _lead_world(_Shifted(g, s0), shifted)
    lead = route_lead(w, _Shifted(g, s0), 0.0, 0.0)
    assert lead is not None and lead.gap_m == pytest.approx(40.0 - 2.0 - 2.2, abs=0.1) and lead.speed_mps == pytest.approx(20.0)
    w = _lead_world(_Shifted(g, s0), shifted[:3])
    assert route_lead(w, _Shifted(g, s0), 0.0, 0.0) is None  # oncoming, other lane, behind: no lead
    stopped_oncoming = [(30.0, 0.0, math.pi, 0.0)]  # a car standing in the lane is in the way
    assert route_lead(_lead_world(_Shifted(g, s0), stopped_oncoming), _Shifted(g, s0), 0.0, 0.0) is not None
    env.close()


def test_a_pedestrian_walking_into_the_lane_is_in_the_way() -> None:
    from opends_gym.drivers.percept import route_lead

    env = gym.make("OpenDS/DrivingTask-v0", task=str(CORPUS / "opends-cts" / "MotorwayTask"))
    g = _Shifted(env.unwrapped.guide, env.unwrapped.guide.join_s_m + 50.0)
    walking_in = [(25.0, 5.0, -math.pi / 2, 1.5)]  # 5 m to the left, walking right at 1.5 m/s
    walking_away = [(25.0, 5.0, math.pi / 2, 1.5)]
    assert route_lead(_lead_world(g, walking_in, pedestrians=1), g, 0.0, 0.0) is not None
    assert route_lead(_lead_world(g, walking_away, pedestrians=1), g, 0.0, 0.0) is None
    env.close()


class _Shifted:
    """A guide whose route starts `s0` metres into another's (the motorway part of the route)."""

    def __init__(self, guide: object, s0: float) -> None:
        from opends_gym.sim.road import Polyline

        g: object = guide
        pts = [g.polyline.point_at(s0 + k)[:2] for k in range(0, 400)]  # type: ignore[attr-defined]
        self.polyline = Polyline(pts)
        self.lane_width_m = g.lane_width_m  # type: ignore[attr-defined]

    def heading_at(self, s_m: float) -> float:
        return self.polyline.point_at(s_m)[2]


def test_rule_driver_follows_a_curved_opendrive_lane(tmp_path: Path) -> None:
    """init_drive with its road bent into a 500 m radius arc: lanes are known along the curve
    and the rule driver stays in its lane around it."""
    dst = tmp_path / "init_drive"
    shutil.copytree(CORPUS / "opends2023-annegretj" / "init_drive", dst)
    xodr = dst / "road.xodr"
    text = xodr.read_text()
    xodr.write_text(text.replace("<line/>", '<arc curvature="0.002"/>', 1))
    env = gym.make("OpenDS/DrivingTask-v0", task=str(dst), policy_hz=4.0, max_episode_s=60.0, terminate_on_collision=False)
    base = env.unwrapped
    g = base.guide
    od = base.world.road.opendrive
    assert g.source == "opendrive" and g.lanes_known
    for s_m in (200.0, 600.0):  # lane centres of the bent road lie on the guide's lanes
        for lane in (-2, -1, 1):
            x, z, _ = od.lane_center("s000", lane, s_m)
            p = g.locate(x, z)
            assert p.lane_index >= 0 and abs(p.lateral_m - g.lane_laterals_m[p.lane_index]) < 0.2
    yaw0 = base.world.start_pose.yaw_rad
    m = _episode(env)
    turned = abs(math.remainder(base.world.ego.state.yaw - yaw0, 2.0 * math.pi))
    assert math.degrees(turned) > 60.0  # it went round the bend (about 95 deg in 60 s at 50 km/h)
    assert m["off_road_s"] == 0.0 and m["mean_abs_lateral_offset_m"] < 0.5 and m["collisions"] == 0
    env.close()


@pytest.mark.parametrize(
    ("env_id", "known"),
    [("OpenDS/LaneChangeTest-v0", True), ("OpenDS/ReactionTest-v0", True), ("OpenDS/BrakeReaction-v0", True), ("OpenDS/ConTRe-v0", False)],
)
def test_task_envs_say_whether_lanes_are_known(env_id: str, known: bool) -> None:
    env = gym.make(env_id)
    _, info = env.reset(seed=0)
    assert info["lanes_known"] is known
    _, _, _, _, info = env.step(env.action_space.sample())
    assert info["lanes_known"] is known
    env.close()


def test_motorway_driver_view_shows_the_road_at_the_start() -> None:
    """The MotorwayTask car starts on a slip road that only the task's 3D model has: the
    view draws the ego's road onto the motorway there instead of grass alone."""
    from opends_gym.render import make_renderer
    from opends_gym.render import palette as pal
    from opends_gym.sim.world import World

    world = World(CORPUS / "opends-cts" / "MotorwayTask")
    frame = make_renderer("driver_view", world).render(160, 90)
    asphalt = np.all(np.abs(frame.astype(int) - np.array(pal.ASPHALT)) <= 3, axis=-1)
    assert asphalt[45:, 60:100].mean() > 0.3  # asphalt straight ahead, below the horizon
    world.close()


def _motorway_with_third_lane(tmp_path: Path, declare: bool) -> Path:
    """MotorwayTask plus a lane C 3.79 m left of lane B (x = 5.70, towards +Z); with
    `declare`, A's segments name B as their left neighbour (and nothing else)."""
    dst = tmp_path / ("declared" if declare else "parallel") / "MotorwayTask"
    shutil.copytree(CORPUS / "opends-cts" / "MotorwayTask", dst)
    f = dst / "scenario.xml"
    text = f.read_text()
    wps = "".join(
        f'<wayPoint id="WayPoint_C{k}"><translation><vector jtype="java_lang_Float" size="3"><entry>5.70</entry>'
        f"<entry>-0.44</entry><entry>{z}</entry></vector></translation></wayPoint>"
        for k, z in enumerate((-2000, -1000, 0))
    )
    segs = "".join(
        f'<segment id="Segment_C{k}"><from>WayPoint_C{k}</from><to>WayPoint_C{k + 1}</to><speed>80</speed></segment>' for k in range(2)
    )
    text = text.replace("</wayPoints>", wps + "</wayPoints>", 1).replace("</segments>", segs + "</segments>", 1)
    if declare:
        for k in range(1, 26):
            a, b = f"Segment_A{k:02d}", f"Segment_B{min(k, 16):02d}"
            text = text.replace(f'<segment id="{a}">', f'<segment id="{a}"><leftNeighbor>{b}</leftNeighbor>', 1)
    f.write_text(text)
    return dst


@pytest.mark.parametrize(("declare", "lanes"), [(False, (0.0, 3.79, 7.58)), (True, (0.0, 3.79))])
def test_segment_lanes_are_declared_neighbours_else_parallel_segments(tmp_path: Path, declare: bool, lanes: tuple[float, ...]) -> None:
    env = gym.make("OpenDS/DrivingTask-v0", task=str(_motorway_with_third_lane(tmp_path, declare)))
    g = env.unwrapped.guide
    assert g.source == "segments" and g.lane_laterals_m == pytest.approx(lanes, abs=0.01)
    assert g.locate(5.70, -900.0).lane_index == (2 if not declare else -1)  # lane C, or off the known lanes
    env.close()


def test_a_distracted_driver_turns_the_key_too(tmp_path: Path) -> None:
    from opends_gym.drivers.agents import make_agent

    env = gym.make("OpenDS/DrivingTask-v0", task=str(_with_engine_off(tmp_path)), policy_hz=4.0, max_episode_s=8.0)
    agent = make_agent("distracted:heavy")
    obs, info = env.reset(seed=0)
    agent.reset(env, 0)
    for _ in range(32):
        obs, _, _, _, info = env.step(agent.act(obs, info))
    assert env.unwrapped.world.ego.powertrain.state.engine_on and info["speed_kmh"] > 10.0
    env.close()


def test_validate_names_where_the_lanes_come_from(capsys: pytest.CaptureFixture[str]) -> None:
    from opends_gym.cli.main import main as cli

    tasks = [CORPUS / "opends-cts" / "MotorwayTask", CORPUS / "opends2023-annegretj" / "init_drive", DRIVES / "Countryside"]
    assert cli(["validate", *map(str, tasks)]) == 0
    out = capsys.readouterr().out
    assert "road=segments road_lanes=2" in out and "road=opendrive road_lanes=3" in out and "road=traffic_route road_lanes=0" in out


@pytest.mark.parametrize("log", ["2019_01_04-11_26_07/carData(2).txt", "2019_01_04-11_40_24/carData.txt"])
def test_real_countryside_drives_stay_on_the_road_the_guide_builds(log: str) -> None:
    """A person drove the Countryside task in OpenDS (2019 logs): every recorded position lies
    on the road the guide builds for it (start heading as OpenDS sets it, then the traffic
    route it joins), within 3 m of its line."""
    env = gym.make("OpenDS/DrivingTask-v0", task=str(DRIVES / "Countryside"))
    g = env.unwrapped.guide
    rows = [line.split(":") for line in (DRIVES / "drives" / log).read_text().splitlines() if line[:1].isdigit()]
    offsets = [abs(g.polyline.project(float(r[1]), float(r[3])).offset_m) for r in rows]
    assert len(offsets) > 100 and max(offsets) < 3.0 and not any(g.off_road(o) for o in offsets)
    env.close()


def test_rule_driver_yields_at_the_motorway_merge_to_a_car_about_to_pass() -> None:
    """On the slip road the driver accepts a gap, as a person checking the mirror does: a
    motorway car reaching the join at the ego's time makes it stop before the join; with
    that car moved far back (or already past) the way is free."""
    from opends_gym.drivers.percept import MERGE_STOP_BEFORE_M, merge_stop_left_m

    env = gym.make("OpenDS/DrivingTask-v0", task=str(CORPUS / "opends-cts" / "MotorwayTask"))
    env.reset(seed=0)
    base = env.unwrapped
    world, guide = base.world, base.guide
    s = world.ego.state
    s_m = guide.locate(s.x, s.z).s_m
    assert s_m < guide.join_s_m  # the ego starts on the connector
    tr = world.traffic
    jx, jz, heading = guide.polyline.point_at(guide.join_s_m)
    fx, fz = -math.sin(heading), -math.cos(heading)
    ego_eta = (2.0 * (guide.join_s_m - s_m) / 2.0) ** 0.5  # from rest at the merge acceleration
    tr.enabled[:] = False
    tr.enabled[0] = True
    tr.yaw[0], tr.speed[0] = heading, 27.0
    tr.positions[0, 0], tr.positions[0, 2] = jx - fx * 27.0 * ego_eta, jz - fz * 27.0 * ego_eta  # arrives with the ego
    left = merge_stop_left_m(world, guide, s_m, 0.0)
    assert left < math.inf and guide.join_s_m - MERGE_STOP_BEFORE_M - s_m <= left <= guide.join_s_m - s_m
    tr.positions[0, 0], tr.positions[0, 2] = jx - fx * 27.0 * (ego_eta + 10.0), jz - fz * 27.0 * (ego_eta + 10.0)
    assert merge_stop_left_m(world, guide, s_m, 0.0) == math.inf  # 10 s behind: a free gap
    tr.positions[0, 0], tr.positions[0, 2] = jx + fx * 20.0, jz + fz * 20.0
    assert merge_stop_left_m(world, guide, s_m, 0.0) == math.inf  # already past the join
