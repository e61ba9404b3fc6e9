"""Pictures: an episode recorded with what the bolt saw and drawn as a GIF
(:mod:`~noisybolt.viz.episodes`), and heat-maps of where policies go
(:mod:`~noisybolt.viz.heatmaps`). matplotlib-based, so ``import noisybolt`` never
imports this package."""

from __future__ import annotations

from noisybolt.viz.episodes import (
    BAND_COLOURS,
    DPI,
    EpisodeRecording,
    default_frame,
    policy_from_model,
    record_episode,
    render_episode_frames,
    save_episode_gif,
)
from noisybolt.viz.heatmaps import (
    compare_heatmaps,
    gridworld_room,
    trajectory_heatmap,
    visit_counts,
)

__all__ = [
    "BAND_COLOURS",
    "DPI",
    "EpisodeRecording",
    "compare_heatmaps",
    "default_frame",
    "gridworld_room",
    "policy_from_model",
    "record_episode",
    "render_episode_frames",
    "save_episode_gif",
    "trajectory_heatmap",
    "visit_counts",
]
