"""Night from the scene's lights: a scene lit only by a dim ambient light is dark, except
where the ego's low beam falls on the road ahead; the corpus's lit scenes stay daylight."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from opends_gym.render import make_renderer
from opends_gym.render.night import daylight
from opends_gym.sim.world import World
from opends_gym.task import load_task
from opends_gym.task.model_scene import AmbientLight


def _view(task: object, headlights: bool = True) -> np.ndarray:
    world = World(task)  # type: ignore[arg-type]
    world.run(0.5)
    view = make_renderer("driver_view", world)
    view.headlights = headlights
    return np.asarray(view.render(160, 90), float)


def test_dim_scene_lights_make_night_with_headlights() -> None:
    task = load_task("LaneChangeTest")
    assert daylight(World(task)) == 1.0  # no scene lights: OpenDS's default daylight
    assert daylight(World("ReactionTest")) == 1.0  # four 0.7 directional lights from 35 degrees above
    dim = dataclasses.replace(task, scene=dataclasses.replace(task.scene, lights=(AmbientLight((0.1, 0.1, 0.1, 1.0)),)))
    assert daylight(World(dim)) == pytest.approx(0.1)
    day, night = _view(task), _view(dim)
    sky = (slice(0, 10), slice(None))
    assert night[sky].mean() < 0.15 * day[sky].mean()  # the sky is dark
    road_ahead = (slice(80, 90), slice(70, 90))  # just in front of the car, in the beam
    assert night[road_ahead].mean() > 0.6 * day[road_ahead].mean()
    side = (slice(80, 90), slice(0, 10))  # the same distance, outside the beam
    assert night[side].mean() < 0.2 * day[side].mean()
    dark = _view(dim, headlights=False)  # toggle_headlight in the drive window
    assert dark[road_ahead].mean() < 0.2 * day[road_ahead].mean()


def test_headlight_key_toggles_the_beam() -> None:
    from opends_gym.human.view_state import ViewState

    view = ViewState.from_settings(load_task("ReactionTest").settings)
    assert view.headlights and view.command("toggle_headlight") and not view.headlights
