"""soig.torch.Dataset in a DataLoader with 2 worker processes. Needs torch: skipped without
it (scripts/python-test.sh runs it in .venv-train, which scripts/setup-train.sh gives torch)."""

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="torch is not installed here (see the module doc)")

import soig.torch  # noqa: E402
from conftest import small_campaign  # noqa: E402


def test_dataloader_two_workers_renders_what_image_renders():
    c = small_campaign().set("images", 6)
    ds = soig.torch.Dataset(c)
    assert len(ds) == 6
    loader = torch.utils.data.DataLoader(
        ds, batch_size=2, num_workers=2, shuffle=False, collate_fn=soig.torch.collate
    )
    seen = 0
    for b, (x, boxes) in enumerate(loader):
        assert x.shape == (2, 1, 1024, 1024) and x.dtype == torch.float32
        for k in range(2):
            im = c.image(2 * b + k)
            assert np.array_equal(x[k, 0].numpy(), im.png.astype(np.float32))
            want = np.array(im.label_boxes, dtype=np.float32).reshape(-1, 4)
            np.testing.assert_array_equal(boxes[k].numpy(), want)
            seen += 1
    assert seen == 6
    with pytest.raises(IndexError):
        ds[6]


def test_default_transform_returns_every_box_of_a_multi_object_frame():
    # Issue #43: on the main of 2026-11-28 the default transform kept one box per frame and
    # silently dropped the others (38 of 71 objects in one test).
    c = small_campaign().set("images", 8).set("objects.per_frame", {"min": 2, "max": 3})
    ds = soig.torch.Dataset(c)
    total = 0
    for i in range(len(ds)):
        _, boxes = ds[i]
        im = c.image(i)
        assert boxes.shape == (len(im.label_boxes), 4)
        np.testing.assert_array_equal(boxes.numpy(), np.array(im.label_boxes, np.float32).reshape(-1, 4))
        total += len(im.label_boxes)
    assert total > len(ds), f"{total} boxes in {len(ds)} frames of 2-3 objects"
