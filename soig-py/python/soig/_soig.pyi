"""Type stubs of the native module (soig-py/src/lib.rs); use it through `soig`."""

from pathlib import Path
from typing import Any, Optional

__version__: str

class SoigError(Exception):
    """A soig run, input or output failed; the message names the file and what is wrong."""

class CampaignError(SoigError):
    """A campaign that does not parse or validate."""

    file: str
    line: Optional[int]
    field: Optional[str]
    message: str

class NativeCampaign:
    @staticmethod
    def from_parts(text: str, path: str, overrides: list[str] = ...) -> NativeCampaign: ...
    @staticmethod
    def from_file(path: str) -> NativeCampaign: ...
    @staticmethod
    def dict_to_toml(d: dict[str, Any]) -> str: ...
    @staticmethod
    def override_text(key: str, value: Any) -> str: ...
    def with_set(self, key: str, value: Any) -> NativeCampaign: ...
    @property
    def text(self) -> str: ...
    @property
    def path(self) -> Path: ...
    @property
    def overrides(self) -> list[str]: ...
    @property
    def name(self) -> str: ...
    @property
    def images(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def hash(self) -> str: ...
    @property
    def output_dir(self) -> Path: ...
    @property
    def resolved(self) -> dict[str, Any]: ...
    def image(self, index: int) -> dict[str, Any]: ...

def run(
    campaign: NativeCampaign,
    out: str,
    fresh: bool = ...,
    python: Optional[str] = ...,
    force: bool = ...,
) -> dict[str, Any]: ...
def build_id() -> str: ...
def verify(path: str) -> dict[str, Any]: ...
def eval(
    labels: str,
    predictions: str,
    mode: str = ...,
    images: Optional[str] = ...,
    image_size: int = ...,
    conf: float = ...,
    iou: float = ...,
) -> dict[str, Any]: ...
def detect_files(
    inputs: list[str],
    out: str,
    detector: Optional[str] = ...,
    model: Optional[str] = ...,
    campaign: Optional[NativeCampaign] = ...,
    psf_fwhm_px: Optional[float] = ...,
    star_trail_angle_deg: Optional[float] = ...,
    conf: Optional[float] = ...,
) -> dict[str, Any]: ...
def write_frame(array: Any, path: str) -> None: ...
