"""noisybolt: restraining bolts with noisy perception for reinforcement learning.

Layers, lowest first (a lower layer never imports a higher one):
``logic`` (LTLf → DFA), ``bolt`` (Algorithm 1 and reward timing), ``perception``
(cameras, noise, fluent classifiers), ``envs`` (worlds and their true fluents),
``wrappers``, ``agents``, ``experiments``, ``cli``.
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]
