"""gweave: a G-code workbench for mixing hotends, rotary printers and binder jetting.

The engine is Rust; this package is a thin, typed layer over it. Reports are plain dicts with
the same fields as the command line's ``--json`` output.

Example::

    import gweave
    s = gweave.stats("part.gcode")
    print(s["layers"], [t["extruded_mm"] for t in s["filament"]])
    for line in gweave.read("part.gcode"):
        if line.is_move and line.extruded > 0:
            print(line.layer, line.position)
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Sequence, Tuple, Union

from . import _gweave
from ._gweave import Line, Reader

__version__: str = _gweave.__version__

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["Line", "Reader", "read", "stats", "check", "cat", "main", "__version__"]
__all__ += ["preview", "toolpath"]


def read(path: PathLike) -> Reader:
    """Iterate a G-code file's lines, each with its parsed words and the machine state after it.

    Memory stays bounded whatever the file size.
    """
    return Reader(os.fspath(path))


def stats(path: PathLike, *, filament_diameter: Optional[float] = None) -> Dict[str, Any]:
    """Statistics of a G-code file: slicer, layers, extents, filament per tool, distances, time.

    ``filament_diameter`` (mm) overrides the file's own setting.
    """
    return json.loads(_gweave.stats_json(os.fspath(path), filament_diameter=filament_diameter))


def check(
    path: PathLike,
    *,
    bed: Optional[Sequence[float]] = None,
    max_feed: Optional[float] = None,
) -> Dict[str, Any]:
    """Lint a G-code file. ``bed`` is the printable volume ``(x, y, z)`` in mm; ``max_feed`` in mm/min.

    The report has ``errors``, ``warnings`` and ``findings`` (line, column, kind, severity).
    """
    bed_tuple = None if bed is None else (float(bed[0]), float(bed[1]), float(bed[2]))
    return json.loads(_gweave.check_json(os.fspath(path), bed=bed_tuple, max_feed=max_feed))


def cat(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
) -> None:
    """Parse a file and write it back unchanged, atomically (the identity every transform builds on)."""
    _gweave.cat(
        os.fspath(path),
        None if output is None else os.fspath(output),
        in_place=in_place,
        backup=backup,
    )


# ---- preview (render) ----

_PREVIEW_FORMATS = {".png": "png", ".svg": "svg", ".html": "html", ".htm": "html"}


def preview(
    path: PathLike,
    *,
    output: Optional[PathLike] = None,
    layer: Union[int, Tuple[int, int], None] = None,
    view: str = "top",
    colour_by: str = "tool",
    size: Tuple[int, int] = (1200, 900),
    compare: Optional[PathLike] = None,
    tool_colours: Optional[Sequence[str]] = None,
    travel: bool = False,
) -> bytes:
    """Draw a file as ``gweave preview`` does; returns the file's bytes (PNG when ``output`` is None).

    ``output`` picks the format by extension (``.png``, ``.svg``, ``.html``) and is written.
    ``layer`` is one 0-based layer or an inclusive ``(first, last)`` range; ``view`` is ``"top"`` or
    ``"iso"``; ``colour_by`` is ``tool``, ``feature``, ``speed``, ``layer`` or ``mix`` (per-tool
    ``tool_colours`` such as ``["#00ffff", "#ff00ff"]``); ``compare`` highlights moves that differ
    from another file; ``size`` is ``(width, height)`` in pixels.
    """
    fmt = "png"
    if output is not None:
        ext = os.path.splitext(os.fspath(output))[1].lower()
        if ext not in _PREVIEW_FORMATS:
            raise ValueError(f"unknown output format {ext!r} (.png, .svg or .html)")
        fmt = _PREVIEW_FORMATS[ext]
    layers = (layer, layer) if isinstance(layer, int) else None if layer is None else (int(layer[0]), int(layer[1]))
    data = _gweave.preview_bytes(
        os.fspath(path),
        format=fmt,
        layers=layers,
        view=view,
        colour_by=colour_by,
        size=(int(size[0]), int(size[1])),
        compare=None if compare is None else os.fspath(compare),
        tool_colours=None if tool_colours is None else list(tool_colours),
        travel=travel,
    )
    if output is not None:
        with open(output, "wb") as f:
            f.write(data)
    return data


def toolpath(path: PathLike, *, travel: bool = True, min_len: float = 0.0) -> Dict[str, Any]:
    """A file's segments as NumPy arrays (NumPy is needed for this function only).

    Keys: ``start`` and ``end`` (float32, shape (n, 3), mm), ``tool`` (uint16), ``feature`` (uint8,
    an index into ``feature_names``), ``feed_mm_s`` (float32), ``layer`` (uint32), ``extruding``
    (bool); plus ``feature_names`` and ``layer_z`` (lists). ``min_len`` (mm) merges chained moves
    shorter than that, for huge files; ``travel=False`` keeps extruding moves only.
    """
    import numpy as np

    n, cols = _gweave.toolpath_columns(os.fspath(path), travel=travel, min_len=min_len)
    dtypes = {"tool": "<u2", "feature": "u1", "feed_mm_s": "<f4", "layer": "<u4", "extruding": "u1"}
    out: Dict[str, Any] = {
        "start": np.frombuffer(cols["start"], dtype="<f4").reshape(n, 3),
        "end": np.frombuffer(cols["end"], dtype="<f4").reshape(n, 3),
    }
    for name, dtype in dtypes.items():
        out[name] = np.frombuffer(cols[name], dtype=dtype)
    out["extruding"] = out["extruding"].astype(bool)
    out["feature_names"] = cols["feature_names"]
    out["layer_z"] = cols["layer_z"]
    return out


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the ``gweave`` command line (the same binary as the Rust CLI)."""
    import sys

    args = list(sys.argv if argv is None else ["gweave", *argv])
    return _gweave.run_cli(args)
