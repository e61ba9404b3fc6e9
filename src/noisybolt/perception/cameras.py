"""World-independent camera helpers: composite cached tiles into a batch of images.

A tile world (a gridworld, a board game) draws every cell from a small atlas of tile
images. Rendering a batch is then pure array work: copy a static background and paste, per
image, the few tiles that differ (the agent). :class:`TileCompositor` does this for
``[n_images, ...]`` at once with numpy, with no Python loop over images, so a camera costs
a memory copy rather than a rasterisation. Worlds build the atlas once (the gridworld takes
MiniGrid's own tiles, so its pictures match MiniGrid's renderer pixel for pixel).

Example:
    >>> import numpy as np
    >>> tiles = np.zeros((2, 2, 2, 3), dtype=np.uint8)
    >>> tiles[1] = 255  # tile 1 is white, tile 0 black
    >>> comp = TileCompositor(tiles, layout=np.zeros((2, 3), dtype=np.intp))
    >>> images = comp.render_sprites(np.array([1, 1]), rows=np.array([0, 1]), cols=np.array([2, 0]))
    >>> images.shape
    (2, 4, 6, 3)
    >>> int(images[0, 0, 4, 0]), int(images[0, 2, 0, 0]), int(images[1, 2, 0, 0])
    (255, 0, 255)
"""

from __future__ import annotations

import numpy as np

from noisybolt.errors import ConfigError

__all__ = ["TileCompositor"]


class TileCompositor:
    """Renders batches of tiled images from a tile atlas and a background layout.

    Args:
        tiles: uint8 ``[n_tiles, tile_h, tile_w, channels]``: the atlas.
        layout: integer ``[rows, cols]``: the tile id of every cell of the static
            background.

    Raises:
        ConfigError: if the atlas is not a 4-d uint8 array or the layout names a tile
            outside it.
    """

    def __init__(self, tiles: np.ndarray, *, layout: np.ndarray) -> None:
        tiles = np.asarray(tiles)
        layout = np.asarray(layout)
        if tiles.ndim != 4 or tiles.dtype != np.uint8:
            raise ConfigError(
                f"tiles must be uint8 [n_tiles, tile_h, tile_w, channels], got {tiles.dtype} "
                f"{tiles.shape}"
            )
        if layout.ndim != 2 or not np.issubdtype(layout.dtype, np.integer):
            raise ConfigError(f"layout must be an integer [rows, cols] array, got {layout.shape}")
        if layout.size and (layout.min() < 0 or layout.max() >= len(tiles)):
            raise ConfigError(f"layout refers to tiles outside the atlas of {len(tiles)} tiles")
        self._tiles = np.ascontiguousarray(tiles)
        self._tiles.setflags(write=False)
        self._layout = layout.astype(np.intp)
        self._background = self._compose(self._layout[None])[0]
        self._background.setflags(write=False)

    @property
    def tiles(self) -> np.ndarray:
        """The atlas, uint8 ``[n_tiles, tile_h, tile_w, channels]`` (read-only)."""
        return self._tiles

    @property
    def grid_shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of cells."""
        return (int(self._layout.shape[0]), int(self._layout.shape[1]))

    @property
    def image_shape(self) -> tuple[int, int, int]:
        """``(height, width, channels)`` of one rendered image."""
        h, w, c = self._background.shape
        return (int(h), int(w), int(c))

    @property
    def background(self) -> np.ndarray:
        """The static background image, uint8 ``[height, width, channels]`` (read-only)."""
        return self._background

    def render_sprites(
        self,
        sprite_ids: np.ndarray,
        *,
        rows: np.ndarray,
        cols: np.ndarray,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """The background with, in each image, the given cells replaced by sprite tiles.

        Args:
            sprite_ids: integer ``[n_images]`` or ``[n_images, n_sprites]``: tile ids.
            rows: cell rows, same shape as ``sprite_ids``.
            cols: cell columns, same shape as ``sprite_ids``.
            out: optional uint8 ``[n_images, height, width, channels]`` buffer to fill.

        Returns:
            uint8 ``[n_images, height, width, channels]``. Where two sprites of one image
            share a cell, the later one is drawn.
        """
        ids = np.asarray(sprite_ids, dtype=np.intp)
        rows_ = np.asarray(rows, dtype=np.intp)
        cols_ = np.asarray(cols, dtype=np.intp)
        if ids.ndim == 1:
            ids, rows_, cols_ = ids[:, None], rows_[:, None], cols_[:, None]
        n = ids.shape[0]
        h, w, c = self.image_shape
        if out is None:
            out = np.empty((n, h, w, c), dtype=np.uint8)
        out[...] = self._background
        gh, gw = self.grid_shape
        th, tw = self._tiles.shape[1:3]
        cells = out.reshape(n, gh, th, gw, tw, c)
        image_idx = np.arange(n)
        for k in range(ids.shape[1]):  # a handful of sprites, never one per image
            # Advanced indices split by slices put the batch axis first: [n, th, tw, c].
            cells[image_idx, rows_[:, k], :, cols_[:, k], :, :] = self._tiles[ids[:, k]]
        return out

    def render_layouts(self, layouts: np.ndarray) -> np.ndarray:
        """Render arbitrary per-image layouts.

        Args:
            layouts: integer ``[n_images, rows, cols]``: the tile id of every cell.

        Returns:
            uint8 ``[n_images, height, width, channels]``.
        """
        layouts = np.asarray(layouts, dtype=np.intp)
        if layouts.ndim != 3 or layouts.shape[1:] != self._layout.shape:
            raise ConfigError(
                f"layouts must be [n_images, {self._layout.shape[0]}, {self._layout.shape[1]}],"
                f" got {layouts.shape}"
            )
        return self._compose(layouts)

    def _compose(self, layouts: np.ndarray) -> np.ndarray:
        n, gh, gw = layouts.shape
        th, tw, c = self._tiles.shape[1:]
        gathered = self._tiles[layouts]  # [n, gh, gw, th, tw, c]
        return np.ascontiguousarray(gathered.transpose(0, 1, 3, 2, 4, 5)).reshape(
            n, gh * th, gw * tw, c
        )
