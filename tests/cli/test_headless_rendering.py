"""On a machine without a display, rendering a pygame world prints no SDL alarm."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from noisybolt.envs.labels import headless_rendering

RENDER = (
    "import gymnasium as gym\n"
    "env = gym.make('Acrobot-v1', render_mode='rgb_array')\n"
    "env.reset(seed=0)\n"
    "print(env.render().shape)\n"
)


def _render(prelude: str) -> subprocess.CompletedProcess[str]:
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in {"DISPLAY", "WAYLAND_DISPLAY", "XDG_RUNTIME_DIR", "SDL_VIDEODRIVER"}
    }
    return subprocess.run(
        [sys.executable, "-c", prelude + RENDER],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )


def test_a_pygame_world_renders_without_the_sdl_alarm() -> None:
    pytest.importorskip("pygame")
    bare = _render("")
    if "XDG_RUNTIME_DIR" not in bare.stderr:
        pytest.skip("this machine's SDL prints no alarm without a display")
    fixed = _render("from noisybolt.envs.labels import headless_rendering\nheadless_rendering()\n")
    assert fixed.stdout.strip() == bare.stdout.strip() == "(500, 500, 3)"
    assert "XDG_RUNTIME_DIR" not in fixed.stderr
    # A world labelled from Python (no command line) is as quiet: FluentLabels sets it up.
    labelled = _render(
        "import gymnasium as gym, noisybolt\n"
        "noisybolt.FluentLabels(gym.make('Acrobot-v1', render_mode='rgb_array'),\n"
        "                       fluents={'up': lambda e: True})\n"
    )
    assert "XDG_RUNTIME_DIR" not in labelled.stderr


def test_a_display_or_the_users_own_driver_is_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.delenv("SDL_VIDEODRIVER", raising=False)
    headless_rendering()
    assert "SDL_VIDEODRIVER" not in os.environ
    monkeypatch.delenv("DISPLAY")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("SDL_VIDEODRIVER", "x11")
    headless_rendering()
    assert os.environ["SDL_VIDEODRIVER"] == "x11"
    monkeypatch.delenv("SDL_VIDEODRIVER")
    headless_rendering()
    assert os.environ["SDL_VIDEODRIVER"] == "dummy"
