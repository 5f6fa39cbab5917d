"""Python's transforms finish their output as the CLI's do (issue 21): one header line naming the
run in the CLI's words, the slicer's figures rewritten for the file as written, and a second run
of the same transform on its own output refused."""

import pytest

import gweave

TORUS = ("prusaslicer", "pr_torus_pva.gcode")


def headers(path):
    lines = path.read_text().splitlines()
    return [l for l in lines if l.startswith("; gweave ") and l.endswith(" (generated)")]


def test_a_mix_output_names_its_run_and_its_figures_are_true(data, tmp_path):
    out = tmp_path / "mixed.gcode"
    gweave.mix(data.joinpath(*TORUS), out, at_layer=["0=Orange", "3=Blue"], purge_mm=25)
    expected = "mix --at-layer 0=Orange --at-layer 3=Blue --purge-mm 25"
    assert headers(out) == [f"; gweave {gweave.__version__} {expected} (generated)"]
    s = gweave.stats(out)
    # The purges are in the file's filament now, and the slicer's footer says so.
    assert s["filament_matches_slicer"] is True
    before = gweave.stats(data.joinpath(*TORUS))
    assert s["slicer_figures"]["filament_used_mm"] != before["slicer_figures"]["filament_used_mm"]


def test_a_second_purge_shift_on_its_own_output_raises_naming_the_first(data, tmp_path):
    once = tmp_path / "once.gcode"
    gweave.purge_shift(data.joinpath(*TORUS), once, purge_mm=2.5)
    assert headers(once) == [f"; gweave {gweave.__version__} purge-shift --purge-mm 2.5 (generated)"]
    twice = tmp_path / "twice.gcode"
    earlier = r"once\.gcode:1: this file was written by `gweave .* purge-shift --purge-mm 2\.5`: a second"
    with pytest.raises(ValueError, match=earlier):
        gweave.purge_shift(once, twice, purge_mm=2.5)
    assert not twice.exists()


def test_a_rotary_tube_names_its_run(tmp_path):
    out = tmp_path / "tube.gcode"
    gweave.rotary_tube(out, mandrel_diameter=20, length=10, layer_count=2, interweave=False)
    expected = "rotary tube --mandrel-diameter 20 --length 10 --layer-count 2 --no-interweave"
    assert headers(out) == [f"; gweave {gweave.__version__} {expected} (generated)"]
