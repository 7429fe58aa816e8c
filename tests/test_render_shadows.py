"""Sun shadows "where the GPU allows": the `shadows=` option and `OPENDS_GYM_SHADOWS` decide
them through the graphics pipe's shader support; this host's software pipe has none."""

from __future__ import annotations

import numpy as np
import pytest

from opends_gym.render import make_renderer
from opends_gym.render.compose import ViewComposer
from opends_gym.sim.world import World
from opends_gym.task.bundled import BUNDLED_DIR


@pytest.fixture
def world(monkeypatch: pytest.MonkeyPatch) -> World:
    monkeypatch.delenv("OPENDS_GYM_RENDER_PIPE", raising=False)  # the software pipe (p3tinydisplay)
    monkeypatch.delenv("OPENDS_GYM_SHADOWS", raising=False)
    w = World(BUNDLED_DIR / "ThreeVehiclePlatoon")
    w.run(2.0)
    return w


def test_auto_gives_no_shadows_on_the_software_pipe_and_the_same_frame(world: World) -> None:
    auto = make_renderer("chase", world)
    off = make_renderer("chase", world, shadows="off")
    assert auto.shadow_mode == "auto" and not auto.shadows_active and not off.shadows_active
    assert np.array_equal(auto.render(96, 54), off.render(96, 54))
    assert not ViewComposer(world).view.shadows_active


def test_shadows_on_without_shaders_is_a_one_line_error_naming_the_pipe(world: World) -> None:
    with pytest.raises(RuntimeError, match=r"p3tinydisplay.*OPENDS_GYM_RENDER_PIPE=gl or egl") as err:
        make_renderer("driver_view", world, shadows="on")
    assert "\n" not in str(err.value)
    with pytest.raises(RuntimeError, match="shadows='on'"):
        ViewComposer(world, shadows="on")


def test_the_environment_sets_the_default_and_bad_values_are_named(world: World, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENDS_GYM_SHADOWS", "on")
    with pytest.raises(RuntimeError, match="p3tinydisplay"):
        make_renderer("driver_view", world)
    assert not make_renderer("driver_view", world, shadows="off").shadows_active  # the option beats the environment
    monkeypatch.setenv("OPENDS_GYM_SHADOWS", "sometimes")
    with pytest.raises(ValueError, match=r"OPENDS_GYM_SHADOWS='sometimes': choose one of auto, on, off"):
        make_renderer("driver_view", world)
    with pytest.raises(ValueError, match=r"shadows='yes'"):
        make_renderer("driver_view", world, shadows="yes")
