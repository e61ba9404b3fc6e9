"""Bolt Gymnasium's FrozenLake: the bolt wants the agent off the top row after its first step.

Both shortest routes to the goal take six steps, one along the top row, one down the left
column; the bolt's spec ``X(G(!top_row))`` picks the second. The bolt sees the lake through
the env's own render (256x256 RGB); here an oracle reads the fluents (use ``"synthetic"``
for noisy readings, or ``"classifier"`` to learn them from the images). The lake's 4x4
cells are declared as a grid, so ``noisybolt evaluate RUN --heatmap map.png`` draws
where the agent goes.

Run: ``python examples/frozenlake.py``; or through the CLI, from this folder::

    noisybolt train --world frozenlake:make_lake --spec "X(G(!top_row))"
        --detector synthetic --frames 20k     (one line; the compliance scale comes from
        the declared return bounds: an episode returns 0 or 1)
"""

import gymnasium as gym
from stable_baselines3 import PPO

import noisybolt


def make_lake() -> noisybolt.FluentLabels:
    lake = gym.make("FrozenLake-v1", render_mode="rgb_array", is_slippery=False)
    fluents = {"top_row": lambda env: env.s < 4, "at_goal": lambda env: env.s == 15}
    grid = noisybolt.GridLayout(width=4, height=4, position=lambda env: (env.s % 4, env.s // 4))
    return noisybolt.FluentLabels(
        lake, fluents=fluents, success="at_goal", return_bounds=(0, 1), grid=grid
    )


# Paid once, when the episode ends with the spec satisfied: no reward for loitering.
SPEC = noisybolt.Spec(
    "X(G(!top_row))", terminal_reward=1.0, low_confidence_cost=0.0, reward_timing="episode_end"
)


def train(frames: int = 20_000, seed: int = 0) -> PPO:
    env = noisybolt.make_bolted_vec_env(make_lake, 8, [SPEC], "oracle", seed=seed)
    model = PPO("MultiInputPolicy", env, n_steps=64, batch_size=128, seed=seed, verbose=0)
    return model.learn(frames)


if __name__ == "__main__":
    model = train()
    env = noisybolt.RestrainingBoltWrapper(make_lake(), [SPEC], "oracle")
    obs, info = env.reset(seed=0)
    done, states = False, []
    while not done:
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(int(action))
        done, states = terminated or truncated, [*states, int(obs["image"])]
    complied = bool(info["true_accepting"][0])  # from the true fluents, not the detector's
    print(f"route {states}, goal {info['is_success']}, complied {complied}")
