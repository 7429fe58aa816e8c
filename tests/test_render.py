"""Headless rendering: env frames and image observations, content, weather, HUD, composition, window.

Everything runs without a display (pygame's dummy SDL video driver for the window test).
Content checks compare frames of the same world state with one thing changed, so they
fail if that thing is not drawn.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import opends_gym  # noqa: F401  (registers the envs)
from opends_gym.render import RENDER_VIEWS, make_renderer
from opends_gym.render import palette as pal
from opends_gym.render.camera import Camera, clip_near
from opends_gym.render.compose import ViewComposer, compose_view
from opends_gym.render.hud import HudOverlay, needle_angle_rad
from opends_gym.render.weather import fog_for, visibility_m
from opends_gym.sim.triggers.actions import BUILTIN_HANDLERS
from opends_gym.sim.triggers.reactions import ReactionResult
from opends_gym.sim.world import World
from opends_gym.task.bundled import BUNDLED_DIR
from opends_gym.task.model_scene import Picture, ScreenAnchor
from opends_gym.task.model_settings import TopView
from opends_gym.task.model_task import Pose
from opends_gym.task.values import Rotation

from .conftest import CORPUS


@pytest.fixture(autouse=True)
def _headless(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")


def has_color(frame: np.ndarray, color: tuple[int, int, int], min_pixels: int = 1) -> bool:
    return int(np.all(frame == np.asarray(color, np.uint8), axis=-1).sum()) >= min_pixels


def n_colors(frame: np.ndarray) -> int:
    return len(np.unique(frame.reshape(-1, 3), axis=0))


def surface_frame(surface: Any) -> np.ndarray:
    from opends_gym.render._pg import to_array

    return to_array(surface)


@pytest.fixture(scope="module")
def lct_world_with_signs() -> World:
    """The LCT after its first sign trigger fired (manipulateObject visible=true on both signs)."""
    env = gym.make("OpenDS/LaneChangeTest-v0")
    env.reset(seed=0)
    world = env.unwrapped.world
    for _ in range(300):
        env.step(np.zeros(env.action_space.shape, np.float32))
        if any(o.visible for o in world.objects.objects):
            break
    assert any(o.visible for o in world.objects.objects), "no LCT sign became visible"
    return world


# ---------------------------------------------------------------------------- env frames
@pytest.mark.parametrize("env_id", ["OpenDS/LaneChangeTest-v0", "OpenDS/ReactionTest-v0"])
@pytest.mark.parametrize("view", ["topdown", "driver_view"])
def test_env_rgb_array_frames_are_not_blank(env_id: str, view: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array", extra={"render_view": view})
    env.reset(seed=3)
    # straight ahead, no pedal: (random actions may turn OpenDS's car, 1 rad at full lock, off its road)
    straight = np.zeros(env.action_space.shape, env.action_space.dtype) if isinstance(env.action_space, gym.spaces.Box) else 0
    for _ in range(5):
        env.step(straight)
    frame = env.render()
    cfg = env.unwrapped.config
    assert isinstance(frame, np.ndarray)
    assert frame.shape == (cfg.render_height, cfg.render_width, 3) and frame.dtype == np.uint8
    assert n_colors(frame) >= (5 if view == "topdown" else 20)
    assert has_color(frame, pal.ASPHALT, 500), "the road's grey is missing"
    assert has_color(frame, pal.MARKING, 20), "the lane markings' white is missing"
    env.close()


@pytest.mark.parametrize("env_id", ["OpenDS/LaneChangeTest-v0", "OpenDS/ReactionTest-v0"])
@pytest.mark.parametrize("obs", ["topdown", "driver_view"])
def test_image_observations(env_id: str, obs: str) -> None:
    env = gym.make(env_id, observation=obs)
    o, _ = env.reset(seed=1)
    assert o.shape == (84, 84, 3) and o.dtype == np.uint8
    assert env.observation_space.contains(o)
    o2, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(o2)
    assert n_colors(o2) >= 5
    assert has_color(o2, pal.ASPHALT, 50)
    assert has_color(o2, pal.MARKING, 3)
    env.close()


def test_unknown_view_and_bad_options_are_rejected() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    with pytest.raises(ValueError, match="unknown render view 'fisheye'"):
        make_renderer("fisheye", world)
    with pytest.raises(ValueError, match="scale_px_per_m"):
        make_renderer("topdown", world, scale_px_per_m=0.0)
    with pytest.raises(ValueError, match="camera mode"):
        make_renderer("driver_view", world, camera_mode="cockpit")


@pytest.mark.parametrize("view", RENDER_VIEWS)
def test_every_view_renders_any_size(view: str) -> None:
    world = World(BUNDLED_DIR / "ReactionTest")
    r = make_renderer(view, world)
    for w, h in ((84, 84), (320, 180), (97, 203)):
        f = r.render(w, h)
        assert f.shape == (h, w, 3) and f.dtype == np.uint8
        assert n_colors(f) >= 4


# ---------------------------------------------------------------------------- content
def test_sign_made_visible_by_an_action_appears_in_driver_view(lct_world_with_signs: World) -> None:
    world = lct_world_with_signs
    signs = [o for o in world.objects.objects if o.visible]
    r = make_renderer("driver_view", world)
    shown = r.render(320, 180)
    for o in signs:
        o.visible = False
    hidden = r.render(320, 180)
    for o in signs:
        o.visible = True
    changed = np.any(shown != hidden, axis=-1)
    assert changed.sum() > 30, "making the signs visible changed almost nothing"
    px = shown[changed].astype(int)
    blue_board = (px[:, 2] > px[:, 0] + 40) & (px[:, 0] < 80)  # saturated blue LCT boards, not the paler sky (red >= 92)
    assert blue_board.sum() > 10
    # the boards stand on both sides of the road
    cols = np.flatnonzero(changed.any(axis=0))
    assert cols.min() < 160 < cols.max()


def test_sign_is_on_the_map_too(lct_world_with_signs: World) -> None:
    world = lct_world_with_signs
    signs = [o for o in world.objects.objects if o.visible]
    r = make_renderer("topdown", world, view_m=120.0)
    shown = r.render(160, 160)
    for o in signs:
        o.visible = False
    hidden = r.render(160, 160)
    for o in signs:
        o.visible = True
    assert np.any(shown != hidden)


def test_trigger_volumes_hidden_unless_debug() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    plain = make_renderer("topdown", world, view_m=40.0).render(128, 128)
    debug = make_renderer("topdown", world, view_m=40.0, show_triggers=True).render(128, 128)
    assert not has_color(plain, pal.TRIGGER_DEBUG)
    assert has_color(debug, pal.TRIGGER_DEBUG, 10)


def _fog_distance(frame: np.ndarray, rows: slice) -> float:
    return float(np.abs(frame[rows].astype(float) - np.asarray(pal.FOG, float)).mean())


def test_fog_makes_distant_pixels_converge_to_the_fog_colour() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    r = make_renderer("driver_view", world)
    set_weather = BUILTIN_HANDLERS["setWeather"]
    horizon = slice(80, 100)  # 180-row frame, camera level: the horizon is at row 90
    near = slice(170, 180)
    dist = {}
    frames = {}
    for p in (-1.0, 30.0, 100.0):
        set_weather(world.triggers, {"fog_percent": p}, "test")
        frames[p] = f = r.render(320, 180)
        dist[p] = _fog_distance(f, horizon)
    assert dist[-1.0] > dist[30.0] > dist[100.0]
    assert dist[100.0] < 6.0, "dense fog should leave the far scene in the fog colour"
    # near pixels keep more of their own colour than far ones
    assert _fog_distance(frames[100.0], near) > dist[100.0] + 20
    assert visibility_m(0) == pytest.approx(2000.0) and visibility_m(100) == pytest.approx(40.0)
    assert fog_for({"fog_percent": -1.0}) is None


def test_rain_and_snow_are_drawn_and_deterministic() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    r = make_renderer("driver_view", world)
    clear = r.render(320, 180)
    world.triggers.weather["raining_percent"] = 100.0
    rain = r.render(320, 180)
    assert has_color(rain, pal.RAIN, 20) and not has_color(clear, pal.RAIN)
    assert np.array_equal(rain, r.render(320, 180)), "the same world state must give the same frame"
    world.run(0.1)
    assert not np.array_equal(rain, r.render(320, 180)), "rain falls with simulation time"
    world.triggers.weather.update(raining_percent=-1.0, snowing_percent=100.0)
    snow = r.render(320, 180)
    assert has_color(snow, pal.SNOW, 20)


def test_traffic_brake_light_changes_pixels() -> None:
    world = World(BUNDLED_DIR / "ThreeVehiclePlatoon")
    assert world.traffic is not None and "car1" in world.traffic.ids
    for view in ("driver_view", "topdown"):
        r = make_renderer(view, world)
        world.traffic.set_brake_light("car1", False)
        off = r.render(320, 180)
        world.traffic.set_brake_light("car1", True)
        on = r.render(320, 180)
        changed = np.any(on != off, axis=-1)
        assert changed.sum() >= 2, view
        assert has_color(on, pal.BRAKE_ON) and not has_color(off, pal.BRAKE_ON), view
    world.traffic.set_brake_light("car1", None)


def test_turn_signal_blinks_in_simulation_time() -> None:
    world = World(BUNDLED_DIR / "ThreeVehiclePlatoon")
    r = make_renderer("chase", world)
    world.traffic.set_turn_signal("car1", "left")
    frames = []
    for _ in range(3):
        frames.append(has_color(r.render(320, 180), pal.SIGNAL_ON))
        world.run(1.0 / 3.0)  # half a blink period
    assert frames[0] != frames[1] and frames[0] == frames[2]


def test_traffic_light_state_is_drawn() -> None:
    world = World(CORPUS / "opends-cts" / "Idealtest2")
    assert world.lights is not None
    # the car where the scene places it, facing -X towards intersection 03 (the task's autopilot
    # would start it at waypoint 209, under a light)
    world.reset(start=Pose(world.task.car_model.translation_m or (0.0, 0.0, 0.0), Rotation.from_euler_deg(0.0, 90.0, 0.0)))
    scene_r = make_renderer("topdown", world, view_m=200.0)
    scene_r.render(200, 200)
    lights = scene_r.scene.lights
    assert lights, "Idealtest2 lights should be placed at their waypoints"
    ego = world.ego.state  # the nearest light ahead of the car (the chase camera looks forward)
    ahead = [p for p in lights if (p.x - ego.x) * -math.sin(ego.yaw) + (p.z - ego.z) * -math.cos(ego.yaw) > 0.0]
    light_id = min(ahead, key=lambda p: math.hypot(p.x - ego.x, p.z - ego.z)).light_id
    world.lights.set_mode("external")
    for state, lamp in (("red", pal.LAMP_RED), ("green", pal.LAMP_GREEN)):
        assert world.lights.set_external_state(light_id, state)
        for view in ("topdown", "chase"):
            f = make_renderer(view, world, **({"view_m": 200.0} if view == "topdown" else {})).render(320, 180)
            assert has_color(f, lamp), (state, view)


def test_opendrive_road_is_drawn() -> None:
    world = World(CORPUS / "opends2023-annegretj" / "init_drive")
    assert world.road.opendrive is not None
    world.triggers.weather["fog_percent"] = -1.0
    for view in ("topdown", "driver_view"):
        f = make_renderer(view, world).render(160, 90)
        assert has_color(f, pal.ASPHALT, 100), view


# ---------------------------------------------------------------------------- HUD
def _hud_frame(world: World, **kw: Any) -> np.ndarray:
    from opends_gym.render._pg import new_surface

    s = new_surface(320, 180)
    s.fill((0, 0, 0))
    HudOverlay(world, **kw).draw(s)
    return surface_frame(s)


def test_hud_shows_message_warning_pause_and_instructions() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    hud = world.triggers.hud
    base = _hud_frame(world, show_analog=False)
    assert not base.any()
    BUILTIN_HANDLERS["sendMessage"](world.triggers, {"text": "Change lanes now", "duration_s": 5.0}, "test")
    msg = _hud_frame(world, show_analog=False)
    assert np.any(msg[:60] != base[:60]), "the message should appear in the upper part"
    hud.message_until_s = 0.0
    BUILTIN_HANDLERS["warningFrame"](world.triggers, {"interval_s": 0.5, "duration_s": 10.0}, "test")
    warn = _hud_frame(world, show_analog=False)
    assert has_color(warn[:3], pal.WARNING, 300) and has_color(warn[90:91, :3], pal.WARNING)
    hud.warning_until_s = 0.0
    world.triggers.paused = True
    paused = _hud_frame(world, show_analog=False)
    assert np.any(paused[70:110] != 0)
    world.triggers.paused = False
    hud.instruction_screen = "welcome"
    instr = _hud_frame(world, show_analog=False)
    assert np.any(instr != base)
    hud.instruction_screen = None


def test_hud_indicators_follow_settings_and_speed() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    none = _hud_frame(world, show_analog=False, show_digital=False)
    analog = _hud_frame(world, show_analog=True)
    digital = _hud_frame(world, show_analog=False, show_digital=True)
    assert not none.any() and analog.any() and digital.any()
    world.ego.body.state.u = 30.0
    faster = _hud_frame(world, show_analog=True)
    assert np.any(faster != analog), "the speed needle should move"
    assert needle_angle_rad(0, 1.0, 260) == pytest.approx(math.radians(192))
    assert needle_angle_rad(999, 1.0, 260) == pytest.approx(math.radians(192 - 260))


def test_hud_option_draws_instruments_over_any_view() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    for view in ("topdown", "driver_view"):
        plain = make_renderer(view, world).render(320, 180)
        with_hud = make_renderer(view, world, hud=True).render(320, 180)
        changed = np.any(plain != with_hud, axis=-1)
        assert changed[100:, 160:].sum() > 500, "the dials sit bottom right"
        assert not changed[:60, :100].any()


def test_hud_pictures_placeholder_and_image(tmp_path: Path) -> None:
    import pygame

    world = World(BUNDLED_DIR / "LaneChangeTest")
    pic = Picture(
        id="arrow",
        key="Textures/arrow.png",
        v_position=ScreenAnchor("fromTop", "px", 20),
        h_position=ScreenAnchor("fromLeft", "percent", 50),
        width_px=40,
        height_px=30,
    )
    world.task = dataclasses.replace(world.task, scene=dataclasses.replace(world.task.scene, pictures=(pic,)), folder=tmp_path)
    world.triggers.hud.pictures["arrow"] = False
    hidden = _hud_frame(world, show_analog=False)
    BUILTIN_HANDLERS["manipulatePicture"](world.triggers, {"picture_id": "arrow", "visible": True}, "test")
    placeholder = _hud_frame(world, show_analog=False)
    assert not hidden.any()
    box = placeholder[20:50, 160:200]
    assert box.any() and not placeholder[:15].any(), "the placeholder belongs at 20 px from the top, 50 % from the left"
    (tmp_path / "Textures").mkdir()
    img = pygame.Surface((8, 8))
    img.fill((10, 200, 30))
    pygame.image.save(img, str(tmp_path / "Textures" / "arrow.png"))
    shown = _hud_frame(world, show_analog=False)
    assert tuple(shown[35, 180]) == (10, 200, 30)


def test_hud_reaction_feedback_shows_for_two_seconds() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    world.run(0.5)
    before = _hud_frame(world, show_analog=False)
    world.triggers.center.results.append(ReactionResult("timer1", "laneChange", "g", 1, 0.83, 0.0, world.t_s, world.t_s))
    correct = _hud_frame(world, show_analog=False)
    assert has_color(correct, (80, 230, 80), 10) and not before.any()
    world.triggers.center.results[-1] = ReactionResult("timer1", "laneChange", "g", -2, 10.0, 0.0, world.t_s, world.t_s)
    missed = _hud_frame(world, show_analog=False)
    assert has_color(missed, (250, 170, 40), 10)
    world.run(2.0)
    assert not _hud_frame(world, show_analog=False).any(), "feedback disappears after two seconds"


# ---------------------------------------------------------------------------- composition
def test_compose_mirrors_screens_and_top_view_to_size() -> None:
    world = World(BUNDLED_DIR / "ReactionTest")
    g = world.task.settings.general
    plain = ViewComposer(world, g, hud=False).render(480, 180)
    assert plain.shape == (180, 480, 3)
    mirrored = ViewComposer(world, dataclasses.replace(g, mirror_mode="back_only"), hud=False).render(480, 180)
    x0, x1, y0, y1 = int(0.3 * 480), int(0.7 * 480), int(0.02 * 180), int(0.22 * 180)
    assert np.any(mirrored[y0:y1, x0:x1] != plain[y0:y1, x0:x1])
    assert np.array_equal(mirrored[100:, :100], plain[100:, :100]), "outside the mirror nothing changes"
    three = dataclasses.replace(g, number_of_screens=3, mirror_mode="all", top_view=TopView())
    frame = ViewComposer(world, three).render(900, 300)
    assert frame.shape == (300, 900, 3) and frame.dtype == np.uint8
    one_wide = ViewComposer(world, dataclasses.replace(g, mirror_mode="all", top_view=TopView())).render(900, 300)
    assert not np.array_equal(frame, one_wide)
    with_hud = compose_view(world, world.task.settings, 320, 180)
    assert with_hud.shape == (180, 320, 3)


def test_compose_rejects_unknown_mirror_mode() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    with pytest.raises(ValueError, match="mirror mode"):
        ViewComposer(world, mirror_mode="everywhere")


# ---------------------------------------------------------------------------- determinism
@pytest.mark.parametrize("view", ["topdown", "driver_view", "chase"])
def test_same_world_state_same_frame(view: str) -> None:
    frames = []
    for _ in range(2):
        env = gym.make("OpenDS/ReactionTest-v0", render_mode="rgb_array", extra={"render_view": view})
        env.reset(seed=7)
        env.unwrapped.world.triggers.weather.update(raining_percent=50.0, snowing_percent=20.0, fog_percent=20.0)
        rng = np.random.default_rng(0)
        for _ in range(20):
            env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        frames.append(env.render())
        assert np.array_equal(frames[-1], env.render())
        env.close()
    assert np.array_equal(frames[0], frames[1])


# ---------------------------------------------------------------------------- maths and window
def test_camera_projection_and_near_clipping() -> None:
    cam = Camera(0.0, 1.0, 0.0, yaw=0.0)
    view = cam.to_view(np.array([[0.0, 1.0, -10.0], [2.0, 1.0, -10.0], [0.0, 3.0, -10.0]]))
    assert view[0] == pytest.approx([0.0, 0.0, 10.0])
    px = cam.project(view, 200, 100)
    assert px[0] == pytest.approx([100.0, 50.0])
    assert px[1][0] > 100.0 and px[2][1] < 50.0  # right is right, up is up
    mirror = Camera(0.0, 1.0, 0.0, yaw=0.0, mirror=True).project(view, 200, 100)
    assert mirror[1][0] < 100.0
    left_turn = Camera(0.0, 1.0, 0.0, yaw=0.5 * math.pi)  # looking along -X
    assert left_turn.to_view(np.array([-5.0, 1.0, 0.0]))[2] == pytest.approx(5.0)
    poly = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]])
    clipped = clip_near(poly, 0.5)
    assert len(clipped) == 4 and np.all(clipped[:, 2] >= 0.5 - 1e-9)
    depths = cam.ground_row_depths(200, 100, 1.0)
    assert np.isinf(depths[:50]).all() and np.isfinite(depths[50:]).all() and np.all(np.diff(depths[50:]) < 0)


def test_topdown_scale_and_orientation_options() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    world.ego.body.state.yaw = 0.6
    heading_up = make_renderer("topdown", world, heading_up=True).render(96, 96)
    north_up = make_renderer("topdown", world, heading_up=False).render(96, 96)
    zoomed = make_renderer("topdown", world, heading_up=False, scale_px_per_m=8.0).render(96, 96)
    assert not np.array_equal(heading_up, north_up)
    assert not np.array_equal(north_up, zoomed)
    # north-up at 8 px/m: the 11.55 m wide road spans about 92 px of the 96 px frame
    assert not np.all(zoomed[48, 2:94] == np.asarray(pal.GRASS, np.uint8), axis=-1).any()


def test_frame_window_smoke() -> None:
    from opends_gym.render.window import FrameWindow

    seen: list[Any] = []
    win = FrameWindow(64, 48, title="test", on_event=seen.append)
    frame = np.zeros((48, 64, 3), np.uint8)
    frame[:, :32] = (255, 0, 0)
    events = win.show(frame, fps=60)
    assert isinstance(events, list)
    win.show(np.full((24, 32, 3), 128, np.uint8))  # other sizes are scaled to the window
    assert win.events() == win.events()
    assert win.is_open
    win.close()
    assert not win.is_open
    with pytest.raises(RuntimeError):
        win.show(frame)


def test_env_human_mode_uses_the_window() -> None:
    env = gym.make("OpenDS/LaneChangeTest-v0", render_mode="human", render_width=80, render_height=60)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert env.unwrapped._window is not None and env.unwrapped._window.is_open
    env.close()
