"""Bolt a MiniGrid level: in ``MiniGrid-Empty-5x5-v0`` the bolt wants the agent to go down
the left wall before it crosses the room.

The agent starts in the top-left cell facing east, the goal is bottom-right. The shortest
route runs along the top wall (5 actions); the bolt's spec
``G(!top_row | left_col) & F(at_goal)`` (reach the goal, never on the top row away from the
left wall) pays 1 for the one down the left wall (6 actions). The agent sees the whole room
as MiniGrid's symbolic grid (noisybolt's small-image convolutions); the bolt looks through a
small camera (MiniGrid's own drawing, 4 pixels a cell).

Two ways to train it:

* ``python examples/minigrid_empty.py``: the paper-style spec below (1 at the episode's
  end) with these PPO settings, not tuned: one seed had reached the goal by the top-wall
  shortcut after 30k frames and gone down the left wall without reaching the goal after
  60k.
* From this folder, the command line with the default ``compliance`` reward scheme (its
  scale from ``return_bounds``: MiniGrid returns between 0 and 1), rewards normalised
  (the default for a user's world since it was measured to matter; this example needed
  ``--hp normalize_reward=true`` before); the grid's small integers reach the network as
  they are (noisybolt sees them in random play and turns SB3's division by 255 off, with a
  warning). Measured, seed 0, 60k frames (with both settings given by hand then): goal
  100 %, compliance 100 % (first at 40k)::

      noisybolt train --world minigrid_empty:make_room --spec "G(!top_row | left_col)"
          --detector oracle --frames 60k                                   (one line)

The test suite checks the bolting (both routes, hand-computed rewards), not the learning.
"""

import gymnasium as gym
import minigrid  # noqa: F401  (registers the MiniGrid levels)
from minigrid.wrappers import FullyObsWrapper, ImgObsWrapper
from stable_baselines3 import PPO

import noisybolt
from noisybolt.agents.extractor import BoltFeaturesExtractor


def make_room() -> noisybolt.FluentLabels:
    room = ImgObsWrapper(FullyObsWrapper(gym.make("MiniGrid-Empty-5x5-v0")))
    fluents = {
        "top_row": lambda env: env.agent_pos[1] == 1,
        "left_col": lambda env: env.agent_pos[0] == 1,
        "at_goal": lambda env: tuple(env.agent_pos) == (3, 3),
    }
    camera = lambda env: env.unwrapped.get_frame(highlight=False, tile_size=4)  # noqa: E731
    return noisybolt.FluentLabels(
        room, fluents=fluents, camera=camera, success="at_goal", return_bounds=(0, 1)
    )


SPEC = noisybolt.Spec(
    "G(!top_row | left_col) & F(at_goal)",
    terminal_reward=1.0,
    low_confidence_cost=0.0,
    reward_timing="episode_end",
)


def train(frames: int = 200_000, seed: int = 0) -> PPO:
    env = noisybolt.make_bolted_vec_env(make_room, 8, [SPEC], "oracle", seed=seed)
    policy = {"features_extractor_class": BoltFeaturesExtractor, "normalize_images": False}
    model = PPO(
        "MultiInputPolicy",
        env,
        n_steps=32,
        batch_size=128,
        n_epochs=4,
        learning_rate=5e-4,
        policy_kwargs=policy,
        seed=seed,
        verbose=0,
    )
    return model.learn(frames)


if __name__ == "__main__":
    model = train()
    env = noisybolt.RestrainingBoltWrapper(make_room(), [SPEC], "oracle")
    obs, info = env.reset(seed=0)
    done, cells = False, []
    while not done:
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(int(action))
        done, cells = terminated or truncated, [*cells, tuple(env.unwrapped.agent_pos)]
    complied = bool(info["true_accepting"][0])  # from the true fluents, not the detector's
    print(f"cells {cells}, goal {info['is_success']}, complied {complied}")
