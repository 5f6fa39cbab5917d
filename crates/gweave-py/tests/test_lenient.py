"""The transforms' keywords are the CLI's flags (issue 21): ``lenient=`` on mix, purge_shift and
rotary_wrap, ``helical=`` on rotary_wrap, ``fire_order=`` on raster; each call writes the bytes
the same command line writes."""

import pytest

import gweave

# Two layers, the second with a malformed number on line 7.
BAD = (
    "M104 S200\nM83\n;LAYER_CHANGE\nG1 Z0.2 F100\nG1 X10 Y5 E1 F1800\n;LAYER_CHANGE\n"
    "G1 X1..2\nG1 Z0.4 F100\nG1 X0 E2\n"
)

CASES = [
    ("mix", ["mix", "--at-layer", "0=Red", "--at-layer", "1=Blue"], lambda i, o, **k: gweave.mix(i, o, at_layer=["0=Red", "1=Blue"], **k)),
    ("purge-shift", ["purge-shift", "--purge-mm", "1"], lambda i, o, **k: gweave.purge_shift(i, o, purge_mm=1, **k)),
    ("rotary wrap", ["rotary", "wrap", "--mandrel-diameter", "30"], lambda i, o, **k: gweave.rotary_wrap(i, o, mandrel_diameter=30, **k)),
]


@pytest.mark.parametrize("name,argv,call", CASES, ids=[c[0] for c in CASES])
def test_lenient_copies_the_bad_line_as_the_cli_does(tmp_path, name, argv, call):
    bad = tmp_path / "bad.gcode"
    bad.write_text(BAD)
    with pytest.raises(ValueError, match=r"bad\.gcode:7:5: malformed number after 'X'"):
        call(bad, tmp_path / "strict.gcode")
    assert not (tmp_path / "strict.gcode").exists()
    py, cli = tmp_path / "py.gcode", tmp_path / "cli.gcode"
    report = call(bad, py, lenient=True)
    assert (report["malformed_lines"], report["first_malformed_line"]) == (1, 7)
    assert gweave.main(argv + [str(bad), "-o", str(cli), "--lenient", "-q"]) == 0
    assert "\nG1 X1..2\n" in py.read_text()
    assert py.read_bytes() == cli.read_bytes()


def test_helical_wrap_is_the_cli_s(data, tmp_path):
    flat = data / "rotary" / "plate.gcode"
    py, cli = tmp_path / "py.gcode", tmp_path / "cli.gcode"
    report = gweave.rotary_wrap(flat, py, mandrel_diameter=30, helical=True)
    assert report["helical"] is True
    assert gweave.main(["rotary", "wrap", str(flat), "-o", str(cli), "--mandrel-diameter", "30", "--helical", "-q"]) == 0
    assert py.read_bytes() == cli.read_bytes()


def test_fire_order_is_the_cli_s(tmp_path):
    from PIL import Image

    layer = tmp_path / "layer.png"
    Image.new("1", (8, 8), 1).save(layer)
    py, cli = tmp_path / "py.gcode", tmp_path / "cli.gcode"
    gweave.raster(layer, py, fire_order="before")
    assert gweave.main(["raster", str(layer), "-o", str(cli), "--fire-order", "before", "-q"]) == 0
    # One header, written from the options (the CLI's named the layer images it was given).
    assert py.read_bytes().split(b"\n", 1)[0].endswith(b" raster --fire-order before (generated)")
    assert py.read_bytes() == cli.read_bytes()
    text = py.read_text()
    assert "\nM700 P0 S255\nM400\nG1 X" in text, text
    with pytest.raises(ValueError, match="^fire_order: unknown variant `during`, expected `after` or `before`$"):
        gweave.raster(layer, tmp_path / "x.gcode", fire_order="during")
