"""soig from Python: campaigns, seed-exact images by index, runs, verification, metrics and
detection, on soig's Rust core (the same code as the `soig` command, so the same bytes).

    >>> import soig
    >>> c = soig.Campaign("campaigns/quickstart.toml").set("images", 4)
    >>> img = c.image(2)            # rendered now, in memory: what `soig run` writes for image 2
    >>> img.noisy.shape, img.noisy.dtype
    ((1024, 1024), dtype('float32'))

`soig.torch.Dataset` (only with torch installed) renders image i on demand in a DataLoader.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _soig
from ._soig import CampaignError, SoigError

__version__ = _soig.__version__
__all__ = [
    "Campaign",
    "CampaignError",
    "Image",
    "SoigError",
    "build_id",
    "detect",
    "eval",
    "run",
    "verify",
]

PathLike = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class Image:
    """Image `index` of a campaign, as `soig run` writes it.

    noisy: float32 (height, width), ADU: the pixels of `fits/img_NNNNNN.fits`.
    clean: int32 (height, width), noise-free photo-electrons: `fits/img_NNNNNN_clean.fits`.
    png: uint8 (rows, cols), the enhanced image in its final frame (None without an
        `enhance` stage): the pixels of `images/.../img_NNNNNN.png`.
    label: the YOLO label file's text of the PNG, one line per labelled object ("" for an
        empty frame or when no debris photon landed; None without an `enhance` stage), as in
        `labels/.../img_NNNNNN.txt`.
    label_box: the first label box (x1, y1, x2, y2) in the PNG's pixel-edge coordinates (the
        one object of a campaign without `[objects]`), or None.
    label_boxes: every label box, in the label file's order (None without an `enhance` stage).
    truth: the truth record, as in `truth/img_NNNNNN.json`.
    header: the FITS header keywords (WCS and provenance) of both FITS, but BUNIT.
    """

    index: int
    noisy: np.ndarray
    clean: np.ndarray
    png: Optional[np.ndarray]
    label: Optional[str]
    label_box: Optional[Tuple[float, float, float, float]]
    label_boxes: Optional[List[Tuple[float, float, float, float]]]
    truth: dict
    header: dict

    def fits_header(self) -> Any:
        """The header as an `astropy.io.fits.Header` (needs astropy)."""
        from astropy.io import fits  # an optional dependency

        return fits.Header(list(self.header.items()))


class Campaign:
    """A validated soig campaign.

    Campaign(path) reads a campaign file, as `soig run path`; Campaign(dict) builds one from
    nested dicts (tables) as `Campaign.from_dict`. Errors are `soig.CampaignError` naming file,
    line and field, as the command's. Relative paths in the campaign (TLE files, frames,
    model) are read from the campaign file's directory (the current one for text and dicts,
    unless `path` names another).
    """

    __slots__ = ("_built", "_pending")

    def __init__(self, source: Union[PathLike, dict], *, path: Optional[PathLike] = None):
        self._pending: List[str] = []
        if isinstance(source, dict):
            self._built = _soig.NativeCampaign.from_parts(
                _soig.NativeCampaign.dict_to_toml(source), str(path or "<dict>")
            )
        elif isinstance(source, (str, os.PathLike)):
            if path is not None:
                raise TypeError("path= names text or a dict; a file names itself")
            self._built = _soig.NativeCampaign.from_file(os.fspath(source))
        else:
            raise TypeError(f"a campaign is a file path or a dict, not {type(source).__name__}")

    @classmethod
    def from_toml(cls, text: str, path: PathLike = "<string>") -> "Campaign":
        """A campaign from TOML text; `path` names it in errors and its directory is where
        relative paths are read from."""
        c = cls.__new__(cls)
        c._pending = []
        c._built = _soig.NativeCampaign.from_parts(text, os.fspath(path))
        return c

    @property
    def _native(self) -> Any:
        """The campaign with every `set` since the last use applied and judged together, as
        `soig run --set ... --set ...` judges them (so chained sets whose first alone would
        be refused work). A refused set raises CampaignError here, at the use, and the
        campaign stays as it was before those sets."""
        if self._pending:
            pending, self._pending = self._pending, []
            b = self._built
            self._built = _soig.NativeCampaign.from_parts(
                b.text, os.fspath(b.path), b.overrides + pending
            )
        return self._built

    @classmethod
    def from_dict(cls, d: dict, path: PathLike = "<dict>") -> "Campaign":
        """A campaign from nested dicts, lists and scalars (keys as in the TOML file)."""
        return cls(d, path=path)

    def set(self, key: str, value: Any) -> "Campaign":
        """Override a setting as `soig run --set key=value` does (after `extends`), e.g.
        `.set("sensor.width_px", 512)`; returns the campaign, changed in place. The sets are
        judged together at the campaign's next use (as the command judges its `--set`s), so
        `.set("exposure.min_s", 10).set("exposure.max_s", 20)` works; a refused value raises
        CampaignError then, and the campaign stays as it was before those sets."""
        self._pending.append(_soig.NativeCampaign.override_text(key, value))
        return self

    @property
    def name(self) -> str:
        return self._native.name

    @property
    def images(self) -> int:
        """How many images the campaign has."""
        return self._native.images

    @property
    def seed(self) -> int:
        return self._native.seed

    @property
    def hash(self) -> str:
        """sha256 of the resolved campaign: the hash every output of it records."""
        return self._native.hash

    @property
    def output_dir(self) -> Path:
        """Where `soig run` would write it (`output`, else `runs/<name>` beside the file)."""
        return Path(self._native.output_dir)

    @property
    def overrides(self) -> list:
        """The `key=value` overrides applied, in order."""
        return self._native.overrides

    def resolved(self) -> dict:
        """The campaign with every default filled in and TLE files read, as a dict."""
        return self._native.resolved

    def __len__(self) -> int:
        return self.images

    def image(self, index: int) -> Image:
        """Render image `index` (0 <= index < images) in memory: deterministic for
        (campaign, index), the same pixels, label and truth `soig run` writes for it. The GIL
        is released while it renders, so threads render in parallel."""
        return Image(**self._native.image(index))

    def __getstate__(self):
        return (self._native.text, os.fspath(self._native.path), self._native.overrides)

    def __setstate__(self, state):
        text, path, overrides = state
        self._pending = []
        self._built = _soig.NativeCampaign.from_parts(text, path, overrides)

    def __repr__(self) -> str:
        return f"<soig.Campaign {self.name!r}: {self.images} images, hash {self.hash[:12]}>"


def run(
    campaign: Campaign,
    out: Optional[PathLike] = None,
    *,
    fresh: bool = False,
    python: Optional[PathLike] = None,
    force: bool = False,
) -> dict:
    """Run the campaign into `out` (default: its output_dir) as `soig run`: the same files and
    digest. Resumes a killed run of that output unless `fresh`. `python`: the interpreter with
    Ultralytics for a `train` stage. `force`: run even what the work estimate refuses (as
    `soig run --force`). Returns {output, digest, images, resumed, seconds, mix}."""
    out = campaign.output_dir if out is None else Path(out)
    return _soig.run(
        campaign._native,
        os.fspath(out),
        fresh,
        None if python is None else os.fspath(python),
        force,
    )


def build_id() -> str:
    """The build identity a run records to keep two builds out of one output: sha256 of
    soig's native module (not of the interpreter)."""
    return _soig.build_id()


def verify(path: PathLike) -> dict:
    """Check an output against its manifest, as `soig verify`: {ok, digest, files, problems}.
    An output without a readable manifest raises SoigError."""
    return _soig.verify(os.fspath(path))


def eval(
    labels: PathLike,
    predictions: PathLike,
    *,
    mode: str = "ultralytics",
    images: Optional[PathLike] = None,
    image_size: int = 1024,
    conf: float = 0.5,
    iou: float = 0.5,
) -> dict:
    """Precision, recall and mAP of YOLO prediction files against YOLO label files, as
    `soig eval --json` (same keys and defaults); mode "ultralytics" or "coco"."""
    return _soig.eval(
        os.fspath(labels),
        os.fspath(predictions),
        mode,
        None if images is None else os.fspath(images),
        image_size,
        conf,
        iou,
    )


Frame = Union[PathLike, np.ndarray]


def detect(
    frames: Union[Frame, Sequence[Frame]],
    out: Optional[PathLike] = None,
    *,
    detector: Optional[str] = None,
    model: Optional[PathLike] = None,
    campaign: Optional[Campaign] = None,
    psf_fwhm_px: Optional[float] = None,
    star_trail_angle_deg: Optional[float] = None,
    conf: Optional[float] = None,
) -> list:
    """Run soig's detectors (as `soig detect`) on frames: FITS or PNG files, or 2-D numpy
    arrays (uint8: grey levels, as a PNG; any other number type: values, as a FITS). Returns
    one dict per frame with its `detections` (pixel-edge boxes, confidence, streak ends, sky
    positions when the frame has a WCS). `detector`: "streak" (the default without a model),
    "yolo" or "all" (with `model`, an ONNX file). With `out`, the output `soig detect` writes
    goes there; without, it is discarded."""
    if isinstance(frames, np.ndarray) or not isinstance(frames, (list, tuple)):
        frames = [frames]
    with tempfile.TemporaryDirectory(prefix="soig-detect-") as tmp:
        paths, names = [], {}
        for k, f in enumerate(frames):
            if isinstance(f, np.ndarray):
                if f.ndim != 2:
                    raise ValueError(f"frame {k}: a 2-D array, not {f.ndim}-D")
                grey = f.dtype == np.uint8
                p = os.path.join(tmp, f"array_{k:04d}.{'png' if grey else 'fits'}")
                a = np.ascontiguousarray(f if grey else f.astype(np.float32))
                _soig.write_frame(a, p)
                names[p] = f"<array {k}>"
            else:
                p = os.fspath(f)
            paths.append(p)
        target = os.path.join(tmp, "out") if out is None else os.fspath(out)
        r = _soig.detect_files(
            paths,
            target,
            detector,
            None if model is None else os.fspath(model),
            None if campaign is None else campaign._native,
            psf_fwhm_px,
            star_trail_angle_deg,
            conf,
        )
    for fr in r["frames"]:
        fr["file"] = names.get(fr["file"], fr["file"])
    return r["frames"]
