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
    loader = torch.utils.data.DataLoader(ds, batch_size=2, num_workers=2, shuffle=False)
    seen = 0
    for b, (x, box) in enumerate(loader):
        assert x.shape == (2, 1, 1024, 1024) and x.dtype == torch.float32
        for k in range(2):
            im = c.image(2 * b + k)
            assert np.array_equal(x[k, 0].numpy(), im.png.astype(np.float32))
            want = im.label_box if im.label_box is not None else (np.nan,) * 4
            np.testing.assert_array_equal(box[k].numpy(), np.array(want, dtype=np.float32))
            seen += 1
    assert seen == 6
    with pytest.raises(IndexError):
        ds[6]
