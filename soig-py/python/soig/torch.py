"""A PyTorch map-style dataset over a soig campaign: item i is image i, rendered on demand
(nothing on disk), deterministic for (campaign, i) whatever the worker, order or process.

Importing this module needs torch (`import soig.torch` raises ImportError without it).

    >>> from torch.utils.data import DataLoader
    >>> ds = soig.torch.Dataset(soig.Campaign("campaigns/quickstart.toml"))
    >>> for x, boxes in DataLoader(ds, batch_size=4, num_workers=2, collate_fn=soig.torch.collate): ...
"""

from __future__ import annotations

from typing import Any, Callable, Optional

import torch
import torch.utils.data

from . import Campaign, Image

__all__ = ["Dataset", "collate", "default_transform"]


def default_transform(image: Image) -> Any:
    """(pixels, boxes): the enhanced 8-bit image (or the noisy ADU image when the campaign
    has no `enhance` stage) as a float32 tensor of shape (1, rows, cols), and every label box
    (x1, y1, x2, y2) in its pixel-edge coordinates as a float32 tensor of shape (n, 4): one
    row per labelled object of the frame, in the label file's order (none for an empty frame
    or when no debris photon landed; without an `enhance` stage, the first object's box when
    it has one). Frames hold different numbers of boxes: batch them with `collate`."""
    pixels = image.noisy if image.png is None else image.png
    if image.label_boxes is not None:
        boxes = list(image.label_boxes)
    else:
        boxes = [image.label_box] if image.label_box is not None else []
    return (
        torch.from_numpy(pixels.astype("float32", copy=False)).unsqueeze(0),
        torch.tensor(boxes, dtype=torch.float32).reshape(len(boxes), 4),
    )


def collate(batch: list) -> Any:
    """A DataLoader's `collate_fn` for `default_transform`'s items: the images stacked into
    one tensor (batch, 1, rows, cols), the boxes a list of (n_i, 4) tensors (as torchvision's
    detection datasets give them)."""
    pixels, boxes = zip(*batch)
    return torch.stack(pixels), list(boxes)


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
