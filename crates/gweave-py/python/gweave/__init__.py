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

import functools
import json
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

from . import _gweave
from ._gweave import HelicalPath, Line, Machine, Reader

__version__: str = _gweave.__version__

PathLike = Union[str, bytes, "os.PathLike[str]", "os.PathLike[bytes]"]
# A report: the dict of the command line's `--json` document for the same command.
Report = Dict[str, Any]

__all__ = ["Line", "Reader", "read", "stats", "check", "cat", "main", "__version__"]
__all__ += ["Machine", "sim", "estimate"]
# binder-jet raster
__all__ += ["raster", "raster_test_pattern", "slice_raster"]
# purge-shift
__all__ += ["purge_shift"]
# mix
__all__ += ["mix", "predict_colour"]

__all__ += ["rotary_wrap", "rotary_tube", "HelicalPath", "write_helical_paths"]

__all__ += ["preview", "toolpath"]


def _path(value: Any, name: str) -> str:
    """A path argument as the engine takes it: ``str``, ``bytes`` or any ``os.PathLike``; anything
    else is a ``TypeError`` naming the parameter (the engine reports a missing file as
    ``FileNotFoundError`` with its ``errno`` and ``filename``)."""
    try:
        return os.fsdecode(os.fspath(value))
    except TypeError:
        raise TypeError(f"{name}: expected a path (str, bytes or os.PathLike), not {type(value).__name__}") from None


def _opt_path(value: Any, name: str) -> Optional[str]:
    return None if value is None else _path(value, name)


def read(path: PathLike) -> Reader:
    """Iterate a G-code file's lines, each with its parsed words and the machine state after it.

    Memory stays bounded whatever the file size.
    """
    return Reader(_path(path, "path"))


def stats(path: PathLike, *, filament_diameter: Optional[float] = None, lenient: bool = False) -> Report:
    """Statistics of a G-code file: slicer, layers, extents, filament per tool, distances, time.

    ``filament_diameter`` (mm) overrides the file's own setting. ``lenient=True`` reads past
    malformed lines and counts them (``malformed_lines``, ``first_malformed_line``) instead of
    raising ``ValueError`` at the first.
    """
    return json.loads(
        _gweave.stats_json(_path(path, "path"), filament_diameter=filament_diameter, lenient=lenient)
    )


def check(
    path: PathLike,
    *,
    bed: Union[str, Sequence[float], None] = None,
    machine: Optional[PathLike] = None,
    max_feed: Optional[float] = None,
    klipper_max_extrude_cross_section: Optional[float] = None,
    strict: bool = False,
) -> Report:
    """Lint a G-code file, as ``gweave check`` does; ``max_feed`` in mm/min,
    ``klipper_max_extrude_cross_section`` in mm² (``--klipper-max-extrude-cross-section``).

    ``bed`` is the printable volume in mm as ``--bed`` reads it: ``"X,Y,Z"`` from the origin or
    ``"X0,Y0,X1,Y1[,Z]"`` from a corner, as text or as a sequence of those 3, 4 or 5 numbers.
    Without it, the bed the slicer's settings in the file give (PrusaSlicer's ``bed_shape``,
    Cura's ``machine_width``...), if any; ``machine`` (a profile file or a built-in name such as
    ``"prusa-mk3"``) checks against that machine's bed instead. The report has ``errors``, ``warnings``, ``findings``
    (line, column, kind, severity), the ``bed`` used and ``bed_from``, and ``failed``: whether
    the file fails (an error, or with ``strict=True`` a warning too; the CLI's exit code 1).
    """
    return json.loads(
        _gweave.check_json(
            _path(path, "path"),
            bed=bed,
            machine=_opt_path(machine, "machine"),
            max_feed=max_feed,
            klipper_max_extrude_cross_section=klipper_max_extrude_cross_section,
            strict=strict,
        )
    )


def cat(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
) -> Report:
    """Parse a file and write it back unchanged, atomically (the identity every transform builds on).

    Returns what was copied: ``lines``, ``bytes``, ``malformed_lines`` and ``first_malformed_line``
    (a malformed line raises ``ValueError`` naming file, line and column unless ``lenient=True``,
    which copies it as written). ``force=True`` replaces a read-only file in place.
    """
    return json.loads(
        _gweave.cat_json(
            _path(path, "path"),
            _opt_path(output, "output"),
            in_place=in_place,
            backup=backup,
            force=force,
            lenient=lenient,
        )
    )


def sim(
    path: PathLike,
    *,
    machine: Optional[PathLike] = None,
    fault: Sequence[str] = (),
    plot: Optional[PathLike] = None,
    plot_speed: Optional[PathLike] = None,
    raster_out: Optional[PathLike] = None,
) -> Report:
    """Run a file through the virtual printer (``gweave sim``); ``machine`` is a profile TOML or
    a built-in profile's name (``"prusa-mk3"``, ``"klipper"``: ``gweave machine list``).

    ``fault`` injects heater faults as ``--fault`` does (``["hotend-cartridge-off@120s"]``).
    ``plot`` charts each heater's temperature and target over time, ``plot_speed`` the planned
    toolhead speed, each layer's time and each mixing input's filament (a ``.png`` or ``.svg``
    file, by its extension); ``raster_out`` is a folder for the inkjet canvases (one PNG per
    layer and head). The report has ``time`` (``total_s``, ``motion_s``, ``heating_s``...), ``layer_s``,
    ``feature_s``, ``filament_mm`` (each motor's net feed; ``retracted_at_end_mm`` added to it
    is what left the nozzle, ``stats``'s figure), ``mixing_input_mm``, ``steps``, ``position``, ``count``,
    ``heaters``, ``thermal_faults``, ``halted``, ``unknown_commands`` and ``warnings``.
    The run stops at a halt and at the end of program a profile declares (``[firmware] m0 =
    "seed"``). A profile with ``[firmware] kind = "gweave"`` runs the file on gweave's controller
    core instead, and the report is the core's, as ``gweave sim --json`` prints it: ``lines``,
    ``time_s``, ``end_steps``, ``axis_steps``, ``mixing_steps``, ``extruder_steps`` (two hotends),
    ``rotary_steps``, ``halted`` and ``errors`` (``fault``, the charts
    and the canvases are the Marlin model's, and refused there).
    """
    if isinstance(fault, str):
        fault = [fault]
    return _job(_gweave.sim_json, locals())


def estimate(path: PathLike, *, machine: Optional[PathLike] = None, steps: bool = False) -> Report:
    """Estimate the print time with the virtual printer's planner alone (``gweave estimate``).

    ``machine`` is a profile TOML, a built-in profile's name, or ``"slicer"``: the machine
    limits the slicer wrote into the file (the report's ``machine`` says which slicer's).
    Faster than :func:`sim` (reading and parsing on one thread, planning on another, no heaters):
    ``total_s``, ``motion_s``, ``dwell_s``, ``overhead_s``, ``blocks``, ``layer_s``,
    ``feature_s``, and ``steps`` when ``steps=True``; ``warnings`` when the file looks cut
    short (timed to its cut, as a printer runs it). Heating waits and homing are not timed.
    """
    return _job(_gweave.estimate_json, locals())


# ---- binder-jet raster ----


def raster(
    inputs: Union[PathLike, Sequence[PathLike]],
    output: PathLike,
    *,
    head: Optional[PathLike] = None,
    machine: Optional[PathLike] = None,
    threshold: float = 0.5,
    invert: bool = False,
    flip_y: bool = False,
    one_way: bool = False,
    fire_order: str = "after",
    density: int = 1,
    origin: Optional[Sequence[float]] = None,
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
    test_pattern: bool = False,
    pattern_columns: int = 4,
) -> Report:
    """Layer images (folders, globs, image files) or one ``.sl1`` to binder-jet inkjet G-code.

    Per inked column: ``G1 X``, ``M400``, ``M700 P<head> S<bits>`` (``dialect="reprapfirmware"``: M578;
    ``"reprap"`` still accepted; ``fire_order="before"``: fire, wait, then move, the binder-jet
    seed's order). A pixel at or above ``threshold`` (a fraction of full scale) gets binder, a
    dark one with ``invert=True``; ``flip_y=True`` prints the images' first row at the far edge;
    ``one_way=True`` prints every pass left to right; ``density`` fires per pixel.
    Units: ``origin`` mm, ``layer_height`` mm, ``pixel_mm`` mm (or ``dpi``), ``feed`` mm/min;
    ``heads`` heads, one image channel each as ``channels`` lists them (``"r,b"``);
    ``recoat``/``start``/``end`` are files of G-code. ``head`` is a printhead profile TOML;
    ``machine`` (instead) an inkjet machine profile, a file or a built-in name (``binder-jet``):
    its printhead, powder recoat and canvas origin (the default ``origin``, else 20, 20 mm).
    ``fast_estimate=True`` times the print from the path at the feed rate instead of the planner.
    ``test_pattern=True`` writes the nozzle test pattern instead (no ``inputs``: give ``[]``),
    ``pattern_columns`` columns per nozzle address (see :func:`raster_test_pattern`).
    Returns the report of ``gweave raster --json`` (layers, bands, columns, drops per head,
    binder volume, ``time`` with the planner's estimate).
    """
    arguments = dict(locals())
    sources = arguments.pop("inputs")
    paths = [sources] if isinstance(sources, (str, bytes, os.PathLike)) else list(sources)
    compiled = functools.partial(_gweave.raster_json, [_path(p, "inputs") for p in paths])
    return _job(compiled, arguments, ("output",))


def raster_test_pattern(
    output: PathLike,
    *,
    head: Optional[PathLike] = None,
    machine: Optional[PathLike] = None,
    heads: Optional[int] = None,
    dialect: Optional[str] = None,
    pattern_columns: int = 4,
    origin: Optional[Sequence[float]] = None,
) -> Report:
    """Write a nozzle test pattern (``gweave raster --test-pattern``): ``pattern_columns`` columns
    per nozzle address, each address alone; the other keywords as for :func:`raster`."""
    return raster([], test_pattern=True, **locals())


def slice_raster(
    stl: PathLike,
    out_dir: PathLike,
    *,
    layer_height: float,
    dpi: float = 96.0,
    pixel_mm: Optional[float] = None,
    margin: int = 0,
) -> Report:
    """Slice an STL into 1-bit layer PNGs (pixel centres at mid-layer Z, even-odd fill).

    ``layer_height`` in mm; resolution as ``dpi`` or ``pixel_mm``. Returns the report of
    ``gweave slice-raster --json`` (grid, files, pixels per layer).
    """
    return json.loads(
        _gweave.slice_raster_json(
            _path(stl, "stl"),
            _path(out_dir, "out_dir"),
            layer_height=layer_height,
            dpi=dpi,
            pixel_mm=pixel_mm,
            margin=margin,
        )
    )


def _call(function: Any, arguments: Dict[str, Any], files: Sequence[str] = ("path", "output")) -> Any:
    """Calls a compiled job with a wrapper's own arguments (its ``locals()``): the ``files`` it
    reads or writes, in that order (the first required; a reading job such as sim or estimate
    has no ``output``), and the job's options by the names the engine declares
    (``_gweave.job_options``), which the engine reads and checks as the command line reads its
    flags. Paths may be ``str``, ``bytes`` or ``os.PathLike``."""
    options = dict(arguments)
    first, *rest = files
    paths: List[Optional[str]] = [_path(options.pop(first), first)]
    paths += [_opt_path(options.pop(name), name) for name in rest if name in options]
    for name, value in options.items():
        if isinstance(value, (bytes, os.PathLike)):
            options[name] = _path(value, name)
    return function(*paths, **options)


def _job(function: Any, arguments: Dict[str, Any], files: Sequence[str] = ("path", "output")) -> Report:
    """Runs a job (:func:`_call`) whose result is its report as JSON text."""
    return json.loads(_call(function, arguments, files))


def _transform(command: str, arguments: Dict[str, Any]) -> Report:
    """Runs the transform ``command`` of the engine's registry (``_gweave.transforms()``, each
    one a ``gweave`` subcommand too) with a typed wrapper's own arguments (:func:`_job`)."""
    return _job(functools.partial(_gweave.transform_json, command), arguments)


# purge-shift
def purge_shift(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
    config: Optional[PathLike] = None,
    purge_mm: Optional[float] = None,
    purge_mm3: Optional[float] = None,
    filament_diameter: Optional[float] = None,
    cross_layers: bool = False,
    allow_features: Optional[Sequence[str]] = None,
    markers: Optional[Sequence[str]] = None,
    fallback: Optional[str] = None,
    tower_at: Optional[Sequence[float]] = None,
) -> Report:
    """Move every tool/mix change earlier by the purge so it prints inside the part (no wipe tower).

    ``purge_mm`` is mm of filament (or ``purge_mm3``, mm^3); ``config`` a TOML file with per-pair
    amounts, colours, the washout model and rules (keyword arguments override it);
    ``filament_diameter`` (mm) converts mm^3; ``cross_layers=True`` lets a change move into the
    previous layer; ``allow_features`` lists the features a change may move through;
    ``markers`` = (begin, end) are explicit print-proper comments. With too little room,
    ``fallback`` is ``"partial"`` (accept the shortfall), ``"block"`` (purge the rest in a purge
    block, as ``mix`` does) or ``"tower"`` (on a small tower beside the part, its corner
    ``tower_at`` = (x, y) mm if given). A malformed line raises ``ValueError`` naming file, line
    and column unless ``lenient=True``, which copies it through and counts it
    (``malformed_lines``). Returns the report: per change the requested, moved and fallback purge,
    where the change now sits, and totals.
    """
    return _transform("purge-shift", locals())

# ---- preview (render) ----



def preview(
    path: PathLike,
    *,
    output: Optional[PathLike] = None,
    lenient: bool = False,
    report: bool = False,
    format: Optional[str] = None,
    layer: Optional[int] = None,
    layers: Union[str, Tuple[int, int], None] = None,
    view: Optional[str] = None,
    colour_by: str = "tool",
    size: Tuple[int, int] = (1200, 900),
    compare: Optional[PathLike] = None,
    tool_colours: Optional[Sequence[str]] = None,
    mix_profile: Optional[PathLike] = None,
    mandrel_diameter: Optional[float] = None,
    head: Optional[PathLike] = None,
    travel: bool = False,
    min_len: Optional[float] = None,
) -> Union[bytes, Tuple[bytes, Report]]:
    """Draw a file as ``gweave preview`` does; returns the file's bytes (PNG when ``output`` is None),
    or with ``report=True`` the bytes and the report ``gweave preview --json`` prints (format, view,
    layers drawn, strokes, moves, and the ``legend``: each colour and what it stands for).

    ``output`` is written (whole, or not at all) and picks the format by extension (``.png``,
    ``.svg``, ``.html``) unless ``format`` (``"png"``, ``"svg"``, ``"html"``) does.
    ``layer`` is one 0-based layer, ``layers`` an inclusive ``(first, last)`` range (or ``"A-B"``);
    ``min_len`` (mm) merges chained moves shorter than that; ``lenient=True`` draws past
    malformed lines and counts them in the report; ``view`` is ``"top"`` or
    ``"iso"`` (default: top for pictures, iso for the HTML page, which draws the beads as lit 3D
    tubes with WebGL); ``colour_by`` is ``tool``, ``feature``, ``speed``, ``layer`` or ``mix`` (the colour
    each move is predicted to print, from the file's mixing commands and the filaments of the
    ``gweave mix`` profile ``mix_profile``); ``tool_colours`` such as ``["#00ffff", "#ff00ff"]``
    colour the tools; ``mandrel_diameter`` (mm) draws a rotary program without a gweave header on
    its cylinder; ``head`` is the printhead profile of raster output; ``compare`` highlights moves that differ
    from another file (in HTML, the two side by side); ``size`` is ``(width, height)`` in pixels;
    ``travel=True`` draws travel moves too.
    """
    arguments = dict(locals())
    with_report = arguments.pop("report")
    if isinstance(layers, (tuple, list)):
        # The pair as the command line's `A-B`, read and checked by the engine.
        arguments["layers"] = "-".join(str(n) for n in layers)
    if tool_colours is not None:
        arguments["tool_colours"] = list(tool_colours)
    data, report_json = _call(_gweave.preview_json, arguments)
    return (data, json.loads(report_json)) if with_report else data


def toolpath(
    path: PathLike, *, travel: bool = True, min_len: float = 0.0, mandrel_diameter: Optional[float] = None
) -> Report:
    """A file's segments as NumPy arrays (NumPy is needed for this function only).

    Keys: ``start`` and ``end`` (float32, shape (n, 3), mm), ``tool`` (uint16), ``feature`` (uint8,
    an index into ``feature_names``), ``feed_mm_s`` (float32), ``layer`` (uint32), ``extruding``
    (bool); plus ``feature_names`` and ``layer_z`` (lists) and ``on_cylinder``. ``min_len`` (mm)
    merges chained moves shorter than that, for huge files; ``travel=False`` keeps extruding moves
    only. A rotary program (``gweave rotary`` output, whose header names the machine, or any file
    with ``mandrel_diameter``) comes out in 3D on its cylinder, the mandrel along X: ``on_cylinder``
    is true, ``layer_z`` holds each layer's radius and ``feed_mm_s`` the surface speed.
    """
    import numpy as np

    n, cols = _gweave.toolpath_columns(
        _path(path, "path"), travel=travel, min_len=min_len, mandrel_diameter=mandrel_diameter
    )
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
    out["on_cylinder"] = cols["on_cylinder"]
    return out


# mix
def mix(
    path: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    lenient: bool = False,
    config: Optional[PathLike] = None,
    at_layer: Sequence[str] = (),
    at_z: Sequence[str] = (),
    map: Sequence[str] = (),
    gradient: Sequence[str] = (),
    gradient_space: str = "mix",
    dialect: Optional[str] = None,
    purge_mm: Optional[float] = None,
    initial_purge: Optional[float] = None,
) -> Report:
    """Rewrite a file for a mixing hotend (see ``gweave mix``); returns the report.

    ``config`` is a profile TOML file; ``at_layer=["0=Orange", "10=Pink"]``, ``at_z``,
    ``map=["T1=PVA"]``, ``gradient=["0-50=Cyan..Magenta"]``, ``gradient_space`` (``"mix"`` or
    ``"perceived"``), ``dialect`` (``"marlin"``, ``"marlin-direct"``, ``"reprapfirmware"``;
    default: the profile's, else the file's flavour) and ``purge_mm`` (mm of filament per change, 0: none;
    default: the profile's) and ``initial_purge`` (mm purged in the first mix before the first
    extrusion; default: the profile's ``[purge] initial_mm``) work as the command line flags.
    ``lenient=True`` copies malformed lines through and counts them instead of raising.
    """
    return _transform("mix", locals())


def predict_colour(ratios: Sequence[float], profile: Optional[PathLike] = None) -> Report:
    """The colour a mix is predicted to print (see ``gweave mix --predict``).

    ``ratios`` has one share per input, in any scale (``[1, 0, 1, 0]`` is half cyan, half
    yellow); ``profile`` is a ``gweave mix`` profile TOML file whose filaments (colours and
    strengths) are used, else the default cyan, magenta, yellow and white. Returns
    ``{"ratios": [...], "srgb": "#rrggbb", "lab": [L, a, b]}`` with the ratios normalised.
    """
    text = ""
    if profile is not None:
        with open(os.fspath(profile), encoding="utf-8") as f:
            text = f.read()
    return json.loads(_gweave.predict_colour_json([float(r) for r in ratios], config=text))


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the ``gweave`` command (the native executable installed with this package) with
    ``argv`` (``sys.argv[1:]`` if ``None``); returns its exit code.

    A Ctrl-C stops the run (no output written) and raises ``SystemExit(130)``, with the
    ``KeyboardInterrupt`` as its ``__cause__``, as a command-line tool ends: ``finally`` blocks
    and ``atexit`` handlers run.
    """
    import sys

    from . import _command

    return _command.run(list(sys.argv[1:] if argv is None else argv))


# ---- rotary (lathe-type) printing ----------------------------------------------------------
# The jobs' keywords are the options the engine declares (`_gweave.job_options("rotary wrap")`),
# read and checked as the CLI reads its flags; every default, check and computation is the Rust
# library's (the same as `gweave rotary ... --json`).

def rotary_wrap(
    input: PathLike,
    output: Optional[PathLike] = None,
    *,
    in_place: bool = False,
    backup: bool = True,
    force: bool = False,
    mandrel_diameter: Optional[float] = None,
    feed_convention: Optional[str] = None,
    rotary_unit: Optional[str] = None,
    axes: Optional[Sequence[str]] = None,
    config: Optional[PathLike] = None,
    keep_arc_length: Optional[bool] = None,
    seam_rotation: Optional[float] = None,
    helical: bool = False,
    allow_overlap: bool = False,
    chord_tol: Optional[float] = None,
    preview: Optional[PathLike] = None,
    lenient: bool = False,
) -> Report:
    """Wrap a part sliced flat onto the mandrel of a lathe-type printer (``gweave rotary wrap``).

    Flat X runs along the mandrel, Y around it (``theta = 360*y/(pi*D)``), Z away from it
    (radius ``D/2 + z``). ``mandrel_diameter`` in mm; ``feed_convention`` is ``"nist"``, ``"combined"`` or
    ``"inverse-time"``; ``rotary_unit`` ``"deg"`` or ``"mm"``; ``axes`` like ``"X,A,Z"`` or ``"XAZ"`` (read as ``--axes`` is) or a sequence of three letters;
    ``keep_arc_length=True`` keeps flat arc lengths (``False`` turns the config's off);
    ``seam_rotation`` degrees per layer; ``helical=True`` winds each layer as one turn of a helix
    (no weld line); ``allow_overlap=True`` wraps a part wider than the circumference over itself;
    ``chord_tol`` mm; ``lenient=True`` copies malformed lines through and counts them instead of
    raising. Keywords override the TOML ``config``.
    ``preview`` writes a 3D PNG of the executed path. Give ``output``, or ``in_place=True`` to
    replace ``input`` (keeping a ``.bak`` unless ``backup=False``; ``force=True`` replaces a
    read-only file). Returns the report (per-layer radius, angles swept, seam angle; filament;
    time).
    """
    return _job(_gweave.rotary_wrap_json, locals(), ("input", "output"))


def rotary_tube(
    output: PathLike,
    *,
    mandrel_diameter: Optional[float] = None,
    feed_convention: Optional[str] = None,
    rotary_unit: Optional[str] = None,
    axes: Optional[Sequence[str]] = None,
    config: Optional[PathLike] = None,
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
    preview: Optional[PathLike] = None,
) -> Report:
    """Generate a seam-free tube of continuous helical layers (``gweave rotary tube``).

    ``layer_count`` layers, layer k on radius ``D/2 + (k + 1/2)*h`` (``D``: the
    ``mandrel_diameter``, ``h``: the ``layer_height``), each ``length`` mm along the mandrel, advancing ``pitch`` mm per turn
    (default the ``bead_width``: a closed wall), reversing its helix every layer unless
    ``interweave=False``, at surface speed ``speed`` mm/s, at least ``segments_per_turn`` chords
    per turn and chords within ``chord_tol`` mm. Lengths in mm, ``temp`` in degrees C,
    ``filament_diameter`` mm; ``feed_convention``, ``rotary_unit`` and ``axes`` as for
    :func:`rotary_wrap`. Keywords override the TOML ``config``; ``preview`` writes a 3D PNG of
    the tube. Returns the report (per-layer radius, handedness, turns, spindle speed; filament
    and its volume against the wall volume; time).
    """
    return _job(_gweave.rotary_tube_json, locals(), ("output",))


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
) -> Report:
    """Write a program printing custom :class:`HelicalPath` beads in order (one bead each).

    Between paths the nozzle moves without extruding. ``config`` is a TOML file with
    ``[machine]`` and ``[print]`` tables as in the tube's. Returns ``filament_mm`` and
    ``print_time_s``.

    A cone from radius 10 down to 5 over 30 mm, one closed layer::

        cone = gweave.HelicalPath(0, 30, radius=[(0, 10.1), (30, 5.1)], pitch=0.4)
        gweave.write_helical_paths([cone], "cone.gcode", mandrel_diameter=20)
    """
    settings = {
        "print": {
            "layer_height_mm": layer_height,
            "bead_width_mm": bead_width,
            "print_speed_mm_s": speed,
            "nozzle_temp_c": temp,
            "filament_diameter_mm": filament_diameter,
            "chord_tolerance_mm": chord_tol,
            "segments_per_turn": segments_per_turn,
        },
    }
    text = _gweave.write_helical_paths_json(
        list(paths),
        _path(output, "output"),
        settings=json.dumps(settings),
        config=_opt_path(config, "config"),
        mandrel_diameter=mandrel_diameter,
        feed_convention=feed_convention,
        rotary_unit=rotary_unit,
        axes=axes,
    )
    return json.loads(text)
