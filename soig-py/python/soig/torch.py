"""A PyTorch map-style dataset over a soig campaign: item i is image i, rendered on demand
(nothing on disk), deterministic for (campaign, i) whatever the worker, order or process.

Importing this module needs torch (`import soig.torch` raises ImportError without it).

    >>> from torch.utils.data import DataLoader
    >>> ds = soig.torch.Dataset(soig.Campaign("campaigns/quickstart.toml"))
    >>> for x, box in DataLoader(ds, batch_size=4, num_workers=2): ...
"""

from __future__ import annotations

import math
from typing import Any, Callable, Optional

import torch
import torch.utils.data

from . import Campaign, Image

__all__ = ["Dataset", "default_transform"]


def default_transform(image: Image) -> Any:
    """(pixels, box): the enhanced 8-bit image (or the noisy ADU image when the campaign
    has no `enhance` stage) as a float32 tensor of shape (1, rows, cols), and the label box
    (x1, y1, x2, y2) in its pixel-edge coordinates as a float32 tensor (NaN when no debris
    photon landed)."""
    pixels = image.noisy if image.png is None else image.png
    box = image.label_box if image.label_box is not None else (math.nan,) * 4
    return (
        torch.from_numpy(pixels.astype("float32", copy=False)).unsqueeze(0),
        torch.tensor(box, dtype=torch.float32),
    )


class Dataset(torch.utils.data.Dataset):
    """Image i of `campaign` for index i, passed through `transform` (a function of a
    `soig.Image`; default: `default_transform`). The campaign pickles as its text and
    overrides, so workers of any start method rebuild the same campaign; rendering releases
    the GIL."""

    def __init__(self, campaign: Campaign, transform: Optional[Callable[[Image], Any]] = None):
        self.campaign = campaign
        self.transform = default_transform if transform is None else transform

    def __len__(self) -> int:
        return self.campaign.images

    def __getitem__(self, index: int) -> Any:
        if not 0 <= index < len(self):
            raise IndexError(index)
        return self.transform(self.campaign.image(int(index)))
