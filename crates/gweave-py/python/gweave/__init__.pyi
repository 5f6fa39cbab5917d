# The types of gweave's public API (tests/test_stubs.py holds every public name to a stub with the
# same parameters). Reports are the dicts of the command line's `--json` documents.
import os
from typing import Any, Dict, Optional, Sequence, Tuple, Union

from ._gweave import HelicalPath as HelicalPath
from ._gweave import Line as Line
from ._gweave import Machine as Machine
from ._gweave import Reader as Reader

__version__: str
__all__: list[str]

PathLike = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
Report = Dict[str, Any]

def read(path: PathLike) -> Reader: ...
def stats(path: PathLike, *, filament_diameter: Optional[float] = None, lenient: bool = False) -> Report: ...
def check(
    path: PathLike,
    *,
    bed: Union[str, Sequence[float], None] = None,
    max_feed: Optional[float] = None,
    strict: bool = False,
) -> Report: ...
def cat(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
) -> Report: ...
def sim(path: PathLike, *, machine: Optional[PathLike] = None, fault: Sequence[str] = ()) -> Report: ...
def estimate(path: PathLike, *, machine: Optional[PathLike] = None, steps: bool = False) -> Report: ...
def raster(
    inputs: Union[PathLike, Sequence[PathLike]],
    output: PathLike,
    *,
    head: Optional[PathLike] = None,
    threshold: float = 0.5,
    invert: bool = False,
    flip_y: bool = False,
    one_way: bool = False,
    fire_order: str = "after",
    density: int = 1,
    origin: Sequence[float] = (20.0, 20.0),
    layer_height: Optional[float] = None,
    pixel_mm: Optional[float] = None,
    dpi: Optional[float] = None,
    heads: Optional[int] = None,
    channels: Optional[str] = None,
    recoat: Optional[PathLike] = None,
    start: Optional[PathLike] = None,
    end: Optional[PathLike] = None,
    dialect: Optional[str] = None,
    feed: Optional[float] = None,
    fast_estimate: bool = False,
) -> Report: ...
def raster_test_pattern(
    output: PathLike,
    *,
    head: Optional[PathLike] = None,
    heads: Optional[int] = None,
    dialect: Optional[str] = None,
    pattern_columns: int = 4,
    origin: Sequence[float] = (20.0, 20.0),
) -> Report: ...
def slice_raster(
    stl: PathLike,
    out_dir: PathLike,
    *,
    layer_height: float,
    dpi: float = 96.0,
    pixel_mm: Optional[float] = None,
    margin: int = 0,
) -> Report: ...
def purge_shift(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    purge_mm: Optional[float] = None,
    purge_mm3: Optional[float] = None,
    config: Optional[PathLike] = None,
    filament_diameter: Optional[float] = None,
    cross_layers: bool = False,
    allow_features: Optional[Sequence[str]] = None,
    markers: Optional[Sequence[str]] = None,
    fallback: Optional[str] = None,
    tower_at: Optional[Sequence[float]] = None,
    lenient: bool = False,
) -> Report: ...
def preview(
    path: PathLike,
    *,
    output: Optional[PathLike] = None,
    layer: Optional[int] = None,
    layers: Union[str, Tuple[int, int], None] = None,
    view: Optional[str] = None,
    colour_by: str = "tool",
    size: Tuple[int, int] = (1200, 900),
    compare: Optional[PathLike] = None,
    tool_colours: Optional[Sequence[str]] = None,
    travel: bool = False,
    mix_profile: Optional[PathLike] = None,
    mandrel_diameter: Optional[float] = None,
    head: Optional[PathLike] = None,
    min_len: Optional[float] = None,
    lenient: bool = False,
    report: bool = False,
) -> Union[bytes, Tuple[bytes, Report]]: ...
def toolpath(
    path: PathLike, *, travel: bool = True, min_len: float = 0.0, mandrel_diameter: Optional[float] = None
) -> Dict[str, Any]: ...
def mix(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    config: Optional[PathLike] = None,
    at_layer: Sequence[str] = (),
    at_z: Sequence[str] = (),
    map: Sequence[str] = (),
    gradient: Sequence[str] = (),
    gradient_space: str = "mix",
    dialect: Optional[str] = None,
    purge_mm: Optional[float] = None,
    initial_purge: Optional[float] = None,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
) -> Report: ...
def predict_colour(ratios: Sequence[float], profile: Optional[PathLike] = None) -> Dict[str, Any]: ...
def main(argv: Optional[Sequence[str]] = None) -> int: ...
def rotary_wrap(
    input: PathLike,
    output: PathLike,
    *,
    mandrel_diameter: Optional[float] = None,
    feed_convention: Optional[str] = None,
    rotary_unit: Optional[str] = None,
    axes: Optional[Sequence[str]] = None,
    keep_arc_length: Optional[bool] = None,
    seam_rotation: Optional[float] = None,
    helical: bool = False,
    allow_overlap: bool = False,
    chord_tol: Optional[float] = None,
    config: Optional[PathLike] = None,
    preview: Optional[PathLike] = None,
    lenient: bool = False,
) -> Report: ...
def rotary_tube(
    output: PathLike,
    *,
    mandrel_diameter: Optional[float] = None,
    length: Optional[float] = None,
    layer_count: Optional[int] = None,
    layer_height: Optional[float] = None,
    bead_width: Optional[float] = None,
    pitch: Optional[float] = None,
    interweave: Optional[bool] = None,
    segments_per_turn: Optional[int] = None,
    chord_tol: Optional[float] = None,
    speed: Optional[float] = None,
    temp: Optional[float] = None,
    filament_diameter: Optional[float] = None,
    feed_convention: Optional[str] = None,
    rotary_unit: Optional[str] = None,
    axes: Optional[Sequence[str]] = None,
    config: Optional[PathLike] = None,
    preview: Optional[PathLike] = None,
) -> Report: ...
def write_helical_paths(
    paths: Sequence[HelicalPath],
    output: PathLike,
    *,
    mandrel_diameter: Optional[float] = None,
    feed_convention: Optional[str] = None,
    rotary_unit: Optional[str] = None,
    axes: Optional[Sequence[str]] = None,
    layer_height: Optional[float] = None,
    bead_width: Optional[float] = None,
    speed: Optional[float] = None,
    temp: Optional[float] = None,
    filament_diameter: Optional[float] = None,
    chord_tol: Optional[float] = None,
    segments_per_turn: Optional[int] = None,
    config: Optional[PathLike] = None,
) -> Report: ...
