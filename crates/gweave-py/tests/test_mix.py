"""gweave.mix on real slicer files: the same figures as the Rust tests and the command line."""

from pathlib import Path

import pytest

import gweave

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "mix"


def test_the_seeds_layer_schedule(data, tmp_path):
    out = tmp_path / "torus.gcode"
    r = gweave.mix(data / "cura" / "cura_torus.gcode", out, config=EXAMPLES / "seed_layers.toml")
    assert [m["name"] for m in r["mixes"]] == ["Orange", "Pink", "Blue"]
    assert r["mixes"][0]["ratios"] == [0.0, 0.1717, 0.8283, 0.0]
    assert r["mixes"][1]["layers"] == [[10, 24]]
    assert (r["changes"], r["purge"]["count"]) == (2, 2)
    assert abs(r["purge"]["filament_mm"] - 50.0) < 1e-9
    lines = out.read_text().splitlines()
    assert lines.index("M164 S1") < lines.index("T1")


def test_flags_and_soluble_support(data, tmp_path):
    out = tmp_path / "pva.gcode"
    r = gweave.mix(data / "prusaslicer" / "pr_torus_pva.gcode", out, map=["T0=Orange", "T1=support"])
    support = next(m for m in r["mixes"] if m["name"] == "support")
    assert support["ratios"] == [0.0, 0.0, 0.0, 1.0]
    assert r["changes"] == 2


def test_bad_input_raises(data, tmp_path):
    with pytest.raises(ValueError, match="no colour or material named"):
        gweave.mix(data / "cura" / "cura_torus.gcode", tmp_path / "x.gcode", at_layer=["0=Mauve"])
    with pytest.raises(ValueError, match="nothing to do"):
        gweave.mix(data / "cura" / "cura_torus.gcode", tmp_path / "x.gcode")


def test_predict_colour_is_the_command_lines(tmp_path):
    green = gweave.predict_colour([1, 0, 1, 0])
    assert green["ratios"] == [0.5, 0.0, 0.5, 0.0]
    assert green["srgb"] == "#69c348"  # `gweave mix --predict 1:0:1:0`
    assert green["lab"][1] < -30  # a* < 0: green
    profile = tmp_path / "two.toml"
    profile.write_text(
        '[[hardware.inputs]]\ncolour = "#002185"\n[[hardware.inputs]]\ncolour = "#fcd300"\n'
    )
    assert gweave.predict_colour([1, 1], profile=profile)["srgb"] == "#418548"
    with pytest.raises(ValueError, match="mix has 3 inputs, expected 4"):
        gweave.predict_colour([1, 1, 1])
