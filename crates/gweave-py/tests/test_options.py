"""Each transform job's options are declared once, in the engine (name, kind, range, default,
help): the typed wrappers in `gweave/__init__.py` take exactly those keywords with the same
defaults, the compiled functions take them as `**options` (so the stub keeps no second list),
and the engine checks each value, naming the keyword (the CLI names the flag)."""

import ast
import inspect
import json
import re
from pathlib import Path
from typing import Any, Dict

import pytest

import gweave
from gweave import _gweave

TORUS = ("prusaslicer", "pr_torus_pva.gcode")
# Keywords every transform shares, not options of the job: the file, where it goes, strictness.
TRANSFORM = {"path", "output", "in_place", "backup", "force", "lenient"}
# A reading job (sim, estimate) takes its file, and writes nothing but what its options name.
READING = {"path"}
# command -> (typed wrapper, compiled function, the keywords that are no option of the job: the
# files it reads and writes, a rotary job's `preview` picture too)
JOBS = {
    "rotary wrap": (gweave.rotary_wrap, "rotary_wrap_json", TRANSFORM - {"path"} | {"input", "preview"}),
    "rotary tube": (gweave.rotary_tube, "rotary_tube_json", {"output", "preview"}),
    "sim": (gweave.sim, "sim_json", READING),
    "estimate": (gweave.estimate, "estimate_json", READING),
    # preview returns the picture, writes it to `output` if named, and its report on request.
    "preview": (gweave.preview, "preview_json", {"path", "output", "lenient", "report"}),
    # raster reads layer images (or one .sl1), a list.
    "raster": (gweave.raster, "raster_json", {"inputs", "output"}),
}
# The transforms of the engine's registry (purge-shift, mix, ...): one compiled function runs
# them all by their command, each has the typed wrapper named as its command.
TRANSFORMS = _gweave.transforms()
JOBS.update({c: (getattr(gweave, c.replace("-", "_"), None), "transform_json", TRANSFORM) for c in TRANSFORMS})
# Keywords Python takes in a wider type than the declaration's, turned into the command line's
# text by the wrapper before the engine reads it: (annotation, default).
WIDER = {
    ("preview", "layers"): ("Union[str, Tuple[int, int], None]", None),  # (first, last) or "A-B"
    ("preview", "size"): ("Tuple[int, int]", (1200, 900)),  # declared "1200x900"
}

# The annotation each kind of option has in the typed wrapper, and its default there.
ANNOTATION = {
    "number": ("Optional[float]", None),
    "whole": ("Optional[int]", None),
    "path": ("Optional[PathLike]", None),
    "repeated": ("Sequence[str]", ()),
    "texts": ("Optional[Sequence[str]]", None),
    "numbers": ("Optional[Sequence[float]]", None),
}


# A number or count whose default is a value: its annotation in the wrapper, and its type.
VALUED = {"number": ("float", float), "whole": ("int", int)}


def declared(command: str) -> Dict[str, Dict[str, Any]]:
    return {o["name"]: o for o in _gweave.job_options(command)}


@pytest.mark.parametrize("command", sorted(JOBS))
def test_the_wrapper_takes_the_declared_options_with_their_defaults_and_types(command):
    wrapper, _, shared = JOBS[command]
    options = declared(command)
    params = {n: p for n, p in inspect.signature(wrapper).parameters.items() if n not in shared}
    assert list(params) == list(options), "the wrapper's keywords, in the declaration's order"
    for name, p in params.items():
        o = options[name]
        assert p.kind is inspect.Parameter.KEYWORD_ONLY, name
        if (command, name) in WIDER:
            expected = WIDER[command, name]
        elif o["kind"] == "text":
            # A word whose default is a value (gradient_space="mix") or unset.
            expected = ("str", o["default"]) if o["default"] is not None else ("Optional[str]", None)
        elif o["kind"] == "flag":
            # A switch off by default, or unset (keep_arc_length=False turns a config's on off).
            expected = ("bool", False) if o["default"] == "false" else ("Optional[bool]", None)
        elif o["kind"] in VALUED and o["default"] is not None:
            # A number or count whose default is a value (raster's threshold=0.5, density=1).
            annotation, kind = VALUED[o["kind"]]
            expected = (annotation, kind(o["default"]))
        else:
            expected = ANNOTATION[o["kind"]]
        assert (p.annotation, p.default) == expected, name
        assert re.search(f"``{name}[`=]", wrapper.__doc__), f"{name} is not in the docstring"


@pytest.mark.parametrize("command", sorted(JOBS))
def test_the_compiled_function_takes_the_options_as_keywords_and_its_stub_says_so(command):
    _, compiled, shared = JOBS[command]
    shared = shared - {"report"}  # the wrapper's own: what it returns
    if compiled == "transform_json":
        shared = shared | {"command"}  # the registry's row it runs
    params = inspect.signature(getattr(_gweave, compiled)).parameters
    assert set(params) - {"options"} == shared
    assert params["options"].kind is inspect.Parameter.VAR_KEYWORD
    stub = ast.parse((Path(gweave.__file__).parent / "_gweave.pyi").read_text(encoding="utf-8"))
    node = next(n for n in stub.body if isinstance(n, ast.FunctionDef) and n.name == compiled)
    names = {a.arg for a in node.args.args + node.args.kwonlyargs}
    assert names == shared and node.args.kwarg is not None and node.args.kwarg.arg == "options"


def test_declared_ranges_and_help_are_those_of_the_flags():
    purge_mm = declared("purge-shift")["purge_mm"]
    assert purge_mm["flag"] == "--purge-mm" and purge_mm["range"] == (0.0, 1000.0)
    assert purge_mm["help"].startswith("Purge per change, mm of filament")
    assert declared("mix")["gradient_space"]["default"] == "mix"
    # Shared by both rotary jobs, declared once: the same options, first in each.
    machine = [o["name"] for o in _gweave.job_options("rotary wrap")][:5]
    assert machine == ["mandrel_diameter", "feed_convention", "rotary_unit", "axes", "config"]
    assert [o["name"] for o in _gweave.job_options("rotary tube")][:5] == machine
    layer_count = declared("rotary tube")["layer_count"]
    assert layer_count["kind"] == "whole" and layer_count["range"] == (1.0, 1000.0)
    assert declared("rotary tube")["interweave"]["flag"] == "--no-interweave"


def test_a_value_out_of_range_names_the_keyword(data, tmp_path):
    with pytest.raises(ValueError, match=r"^purge_mm = 2000 is out of range: 0 to 1000 mm$"):
        gweave.purge_shift(data.joinpath(*TORUS), tmp_path / "o.gcode", purge_mm=2000)
    with pytest.raises(ValueError, match=r"^tower_at = 1e\+06 is out of range|^tower_at = 1000000 is out of range"):
        gweave.purge_shift(data.joinpath(*TORUS), tmp_path / "o.gcode", purge_mm=2, tower_at=(0, 1e6))
    with pytest.raises(ValueError, match=r"^initial_purge = -1 is out of range: 0 to 1000 mm$"):
        gweave.mix(data.joinpath(*TORUS), tmp_path / "o.gcode", initial_purge=-1)
    with pytest.raises(ValueError, match=r"^gradient_space: unknown variant `lab`, expected `mix` or `perceived`$"):
        gweave.mix(data.joinpath(*TORUS), tmp_path / "o.gcode", gradient_space="lab")
    with pytest.raises(ValueError, match=r"^purge_mm and purge_mm3: give one of them$"):
        gweave.purge_shift(data.joinpath(*TORUS), tmp_path / "o.gcode", purge_mm=2, purge_mm3=5)
    with pytest.raises(ValueError, match=r"^markers: takes 2 values \(BEGIN,END\), not 1$"):
        gweave.purge_shift(data.joinpath(*TORUS), tmp_path / "o.gcode", purge_mm=2, markers=["only"])
    assert not (tmp_path / "o.gcode").exists()


def test_rotary_values_are_checked_as_the_flags_are(data, tmp_path):
    plate = data / "rotary" / "plate.gcode"
    with pytest.raises(ValueError, match=r"^mandrel_diameter = 0.5 is out of range: 1 to 1000 mm$"):
        gweave.rotary_wrap(plate, tmp_path / "o.gcode", mandrel_diameter=0.5)
    with pytest.raises(ValueError, match=r"^helical and seam_rotation: give one of them$"):
        gweave.rotary_wrap(plate, tmp_path / "o.gcode", mandrel_diameter=30, helical=True, seam_rotation=5)
    # A count is an int, as for preview's layer: a float is the wrong type (the CLI, reading
    # text, says "2.5 is not a whole number").
    with pytest.raises(TypeError, match=r"^layer_count: "):
        gweave.rotary_tube(tmp_path / "o.gcode", mandrel_diameter=20, layer_count=2.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^segments_per_turn = 2 is out of range: 3 to 3600$"):
        gweave.rotary_tube(tmp_path / "o.gcode", mandrel_diameter=20, segments_per_turn=2)
    assert not (tmp_path / "o.gcode").exists()


def test_an_unknown_keyword_is_a_type_error_as_python_raises_it(data, tmp_path):
    with pytest.raises(TypeError, match=r"purge_shift\(\) got an unexpected keyword argument 'purge'"):
        _gweave.transform_json("purge-shift", str(data.joinpath(*TORUS)), str(tmp_path / "o.gcode"), purge=2.5)
    with pytest.raises(ValueError, match=r'^no transform "purge" \(purge-shift, mix'):
        _gweave.transform_json("purge", str(data.joinpath(*TORUS)), str(tmp_path / "o.gcode"))


def test_every_job_of_the_engine_is_held_to_its_declaration_here():
    """Regression (issue 40): the jobs were listed by hand here, in the CLI's tests and in the
    compiled module, with nothing holding the lists equal; the engine's list is the one now
    (`gweave_sim::transform::jobs`), and a job missing from `JOBS` has no wrapper checked."""
    assert sorted(JOBS) == sorted(_gweave.jobs())
    assert _gweave.jobs()[: len(TRANSFORMS)] == TRANSFORMS, "the registry's rows first"


@pytest.mark.parametrize("command", TRANSFORMS)
def test_every_transform_of_the_registry_is_a_command_and_a_typed_function(command, capfd, monkeypatch, tmp_path):
    """Regression (issue 40): a transform was written into each front end by hand (13 files
    for one); now it is one row of the engine's registry, from which the CLI derives its
    subcommand and `transform_json` runs it: the typed wrapper, named as the command, is the
    one thing Python adds (held to the declaration above)."""
    name = command.replace("-", "_")
    wrapper = JOBS[command][0]
    assert wrapper is not None, f"no typed wrapper gweave.{name}"
    assert name in gweave.__all__
    # It runs its own row, with its files and every declared option by its keyword: what it
    # hands the compiled function, recorded in its place (the test read the wrapper's source
    # text for the call, which a wrapper running another row with the right text passed).
    calls = []

    def recorded(*args: Any, **options: Any) -> str:
        calls.append((args, options))
        return '{"recorded": true}'

    monkeypatch.setattr(_gweave, "transform_json", recorded)
    src, out = tmp_path / "in.gcode", tmp_path / "out.gcode"
    assert wrapper(src, out) == {"recorded": True}
    assert [args for args, _ in calls] == [(command, str(src), str(out))]
    assert set(calls[0][1]) == set(declared(command)) | (TRANSFORM - {"path", "output"})
    monkeypatch.undo()
    capfd.readouterr()
    assert gweave.main([command, "--help"]) == 0
    assert f"Usage: gweave {command} " in capfd.readouterr().out


def test_the_header_is_written_from_the_options_value(data, tmp_path):
    out = tmp_path / "o.gcode"
    gweave.purge_shift(data.joinpath(*TORUS), out, purge_mm=2.5, tower_at=(10, 20.5), fallback="tower")
    header = [l for l in out.read_text().splitlines() if l.startswith("; gweave ")][0]
    assert header == f"; gweave {gweave.__version__} purge-shift --purge-mm 2.5 --fallback tower --tower-at 10,20.5 (generated)"
    wrapped = tmp_path / "w.gcode"
    plate = data / "rotary" / "plate.gcode"
    gweave.rotary_wrap(plate, wrapped, chord_tol=0.02, axes="x,a,z", rotary_unit="deg", mandrel_diameter=30, lenient=True)
    header = wrapped.read_text().splitlines()[0]
    assert header == (
        f"; gweave {gweave.__version__} rotary wrap --mandrel-diameter 30 --rotary-unit degrees --axes X,A,Z "
        "--chord-tol 0.02 --lenient (generated)"
    )


def test_a_missing_config_file_is_file_not_found_naming_it(data, tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(FileNotFoundError) as e:
        gweave.mix(data.joinpath(*TORUS), tmp_path / "o.gcode", config=missing)
    assert e.value.filename == str(missing)


def test_machine_is_loaded_as_the_cli_loads_it(data, tmp_path):
    """Regression (issue 40): one loader for `--machine` and `machine=`."""
    with pytest.raises(FileNotFoundError) as e:
        gweave.estimate(data.joinpath(*TORUS), machine=tmp_path / "nope.toml")
    assert e.value.filename == str(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[bed]\nx_mm = -1\n")
    with pytest.raises(ValueError, match=rf"^{bad}: .*x_mm = -1 is out of range"):
        gweave.estimate(data.joinpath(*TORUS), machine=bad)


def test_a_refusal_names_the_options_by_their_keywords(tmp_path):
    """Regression (issue 40): the engine's refusals named the CLI's flags; Python names the
    keywords (the CLI the flags: `crates/gweave-cli/tests/lenient_transforms.rs`)."""
    src = tmp_path / "t1.gcode"
    src.write_text("M83\n;LAYER_CHANGE\nG1 X1 E1\nT1\nG1 X2 E1\n")
    out = tmp_path / "out.gcode"
    with pytest.raises(ValueError) as e:
        gweave.mix(src, out, map=["T0=Red"])
    assert str(e.value) == f"{src}:4: the file selects T1, which has no mix: add map T1=<mix>"
    with pytest.raises(ValueError) as e:
        gweave.mix(src, out)
    assert str(e.value) == (
        "mix profile: nothing to do: give a schedule (at_layer, at_z, [[schedule]]), "
        "a gradient (gradient, [[gradient]]) or a tool map (map, [map])"
    )
    with pytest.raises(ValueError) as e:
        gweave.purge_shift(src, out)
    assert str(e.value) == (
        "no purge amount: give purge_mm or purge_mm3, or in the config purge_mm, purge_mm3, "
        "colours, pairs or a washout tolerance"
    )
    assert not out.exists()


def test_estimate_machine_slicer_plans_with_the_files_own_limits_as_the_cli_does(data, capfd):
    """Regression (issue 40): `gweave estimate --machine slicer` planned with the limits the
    slicer wrote into the file; `gweave.estimate(machine="slicer")` looked for a profile called
    `slicer`. One job now runs both."""
    torus = str(data.joinpath(*TORUS))
    r = gweave.estimate(torus, machine="slicer")
    assert r["machine"] == "PrusaSlicer's machine limits in the file, flavour marlin2"
    capfd.readouterr()
    assert gweave.main(["estimate", torus, "--machine", "slicer", "--json", "-q"]) == 0
    assert json.loads(capfd.readouterr().out) == r
    with pytest.raises(ValueError, match=r": machine slicer: the file holds no machine limits"):
        gweave.estimate(data / "cura" / "cura_torus.gcode", machine="slicer")


def test_sim_draws_the_charts_the_cli_draws(data, tmp_path, capfd):
    """Regression (issue 40): `--plot`, `--plot-speed` and `--raster-out` had no keyword; the
    job draws them for both front ends, and refuses a chart that is neither PNG nor SVG before
    the run, naming the keyword."""
    box = data / "prusaslicer" / "pr_box_mach3.gcode"
    with pytest.raises(ValueError, match=r"^plot_speed: a plot is written as PNG or SVG \(by its extension\), not \"jpg\"$"):
        gweave.sim(box, plot_speed=tmp_path / "s.jpg")
    report = gweave.sim(box, plot=tmp_path / "t.svg", plot_speed=tmp_path / "s.png")
    capfd.readouterr()
    assert gweave.main(["sim", str(box), "--json", "-q"]) == 0
    assert json.loads(capfd.readouterr().out) == report, "the CLI and Python report the same run"
    assert (tmp_path / "t.svg").read_text().lstrip().startswith("<svg")
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_marlin_model_option_on_the_controller_core_names_the_keyword(data, tmp_path):
    profile = data.parent.parent / "examples" / "machines" / "gweave-ramps.toml"
    with pytest.raises(ValueError, match=r"^raster_out is for the Marlin model: "):
        gweave.sim(data.joinpath(*TORUS), machine=profile, raster_out=tmp_path / "canvases")


def test_preview_writes_its_output_whole_and_refuses_as_the_cli_does(data, tmp_path, capfd):
    """Regression (issue 40): Python wrote the picture in place (a failed write left part of
    it), checked `layer` against `layers` with a message of its own, and had no `format`."""
    cura = data / "cura" / "cura_dual.gcode"
    out = tmp_path / "p.svg"
    data_svg, r = gweave.preview(cura, output=out, layers=(3, 4), size=(100, 80), report=True)
    assert out.read_bytes() == data_svg and r["format"] == "svg" and r["layers_drawn"] == [3, 4]
    cli = tmp_path / "cli.svg"
    capfd.readouterr()
    assert gweave.main(["preview", str(cura), "-o", str(cli), "--layers", "3-4", "--size", "100x80", "-q"]) == 0
    assert cli.read_bytes() == data_svg, "the CLI and Python draw the same picture"
    assert gweave.preview(cura, format="svg", layer=3, size=(100, 80)).lstrip().startswith(b"<svg")
    with pytest.raises(ValueError, match=r"^layer and layers: give one of them$"):
        gweave.preview(cura, layer=3, layers="3-4")
    with pytest.raises(ValueError, match=r'^format: unknown output format "gif" \(png, svg or html\)$'):
        gweave.preview(cura, format="gif")
    with pytest.raises(TypeError, match=r"^layer: "):
        gweave.preview(cura, layer=2.5)  # type: ignore[arg-type]
    # The picture goes through the engine's writer (a temporary file renamed into place): a
    # failed run leaves what was there and no temporary file; a missing folder is an OSError
    # naming the file.
    keep = tmp_path / "p.png"
    keep.write_bytes(b"old")
    bad = tmp_path / "bad.gcode"
    bad.write_text("G1 X1 Y1 E1\nG1 X1..2\n")
    with pytest.raises(ValueError, match=r"bad.gcode:2:"):
        gweave.preview(bad, output=keep, size=(64, 48))
    assert keep.read_bytes() == b"old"
    with pytest.raises(OSError, match="no/p.png"):
        gweave.preview(cura, output=tmp_path / "no" / "p.png", size=(64, 48))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.gcode", "cli.svg", "p.png", "p.svg"]


def test_the_test_pattern_wrapper_takes_raster_options_with_their_defaults():
    """`raster_test_pattern` is `raster(test_pattern=True)` with the options a pattern uses:
    each is one of raster's, with the same annotation and default."""
    raster = inspect.signature(gweave.raster).parameters
    pattern = inspect.signature(gweave.raster_test_pattern).parameters
    for name, p in pattern.items():
        if name != "output":
            assert (p.annotation, p.default) == (raster[name].annotation, raster[name].default), name
    assert set(pattern) - {"output"} <= set(declared("raster"))


def test_raster_is_checked_and_headed_from_its_options(tmp_path):
    """Regression (issue 40): raster's keywords were a hand-kept signature and its header a
    hand-kept `_flags` list with the defaults typed again; both come from the declaration now."""
    layers = Path(__file__).resolve().parents[3] / "examples" / "raster" / "layers"
    out = tmp_path / "r.gcode"
    gweave.raster(layers, out, threshold=0.5, density=2, dialect="reprap", origin=(10, 20.5), fast_estimate=True)
    header = out.read_text().splitlines()[0]
    assert header == (
        f"; gweave {gweave.__version__} raster --density 2 --origin 10,20.5 --dialect reprapfirmware "
        "--fast-estimate (generated)"
    )
    with pytest.raises(ValueError, match=r"^density = 17 is out of range: 1 to 16 fires per pixel$"):
        gweave.raster(layers, out, density=17)
    with pytest.raises(TypeError, match=r"^density: "):
        gweave.raster(layers, out, density=1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^fire_order: unknown variant `sideways`, expected `after` or `before`$"):
        gweave.raster(layers, out, fire_order="sideways")
    with pytest.raises(ValueError, match=r"^pixel_mm and dpi: give one of them$"):
        gweave.raster(layers, out, pixel_mm=0.1, dpi=300)
