from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

__version__: str

def stats_json(path: str, *, filament_diameter: Optional[float] = None, lenient: bool = False) -> str: ...
def check_json(
    path: str,
    *,
    bed: Union[str, Sequence[float], None] = None,
    machine: Optional[str] = None,
    max_feed: Optional[float] = None,
    klipper_max_extrude_cross_section: Optional[float] = None,
    strict: bool = False,
) -> str: ...
def cat_json(
    path: str,
    output: Optional[str] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
) -> str: ...

# binder-jet raster (its options: `job_options("raster")`)
def raster_json(inputs: List[str], output: str, **options: Any) -> str: ...
def slice_raster_json(
    stl: str, out_dir: str, *, layer_height: float, dpi: float = 96.0, pixel_mm: Optional[float] = None, margin: int = 0
) -> str: ...

# The jobs (transforms, sim, estimate, preview): their options are keyword arguments by the
# names the engine declares (`job_options`); `gweave/__init__.py` types them, `tests/test_options.py` holds the two equal.
def jobs() -> List[str]: ...
def job_options(command: str) -> List[Dict[str, Any]]: ...

# The transforms of the engine's registry (purge-shift, mix, ...), run by their command: the
# typed wrappers of `gweave/__init__.py` call it with the job's options as keywords.
def transform_json(
    command: str,
    path: str,
    output: Optional[str] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
    **options: Any,
) -> str: ...
def transforms() -> List[str]: ...

# mix
def predict_colour_json(ratios: List[float], *, config: str = "") -> str: ...
# The options of preview are read by their declared names, as purge-shift's are.
def preview_json(
    path: str, output: Optional[str] = None, *, lenient: bool = False, **options: Any
) -> Tuple[bytes, str]: ...
def toolpath_columns(
    path: str, *, travel: bool = True, min_len: float = 0.0, mandrel_diameter: Optional[float] = None
) -> Tuple[int, Dict[str, Any]]: ...

class Line:
    number: int
    raw: bytes
    command: Optional[str]
    words: Dict[str, Union[float, str, None]]
    comment: Optional[str]
    text: Optional[str]
    diagnostics: List[Tuple[int, str]]
    position: Tuple[float, float, float, float]
    extruded: float
    is_move: bool
    tool: int
    layer: Optional[int]
    layer_z: float
    feature: str
    region: str

class Reader:
    def __init__(self, path: str) -> None: ...
    def __iter__(self) -> "Reader": ...
    def __next__(self) -> Line: ...

# gweave-sim: the virtual printer
# The options of sim and estimate are read by their declared names, as purge-shift's are.
def sim_json(path: str, **options: Any) -> str: ...
def estimate_json(path: str, **options: Any) -> str: ...

class Machine:
    def __init__(self, *, machine: Optional[str] = None) -> None: ...
    def boot_lines(self) -> List[str]: ...
    def execute(self, line: str) -> List[str]: ...
    @property
    def now_s(self) -> float: ...
    def finish(self) -> None: ...
    def report(self) -> Dict[str, Any]: ...
# rotary (lathe-type) printing
Profile = Union[float, Sequence[Tuple[float, float]], Callable[[float], float]]

def rotary_wrap_json(
    input: str,
    output: Optional[str] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
    preview: Optional[str] = None,
    **options: Any,
) -> str: ...
def rotary_tube_json(output: str, *, preview: Optional[str] = None, **options: Any) -> str: ...
def write_helical_paths_json(paths: List["HelicalPath"], output: str, *, settings: str, config: Optional[str] = None, **machine: Any) -> str: ...

class HelicalPath:
    def __init__(
        self,
        start: float,
        end: float,
        *,
        radius: Profile,
        pitch: Profile,
        handedness: str = "right",
        start_theta: float = 0.0,
        lead_in: float = 0.0,
        lead_out: float = 0.0,
    ) -> None: ...
    def points(self, *, chord_tol: float = 0.01, segments_per_turn: Optional[int] = None) -> List[Tuple[float, float, float]]: ...
