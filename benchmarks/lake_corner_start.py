"""Can the unbolted learner find FrozenLake 8x8's goal from the bottom-left cell?

A diagnostic for the world suite's ``F(bottom_left)`` on FrozenLake (issue 45): the
compliant route goes down the left column to the corner and then round the holes to the
goal. This trains the learner *unbolted*, with the fallback hyperparameters the suite
uses (``configs/hyperparams/_default.yaml``: 8 environments, reward normalisation, a
64x64 MLP; PPO 128 frames an update, A2C 5), on the same lake started at the
bottom-left cell, and asks only for the goal: the second half of the compliant route,
with nothing a bolt pays. Prints the goal rate of 20 sampled episodes every 50k frames.

    .venv/bin/python benchmarks/lake_corner_start.py --algo a2c --seed 0 --frames 300000
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import torch
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecNormalize

#: FrozenLake's 8x8 map with the start moved to the bottom-left cell.
CORNER_START = [
    "FFFFFFFF",
    "FFFFFFFF",
    "FFFHFFFF",
    "FFFFFHFF",
    "FFFHFFFF",
    "FHHFFFHF",
    "FHFFHFHF",
    "SFFHFFFG",
]
SETTINGS = {
    "ppo": {"n_steps": 128, "batch_size": 256, "n_epochs": 4, "learning_rate": 3e-4},
    "a2c": {"n_steps": 5, "learning_rate": 7e-4, "gae_lambda": 1.0},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--algo", choices=sorted(SETTINGS), default="a2c")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--frames", type=int, default=300_000)
    args = parser.parse_args()
    torch.set_num_threads(1)

    def make() -> gym.Env:
        return gym.make("FrozenLake-v1", desc=CORNER_START, is_slippery=False)

    env = VecNormalize(make_vec_env(make, n_envs=8, seed=args.seed), norm_obs=False)
    learner = PPO if args.algo == "ppo" else A2C
    model = learner(
        "MlpPolicy",
        env,
        seed=args.seed,
        ent_coef=0.01,
        policy_kwargs={"net_arch": [64, 64]},
        **SETTINGS[args.algo],
    )
    probe = make()
    for chunk in range(1, args.frames // 50_000 + 1):
        model.learn(50_000, reset_num_timesteps=False)
        goals = 0
        for episode in range(20):
            obs, _ = probe.reset(seed=1000 + episode)
            done, reward = False, 0.0
            while not done:
                action, _ = model.predict(obs, deterministic=False)
                obs, reward, terminated, truncated, _ = probe.step(int(action))
                done = terminated or truncated
            goals += reward > 0
        rate = goals / 20
        print(f"{args.algo} seed {args.seed} {chunk * 50}k frames: goal {rate:.0%}", flush=True)


if __name__ == "__main__":
    main()
