from typing import Any, Dict, List, Optional, Tuple, Union

__version__: str

def stats_json(path: str, *, filament_diameter: Optional[float] = None) -> str: ...
def check_json(path: str, *, bed: Optional[Tuple[float, float, float]] = None, max_feed: Optional[float] = None) -> str: ...
def cat(path: str, output: Optional[str] = None, *, in_place: bool = False, backup: bool = True) -> None: ...
def run_cli(argv: List[str]) -> int: ...

def preview_bytes(
    path: str,
    *,
    format: str,
    layers: Optional[Tuple[int, int]] = None,
    view: str = "top",
    colour_by: str = "tool",
    size: Tuple[int, int] = (1200, 900),
    compare: Optional[str] = None,
    tool_colours: Optional[List[str]] = None,
    travel: bool = False,
) -> bytes: ...
def toolpath_columns(path: str, *, travel: bool = True, min_len: float = 0.0) -> Tuple[int, Dict[str, Any]]: ...

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
