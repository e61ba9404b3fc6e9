"""The paper's policy body: convolutions over the agent's image, then the one-hot DFA states.

Section 2.2 of the paper decomposes the policy as ``π(s') = H(G(s) | Q)``: ``G`` is a stack
of convolutions over the agent's image, ``Q`` the concatenated one-hot DFA states, and ``H``
dense layers. With Stable-Baselines3, ``G | Q`` is a features extractor and ``H`` is the
policy's ``net_arch``. SB3 already one-hot encodes ``MultiDiscrete`` entries of a ``Dict``
observation and moves channel-last uint8 images to channel-first before the extractor, so
this module only has to pick convolutions that suit the image size: MiniGrid-sized grids
and 7×7 views are far below the 36×36 that SB3's ``NatureCNN`` needs.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.preprocessing import get_flattened_obs_dim, preprocess_obs
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

from noisybolt.errors import ConfigError

__all__ = [
    "CNN_KINDS",
    "BoltFeaturesExtractor",
    "check_agent_observation",
    "check_cnn",
    "conv_stack",
]

#: Images with both sides at least this large get the Nature-DQN convolutions.
LARGE_IMAGE_MIN_SIDE = 36

#: Width of the dense layer over an observation that is not an image (a Discrete state,
#: one-hot, or a Box vector), unless ``image_features`` sets it.
VECTOR_FEATURES = 64

#: The convolution stacks :func:`conv_stack` builds, by name (``auto``: by image size).
CNN_KINDS = ("auto", "nature", "atari2013", "grid")


def check_cnn(kind: object) -> str:
    """``kind`` if it names one of :data:`CNN_KINDS`, else a :class:`ConfigError`."""
    if kind not in CNN_KINDS:
        raise ConfigError(f"cnn: unknown convolutions {kind!r}; known: {list(CNN_KINDS)}")
    return str(kind)


def conv_stack(in_channels: int, height: int, width: int, kind: str = "auto") -> nn.Sequential:
    """Convolutions for the agent's image.

    ``kind``:

    - ``nature``: the Nature DQN's three convolutions (32 8×8/4, 64 4×4/2, 64 3×3/1), what
      SB3's ``NatureCNN`` and the RL Zoo's Atari agents use; needs 36×36 or more.
    - ``atari2013``: the 2013 DQN's two (16 8×8/4, 32 4×4/2; Mnih et al., "Playing Atari
      with Deep Reinforcement Learning"): on an 84×84 frame under a third of the Nature
      stack's multiply-adds and a 2,592-long output against 3,136, for more frames per
      hour on a CPU (``benchmarks/breakout_network.py`` measures it); needs 20×20 or more.
    - ``grid``: the paper's own code base for MiniGrid (rl-starter-files: three 2×2
      convolutions of 16, 32, 64 channels), without its max-pool so that a 6×6 room still
      leaves a 3×3 map; needs 4×4 or more.
    - ``auto`` (default): ``nature`` for images at least 36 on each side, else ``grid``.

    Raises:
        ConfigError: an unknown ``kind``, or an image too small for it.
    """
    kind = check_cnn(kind)
    if kind == "auto":
        kind = "nature" if min(height, width) >= LARGE_IMAGE_MIN_SIDE else "grid"
    smallest = {"nature": LARGE_IMAGE_MIN_SIDE, "atari2013": 20, "grid": 4}[kind]
    if min(height, width) < smallest:
        raise ConfigError(
            f"the agent's image is {height}×{width}: the {kind!r} convolutions need at least "
            f"{smallest}×{smallest}"
        )
    if kind == "atari2013":
        return nn.Sequential(
            nn.Conv2d(in_channels, 16, kernel_size=8, stride=4),
            nn.ReLU(),
            nn.Conv2d(16, 32, kernel_size=4, stride=2),
            nn.ReLU(),
            nn.Flatten(),
        )
    if kind == "nature":
        return nn.Sequential(
            nn.Conv2d(in_channels, 32, kernel_size=8, stride=4),
            nn.ReLU(),
            nn.Conv2d(32, 64, kernel_size=4, stride=2),
            nn.ReLU(),
            nn.Conv2d(64, 64, kernel_size=3, stride=1),
            nn.ReLU(),
            nn.Flatten(),
        )
    return nn.Sequential(
        nn.Conv2d(in_channels, 16, kernel_size=2),
        nn.ReLU(),
        nn.Conv2d(16, 32, kernel_size=2),
        nn.ReLU(),
        nn.Conv2d(32, 64, kernel_size=2),
        nn.ReLU(),
        nn.Flatten(),
    )


def _is_vector(space: gym.Space) -> bool:
    """Whether the agent's observation is a state or a vector rather than an image."""
    if isinstance(space, (gym.spaces.Discrete, gym.spaces.MultiDiscrete, gym.spaces.MultiBinary)):
        return True
    return isinstance(space, gym.spaces.Box) and len(space.shape) == 1


def check_agent_observation(space: gym.Space, *, world: str) -> None:
    """Refuses an agent's observation the agents cannot read, before anything is trained:
    an image ``(H, W, C)`` or ``(C, H, W)``, a flat ``Box`` vector, or a ``Discrete``,
    ``MultiDiscrete`` or ``MultiBinary`` state are read; a ``Dict`` or ``Tuple`` (SB3 takes
    no nested spaces beside the bolt's own ``dfa`` entry), a ``Text`` or ``Graph``, or a
    ``Box`` of 2 or 4+ axes are not, and no hyperparameter changes that.

    Raises:
        ConfigError: naming the world, its space and how to flatten it.

    Example:
        >>> check_agent_observation(gym.spaces.Box(0, 255, (84, 84, 3), np.uint8), world="w")
        >>> check_agent_observation(
        ...     gym.spaces.Dict({"pos": gym.spaces.Discrete(4)}), world="w")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        noisybolt.errors.ConfigError: world 'w' gives the agent Dict('pos': Discrete(4)): ...
    """
    if _is_vector(space):
        return
    if isinstance(space, gym.spaces.Box) and len(space.shape) == 3:
        return
    raise ConfigError(
        f"world {world!r} gives the agent {space}: the agents read an image (H, W, C), a "
        "flat Box vector or a Discrete/MultiDiscrete/MultiBinary state; reduce the "
        "observation to one in the world's factory, before FluentLabels: keep its image "
        "(MiniGrid: minigrid.wrappers.ImgObsWrapper) or flatten it "
        "(gymnasium.wrappers.FlattenObservation, for spaces of boxes and discretes)"
    )


def _channels_first(shape: tuple[int, ...]) -> bool:
    # SB3 transposes channel-last uint8 images before they reach us; other image-like Boxes
    # (float or non-0..255 bounds) arrive as declared, so decide from the shape: the
    # channel axis is the smallest one.
    return bool(np.argmin(shape) == 0)


class BoltFeaturesExtractor(BaseFeaturesExtractor):
    """Features ``G(image) | Q`` for ``Dict{"image": Box(H,W,C), "dfa": MultiDiscrete}``.

    A world whose observation is not an image (a ``Discrete`` state, which SB3 one-hot
    encodes, or a flat ``Box`` vector) gets a dense layer of :data:`VECTOR_FEATURES`
    units with a ReLU instead of the convolutions, before the DFA states are appended.

    Args:
        observation_space: the (possibly SB3-transposed) Dict observation space.
        image_key: key of the agent's image.
        dfa_key: key of the DFA states (absent or empty for an unbolted agent).
        image_features: if given, a linear layer + ReLU projects the flattened
            convolution output to this many features before the DFA states are appended
            (for a non-image observation: the dense layer's width).
        cnn: which convolutions (see :func:`conv_stack`; default by image size).

    Example:
        >>> space = gym.spaces.Dict({
        ...     "image": gym.spaces.Box(0, 255, (3, 6, 6), np.uint8),
        ...     "dfa": gym.spaces.MultiDiscrete([3, 2])})
        >>> extractor = BoltFeaturesExtractor(space)
        >>> obs = {"image": torch.zeros(2, 3, 6, 6), "dfa": torch.zeros(2, 5)}
        >>> extractor(obs).shape
        torch.Size([2, 581])
        >>> lake = gym.spaces.Dict({
        ...     "image": gym.spaces.Discrete(16), "dfa": gym.spaces.MultiDiscrete([3])})
        >>> body = BoltFeaturesExtractor(lake)
        >>> body({"image": torch.zeros(2, 16), "dfa": torch.zeros(2, 3)}).shape
        torch.Size([2, 67])
    """

    #: Where each spec's block of the one-hot DFA states starts (``MultiDiscrete`` only).
    state_offsets: torch.Tensor

    #: The dtype the convolutions and the projection compute in under autocast (None:
    #: float32, no autocast); set from ``algorithm.precision`` by
    #: :func:`noisybolt.runs.models.set_precision`, not saved with the model.
    compute_dtype: torch.dtype | None = None

    def __init__(
        self,
        observation_space: gym.spaces.Dict,
        *,
        image_key: str = "image",
        dfa_key: str = "dfa",
        image_features: int | None = None,
        cnn: str = "auto",
    ) -> None:
        if not isinstance(observation_space, gym.spaces.Dict):
            raise ConfigError(
                f"BoltFeaturesExtractor needs a Dict observation space, got {observation_space}"
            )
        if image_key not in observation_space.spaces:
            raise ConfigError(
                f"observation has no {image_key!r} entry; it has {list(observation_space.spaces)}"
            )
        image_space = observation_space.spaces[image_key]
        shape = tuple(int(s) for s in image_space.shape or ())
        first = False
        projection: nn.Module = nn.Identity()
        if _is_vector(image_space):
            # Not an image (a Discrete state, already one-hot by SB3, or a Box vector): a
            # dense layer stands where the convolutions would.
            n_in = get_flattened_obs_dim(image_space)
            n_image = image_features if image_features is not None else VECTOR_FEATURES
            convs: nn.Module = nn.Sequential(nn.Flatten(), nn.Linear(n_in, n_image), nn.ReLU())
        else:
            if len(shape) != 3:
                raise ConfigError(
                    f"the agent's observation must be an image (H, W, C), a Discrete state or "
                    f"a flat Box vector, got {image_space}"
                )
            first = _channels_first(shape)
            channels, height, width = shape if first else (shape[2], shape[0], shape[1])
            convs = conv_stack(channels, height, width, cnn)
            with torch.no_grad():
                n_conv = int(convs(torch.zeros(1, channels, height, width)).shape[1])
            n_image = n_conv
            if image_features is not None:
                projection = nn.Sequential(nn.Linear(n_conv, image_features), nn.ReLU())
                n_image = image_features
        dfa_space = observation_space.spaces.get(dfa_key)
        n_dfa = get_flattened_obs_dim(dfa_space) if dfa_space is not None else 0
        super().__init__(observation_space, features_dim=n_image + n_dfa)
        self.image_key = image_key
        self.dfa_key = dfa_key if n_dfa else None
        self.channels_first = first
        self.is_vector = _is_vector(image_space)
        self.convs = convs
        self.projection = projection
        self.n_dfa = n_dfa
        self.one_hot_states = isinstance(dfa_space, gym.spaces.MultiDiscrete) and n_dfa > 0
        if self.one_hot_states:
            assert isinstance(dfa_space, gym.spaces.MultiDiscrete)
            sizes = torch.as_tensor(np.asarray(dfa_space.nvec, dtype=np.int64).reshape(-1))
            # Where each spec's one-hot block starts. Not persistent: a model saved before
            # it existed loads unchanged, and the offsets follow from the space anyway.
            self.register_buffer("state_offsets", torch.cumsum(sizes, 0) - sizes, persistent=False)

    def preprocess(
        self, observations: dict[str, torch.Tensor], *, normalize_images: bool
    ) -> dict[str, torch.Tensor]:
        """The observation as :meth:`forward` takes it: what SB3's ``preprocess_obs`` makes
        of it, with the DFA states one-hot in one scatter over the batch.

        SB3 one-hot encodes a ``MultiDiscrete`` entry one sub-space at a time (a split, a
        ``one_hot`` per spec with its range check, a concatenation: ~60 us a call on the
        CPU whatever the batch, called for every rollout step and minibatch); this is one
        ``scatter_`` (~8 us), with the same values for states within their ranges (tested).
        The bolt never observes a state outside its DFA's range.
        """
        space = self._observation_space
        assert isinstance(space, gym.spaces.Dict)
        out: dict[str, torch.Tensor] = {}
        for key, value in observations.items():
            if key == self.dfa_key and self.one_hot_states:
                index = value.long().reshape(value.shape[0], -1) + self.state_offsets
                one_hot = torch.zeros(value.shape[0], self.n_dfa, device=value.device)
                out[key] = one_hot.scatter_(1, index, 1.0)
            else:
                processed = preprocess_obs(value, space[key], normalize_images=normalize_images)
                assert isinstance(processed, torch.Tensor)
                out[key] = processed
        return out

    def forward(self, observations: dict[str, torch.Tensor]) -> torch.Tensor:
        """Concatenates the image features with the (already one-hot) DFA states."""
        image = observations[self.image_key].float()
        if not (self.channels_first or self.is_vector):
            image = image.permute(0, 3, 1, 2)
        if self.compute_dtype is None:
            features = self.projection(self.convs(image))
        else:
            # Mixed precision where the cost is: the weights stay float32 (autocast rounds
            # them per product), and what leaves is float32 again, so the DFA states, the
            # dense layers and the log-probabilities PPO's ratio compares are float32.
            with torch.autocast(image.device.type, dtype=self.compute_dtype):
                features = self.projection(self.convs(image))
            features = features.float()
        if self.dfa_key is None:
            return features
        return torch.cat([features, observations[self.dfa_key].float()], dim=1)
