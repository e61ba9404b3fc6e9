"""Where a Breakout player's games leave the wall: each row's bricks gone, all columns.

    .venv/bin/python scripts/breakout_walls.py runs/breakout-ram-ppo-...-seed0 --episodes 64

The periodic evaluations record the left column only (the bolt's fluents). Whether a
player misses the column's top bricks because it never reaches the top rows at all, or
because it reaches them elsewhere but not on the left, is read off the whole wall at the
end of each game: this plays the run's final model (or its latest checkpoint), greedy
unless ``--stochastic``, on evaluation games of the run's own world and bolt (the world in
this process; 8 games in play, the episodes spread evenly over them, as the periodic
evaluations spread theirs, so that short games are not over-represented), and prints,
over the games: the mean score, the share of each row's bricks gone (all 18 columns)
beside the share of games that took that row's left brick, the share of games that took
any brick of the top two rows, the share that cleared the column, and one line per game
(``--games``): its score, the top two rows (``#`` gone) and the left column, top row
first.

The wall is read from the console's RAM as each game ended
(:meth:`~noisybolt.envs.breakout.BreakoutWorld.ended_rams`), whatever the agent sees:
image runs (``breakout``) and RAM runs (``breakout-ram``) alike.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import torch

from noisybolt.envs.breakout import BRICK_ROWS, bricks_present
from noisybolt.runs.config import TrainConfig
from noisybolt.runs.environments import make_env, prepare_bolt
from noisybolt.runs.evaluation import episode_targets
from noisybolt.runs.run_evaluation import load_run_model
from noisybolt.runs.rundir import RunDirectory

#: The worlds whose games are Breakout's (the image agent's and the RAM agent's).
BREAKOUT_WORLDS = ("breakout", "breakout-ram")


def final_walls(run_dir: Path, *, episodes: int, seed: int, stochastic: bool) -> list[Any]:
    """``(score, gone)`` per game: ``gone`` bool ``[rows, columns]``, True where the brick
    is gone at the game's end."""
    torch.set_num_threads(1)
    run = RunDirectory(run_dir)
    config = TrainConfig.from_dict(run.read_config()).override(
        {"world.workers": 0, "world.overlap": False}
    )
    if config.world_config.name not in BREAKOUT_WORLDS:
        raise SystemExit(
            f"{run_dir} is a {config.world_config.name!r} run: only Breakout runs "
            f"({', '.join(BREAKOUT_WORLDS)}) have a wall to read"
        )
    setup = prepare_bolt(config, seed=seed)
    model = load_run_model(run, config)
    n_envs = min(8, episodes)
    env = make_env(
        config,
        setup.detector,
        training=False,
        n_envs=n_envs,
        seed=seed,
        dfas=setup.dfas,
        letters=setup.letters,
        belief=setup.belief,
    )
    # Spread evenly over the games in play, as the periodic evaluations are.
    targets = episode_targets(episodes, n_envs)
    counts = np.zeros(n_envs, dtype=int)
    games: list[Any] = []
    try:
        obs = env.reset()
        while (counts < targets).any():
            actions = model.predict(obs, deterministic=not stochastic)[0]
            obs, _, dones, infos = env.step(actions)
            if not dones.any():
                continue
            # the evaluation world is in this process, whole games: a done is a game's end
            ended = env.env_method("ended_rams", indices=[0])[0]
            for i in np.flatnonzero(dones):
                if counts[i] >= targets[i]:
                    continue
                counts[i] += 1
                games.append((float(infos[i]["episode"]["r"]), ~bricks_present(ended[i])))
    finally:
        env.close()
    return games


def report(games: list[Any], *, lines: bool) -> str:
    """The summary (and one line per game) as text."""
    walls = np.array([gone for _, gone in games])
    scores = np.array([score for score, _ in games])
    out = [
        f"{len(games)} games, score {scores.mean():.1f} ± {scores.std():.1f}",
        "row (top first): bricks gone, all columns | games that took the left brick",
    ]
    for row in range(BRICK_ROWS):
        out.append(f"  {row}: {walls[:, row].mean():.0%} | {walls[:, row, 0].mean():.0%}")
    out.append(
        f"games that took any brick of row 0: {walls[:, 0].any(axis=1).mean():.0%}, of row 1: "
        f"{walls[:, 1].any(axis=1).mean():.0%}; cleared the column: "
        f"{walls[:, :, 0].all(axis=1).mean():.0%}"
    )
    if lines:
        out.append("score | row 0 | row 1 | left column, top first")

        def draw(bits: np.ndarray) -> str:
            return "".join("#" if gone else "." for gone in bits)

        for score, gone in games:
            out.append(f"{score:5.0f} | {draw(gone[0])} | {draw(gone[1])} | {draw(gone[:, 0])}")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--episodes", type=int, default=32)
    parser.add_argument("--seed", type=int, default=12345, help="seeds the evaluation games")
    parser.add_argument("--stochastic", action="store_true", help="sample actions")
    parser.add_argument("--games", action="store_true", help="one line per game")
    args = parser.parse_args()
    if args.episodes < 1:
        parser.error("--episodes must be at least 1")
    games = final_walls(
        args.run, episodes=args.episodes, seed=args.seed, stochastic=args.stochastic
    )
    print(report(games, lines=args.games))


if __name__ == "__main__":
    main()
