"""Bolt Gymnasium's CartPole: fluents over the cart's place and the pole's lean.

A world nobody here wrote, labelled in a few lines: the bolt's vocabulary is where the
cart is (``far_left``, ``far_right``: beyond 0.5 of the track's centre, of 2.4 either
side) and which way the pole leans (``leaning_left``, ``leaning_right``: beyond 0.05
rad). The bolt has no camera (``camera=False``): its detectors read the fluents' truth,
the oracle exactly and ``synthetic`` with noise. ``benchmarks/cartpole_specs.py`` draws
specs over these fluents at random and trains them with the built-in defaults.

Run, from this folder (the compliance scale comes from the declared return bounds: an
episode returns 0 to 500)::

    noisybolt train --world cartpole:make_cart --spec "F(far_left)" --detector synthetic
        --frames 100k                                                    (one line)
"""

import gymnasium as gym

import noisybolt

#: The fluents, in the bolt's column order.
FLUENTS = ("far_left", "far_right", "leaning_left", "leaning_right")


def make_cart() -> noisybolt.FluentLabels:
    """CartPole-v1, its fluents read from the state ``(x, x_dot, theta, theta_dot)``."""
    cart = gym.make("CartPole-v1")
    state = lambda env: env.unwrapped.state  # noqa: E731
    fluents = {
        "far_left": lambda env: state(env)[0] < -0.5,
        "far_right": lambda env: state(env)[0] > 0.5,
        "leaning_left": lambda env: state(env)[2] < -0.05,
        "leaning_right": lambda env: state(env)[2] > 0.05,
    }
    return noisybolt.FluentLabels(cart, fluents=fluents, camera=False, return_bounds=(0, 500))
