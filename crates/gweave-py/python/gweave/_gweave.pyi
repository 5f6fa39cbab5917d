from typing import Dict, List, Optional, Tuple, Union

__version__: str

def stats_json(path: str, *, filament_diameter: Optional[float] = None) -> str: ...
def check_json(path: str, *, bed: Optional[Tuple[float, float, float]] = None, max_feed: Optional[float] = None) -> str: ...
def cat(path: str, output: Optional[str] = None, *, in_place: bool = False, backup: bool = True) -> None: ...
def run_cli(argv: List[str]) -> int: ...

# mix
def mix_json(
    path: str,
    output: Optional[str] = None,
    *,
    config: str = "",
    at_layer: List[str] = ...,
    at_z: List[str] = ...,
    map: List[str] = ...,
    gradient: List[str] = ...,
    perceived: bool = False,
    in_place: bool = False,
    backup: bool = True,
) -> str: ...

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
