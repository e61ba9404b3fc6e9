from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3.common.preprocessing import preprocess_obs

from noisybolt.agents import BoltFeaturesExtractor
from noisybolt.errors import ConfigError


def _space(image_shape: tuple[int, ...], dfa: list[int] | None) -> gym.spaces.Dict:
    spaces: dict[str, gym.spaces.Space] = {"image": gym.spaces.Box(0, 255, image_shape, np.uint8)}
    if dfa is not None:
        spaces["dfa"] = gym.spaces.MultiDiscrete(dfa)
    return gym.spaces.Dict(spaces)


@pytest.mark.parametrize(
    ("shape", "n_conv"),
    [((3, 6, 6), 64 * 3 * 3), ((3, 7, 7), 64 * 4 * 4), ((4, 84, 84), 64 * 7 * 7)],
)
def test_features_are_convolutions_then_one_hot_dfa_states(
    shape: tuple[int, int, int], n_conv: int
) -> None:
    space = _space(shape, [3, 2])
    extractor = BoltFeaturesExtractor(space)
    assert extractor.features_dim == n_conv + 3 + 2
    obs = {"image": np.zeros((2, *shape), np.uint8), "dfa": np.array([[2, 0], [0, 1]])}
    tensors = {k: torch.as_tensor(v) for k, v in obs.items()}
    features = extractor(preprocess_obs(tensors, space, normalize_images=False))
    # The last five features are exactly the one-hot DFA states, after the convolutions.
    np.testing.assert_array_equal(
        features[:, -5:].detach().numpy(), [[0, 0, 1, 1, 0], [1, 0, 0, 0, 1]]
    )


def test_channel_last_images_are_accepted() -> None:
    space = _space((6, 6, 3), [2])
    extractor = BoltFeaturesExtractor(space)
    out = extractor({"image": torch.zeros(1, 6, 6, 3), "dfa": torch.tensor([[1.0, 0.0]])})
    assert out.shape == (1, 64 * 9 + 2)


def test_unbolted_agent_has_image_features_only_and_projection_works() -> None:
    torch.manual_seed(0)
    extractor = BoltFeaturesExtractor(_space((3, 6, 6), None), image_features=32)
    assert extractor.features_dim == 32
    images = torch.randint(0, 11, (3, 3, 6, 6)).float()
    features = extractor({"image": images})  # no "dfa" entry: an unbolted agent
    assert features.shape == (3, 32)
    # The projection is a trained linear layer and a ReLU over the flattened convolutions.
    (linear, relu) = extractor.projection
    assert isinstance(linear, torch.nn.Linear) and isinstance(relu, torch.nn.ReLU)
    flat = extractor.convs(images)
    assert flat.shape == (3, 64 * 3 * 3)
    torch.testing.assert_close(features, torch.relu(flat @ linear.weight.T + linear.bias))
    assert (features > 0).any() and not torch.equal(features[0], features[1])
    # Its weights get gradients: the projection is part of what the agent learns.
    features.sum().backward()
    assert linear.weight.grad is not None and linear.weight.grad.abs().sum() > 0


def test_bad_spaces_are_named_errors() -> None:
    with pytest.raises(ConfigError, match="Dict"):
        BoltFeaturesExtractor(gym.spaces.Box(0, 1, (3, 6, 6)))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="no 'image' entry"):
        BoltFeaturesExtractor(gym.spaces.Dict({"dfa": gym.spaces.MultiDiscrete([2])}))
    with pytest.raises(ConfigError, match="at least 4"):
        BoltFeaturesExtractor(_space((3, 3, 3), [2]))


def test_the_2013_dqn_convolutions_on_an_atari_frame() -> None:
    # 84 -> (84 - 8) / 4 + 1 = 20 -> (20 - 4) / 2 + 1 = 9; 32 channels: 32 * 9 * 9 = 2592.
    extractor = BoltFeaturesExtractor(_space((4, 84, 84), [2]), cnn="atari2013")
    convs = [m for m in extractor.convs if isinstance(m, torch.nn.Conv2d)]
    assert [(c.out_channels, c.kernel_size, c.stride) for c in convs] == [
        (16, (8, 8), (4, 4)),
        (32, (4, 4), (2, 2)),
    ]
    assert extractor.features_dim == 2592 + 2
    projected = BoltFeaturesExtractor(_space((4, 84, 84), [2]), cnn="atari2013", image_features=256)
    assert projected.features_dim == 256 + 2


def test_cnn_kinds_override_the_choice_by_size() -> None:
    grid_on_frame = BoltFeaturesExtractor(_space((3, 40, 40), None), cnn="grid")
    assert grid_on_frame.features_dim == 64 * 37 * 37  # three 2x2 convolutions: 40 -> 37
    nature = BoltFeaturesExtractor(_space((3, 40, 40), None))  # auto: >= 36 on each side
    assert nature.features_dim == 64 * 1 * 1


def test_bad_cnn_settings_are_named_errors() -> None:
    with pytest.raises(ConfigError, match="cnn: unknown convolutions 'resnet'"):
        BoltFeaturesExtractor(_space((3, 84, 84), None), cnn="resnet")
    with pytest.raises(ConfigError, match="'atari2013' convolutions need at least 20"):
        BoltFeaturesExtractor(_space((3, 19, 30), None), cnn="atari2013")
    with pytest.raises(ConfigError, match="'nature' convolutions need at least 36"):
        BoltFeaturesExtractor(_space((3, 35, 84), None), cnn="nature")
