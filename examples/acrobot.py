"""Bolt Gymnasium's Acrobot: fluents over the swing, with a goal.

A second world nobody here wrote, labelled in a few lines. The task is the env's own:
swing the tip above the bar (``-1`` a step until then, 500 steps at most). The bolt's
vocabulary: ``tip_high`` (the goal: the tip above the bar), ``fast`` (the first link
turning faster than ``limit`` rad/s; random play seldom does, a swing-up does), and where
the first link points, ``left`` or ``right`` (beyond 30 degrees either side of hanging
straight down). No camera (``camera=False``): the detectors read the fluents' truth, the
oracle exactly and ``synthetic`` with noise. ``benchmarks/cartpole_specs.py --world
examples.acrobot:make_acrobot`` draws specs over these fluents at random.

Run, from this folder (an episode returns -500 to 0, declared)::

    noisybolt train --world acrobot:make_acrobot --spec "G(!fast)" --detector synthetic
        --frames 150k                                                    (one line)
"""

import gymnasium as gym
import numpy as np

import noisybolt


def make_acrobot(limit: float = 5.0) -> noisybolt.FluentLabels:
    """Acrobot-v1, its fluents read from the state ``(theta1, theta2, dtheta1, dtheta2)``."""
    acrobot = gym.make("Acrobot-v1")
    state = lambda env: env.unwrapped.state  # noqa: E731

    def tip_high(env: gym.Env) -> bool:
        theta1, theta2 = state(env)[:2]
        return bool(-np.cos(theta1) - np.cos(theta2 + theta1) > 1.0)

    fluents = {
        "tip_high": tip_high,
        "fast": lambda env: bool(abs(state(env)[2]) > limit),
        "left": lambda env: bool(np.sin(state(env)[0]) < -0.5),
        "right": lambda env: bool(np.sin(state(env)[0]) > 0.5),
    }
    return noisybolt.FluentLabels(
        acrobot, fluents=fluents, camera=False, success="tip_high", return_bounds=(-500, 0)
    )
