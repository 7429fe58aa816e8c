"""The Panda3D views: camera modes and settings OpenDS reads (outsideCamPosition, showHood,
frustumFar), the user's own models for OpenDS model keys, and the projection the docs'
screenshot probes rely on."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from opends_gym.render import make_renderer
from opends_gym.render import palette as pal
from opends_gym.sim.world import World
from opends_gym.task.bundled import BUNDLED_DIR
from opends_gym.task.model_settings import XYZ


def _general(world: World, **kw: object) -> None:
    s = world.task.settings
    world.task = dataclasses.replace(world.task, settings=dataclasses.replace(s, general=dataclasses.replace(s.general, **kw)))


def _reddish(frame: np.ndarray) -> np.ndarray:
    """Pixels of the ego's red body under the baked shading (0.62..1.0 of pal.EGO)."""
    f = frame.astype(float)
    ratio = f / np.asarray(pal.EGO, float)
    return (ratio.min(axis=-1) > 0.55) & (ratio.max(axis=-1) < 1.05) & (np.ptp(ratio, axis=-1) < 0.1)


def test_outside_camera_stands_where_the_settings_say_and_looks_at_the_car() -> None:
    world = World(BUNDLED_DIR / "ThreeVehiclePlatoon")
    s = world.ego.state
    _general(world, outside_cam_position=XYZ(s.x + 20.0, 3.0, s.z))
    r = make_renderer("driver_view", world, camera_mode="outside")
    cam = r.camera(320, 180)
    assert (cam.x, cam.y, cam.z) == pytest.approx((s.x + 20.0, 3.0, s.z))
    assert cam.yaw == pytest.approx(0.5 * math.pi)  # looking along -X, at the car
    frame = r.render(320, 180)
    red = _reddish(frame)
    assert red.sum() > 50, "the ego car should be in the outside camera's view"
    _, xs = np.nonzero(red)
    assert abs(xs.mean() - 160) < 40, "the car is near the middle of the outside view"


def test_show_hood_puts_the_bonnet_in_the_ego_view_only() -> None:
    world = World(BUNDLED_DIR / "LaneChangeTest")
    plain = make_renderer("driver_view", world).render(160, 90)
    _general(world, show_hood=True)
    hood = make_renderer("driver_view", world).render(160, 90)
    assert not _reddish(plain).any()
    assert _reddish(hood[70:]).mean() > 0.5, "the bonnet fills the bottom of the driver's view"
    assert not _reddish(hood[:40]).any()
    chase = make_renderer("driver_view", world, camera_mode="chase").render(160, 90)
    assert _reddish(chase).sum() > 0  # the chase camera sees the whole car instead


def test_frustum_far_from_the_settings_clips_distant_traffic() -> None:
    world = World(BUNDLED_DIR / "ThreeVehiclePlatoon")  # the lead car is 30 m ahead
    seen = make_renderer("driver_view", world).render(320, 180)
    _general(world, frustum_far_m=20.0)
    clipped = make_renderer("driver_view", world).render(320, 180)
    body = np.asarray(pal.TRAFFIC_BODIES[0], float)
    lead = lambda f: ((np.abs(f.astype(float) / body - 0.8) < 0.25).all(axis=-1)).sum()  # noqa: E731
    assert lead(seen) > 30 and lead(clipped) == 0


EGG = """<CoordinateSystem> { Z-up }
<VertexPool> v {
  <Vertex> 0 { -1 0 0 <RGBA> { 1 0 1 1 } }
  <Vertex> 1 { 1 0 0 <RGBA> { 1 0 1 1 } }
  <Vertex> 2 { 1 0 2 <RGBA> { 1 0 1 1 } }
  <Vertex> 3 { -1 0 2 <RGBA> { 1 0 1 1 } }
}
<Polygon> { <VertexRef> { 0 1 2 3 <Ref> { v } } }
"""


def test_model_map_swaps_an_opends_model_for_the_users_file(tmp_path: Path) -> None:
    (tmp_path / "board.egg").write_text(EGG)
    (tmp_path / "models.json").write_text(json.dumps({"Models/LaneChangeTest/sign_lane*": "board.egg"}))
    world = World(BUNDLED_DIR / "LaneChangeTest")
    for o in world.objects.objects:
        o.visible = not o.is_trigger  # every lane sign up
    plain = make_renderer("driver_view", world).render(320, 180)
    mapped = make_renderer("driver_view", world, model_map=tmp_path / "models.json").render(320, 180)
    magenta = lambda f: ((f[..., 0] > 120) & (f[..., 2] > 120) & (f[..., 1] < 60)).sum()  # noqa: E731
    assert magenta(plain) == 0 and magenta(mapped) > 20
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"bad\.json: model map must map"):
        make_renderer("driver_view", world, model_map=tmp_path / "bad.json")


def test_lens_matches_the_pinhole_projection() -> None:
    """A traffic car's lamp lands on the pixel `Camera.project` gives (the screenshot probes rely on it)."""
    world = World(BUNDLED_DIR / "ThreeVehiclePlatoon")
    world.traffic.set_brake_light("car1", True)
    r = make_renderer("driver_view", world)
    frame = r.render(640, 360)
    lit = np.all(frame == np.asarray(pal.BRAKE_ON, np.uint8), axis=-1)
    ys, xs = np.nonzero(lit)
    i = world.traffic.ids.index("car1")
    x, y, z = world.traffic.positions[i]
    hx, hz = world.traffic.half_extents[i]
    cam = r.camera(640, 360)
    for side, mask in ((-1, xs < 320), (1, xs >= 320)):  # the two brake lamps, left and right of centre
        p = np.array([[x + side * (hx - 0.3), y + 0.45 * 1.45, z + hz + 0.04]])
        px = cam.project(cam.to_view(p), 640, 360)[0]
        assert abs(xs[mask].mean() - px[0]) < 1.5 and abs(ys[mask].mean() - px[1]) < 1.5


def test_lct_sign_is_legible_at_40_m_in_full_hd() -> None:
    """The lane sign 40 m ahead on a 1920x1080 frame: its board shows the lane number as drawn
    on its face texture (the rendered board matches the face image scaled to its size)."""
    import pygame

    from opends_gym.render.sign_textures import face_image
    from opends_gym.render.styles import base_y

    world = World(BUNDLED_DIR / "LaneChangeTest")
    while not any(o.visible for o in world.objects.objects):
        world.run(0.5)
    sign = min((o for o in world.objects.objects if o.visible), key=lambda o: o.position[0])
    world.ego.body.state.z = sign.position[2] + 40.0
    r = make_renderer("driver_view", world)
    frame = r.render(1920, 1080)
    cam = r.camera(1920, 1080)
    board = r.scene.parts(sign)[-1]
    y0, x, z = base_y(sign), sign.position[0], sign.position[2] + board.hz
    corners = np.array([[x - board.hx, y0 + board.y1, z], [x + board.hx, y0 + board.y0, z]])
    (left, top), (right, bottom) = cam.project(cam.to_view(corners), 1920, 1080)
    assert right - left > 60 and bottom - top > 90, "a 1.6 m board 40 m away spans about 80x120 px"
    crop = frame[int(top) + 3 : int(bottom) - 3, int(left) + 3 : int(right) - 3].astype(float)
    face = face_image(board.label, board.color, board.hx / (0.5 * (board.y1 - board.y0)))
    surf = pygame.transform.smoothscale(pygame.surfarray.make_surface(face.swapaxes(0, 1)), (int(right - left), int(bottom - top)))
    ref = pygame.surfarray.array3d(surf).swapaxes(0, 1)[3:-3, 3:-3].astype(float)
    h, w = min(len(crop), len(ref)), min(crop.shape[1], ref.shape[1])
    white = crop[:h, :w].min(axis=-1) > 200
    assert 0.08 < white.mean() < 0.5, "the lane number's white strokes"
    assert np.abs(crop[:h, :w] - ref[:h, :w]).mean() < 18.0  # (about 10; a mirrored face gives 30)


@pytest.mark.parametrize(("height", "focal", "pitch", "eye"), [(84, 86.5, 0.0, 1.2), (720, 1321.0, 0.0, 1.2), (84, 86.5, -0.17, 2.8)])
def test_sky_and_grass_card_follows_the_exact_gradient_with_few_rows(height: int, focal: float, pitch: float, eye: float) -> None:
    from opends_gym.render import meshes

    rows, cols = meshes.background_rows(height, focal, pitch, eye)
    centres = np.arange(height) + 0.5
    horizon = 0.5 * height + focal * math.tan(pitch)
    away = np.abs(centres - horizon) > 0.5  # the pixel the horizon crosses mixes sky and grass
    exact = meshes.background_colors(centres, height, focal, pitch, eye)
    blended = np.stack([np.interp(centres, rows, cols[:, k]) for k in range(3)], axis=1)
    assert np.abs(blended - exact)[away].max() <= meshes.BACKGROUND_TOL + 1e-9
    assert len(rows) <= 12  # (each row is two triangles of the card)
