"""Binder-jet raster through Python: the same figures as the CLI's end-to-end checks."""

from pathlib import Path

import pytest

import gweave

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples" / "raster"
RDATA = ROOT / "crates" / "gweave" / "tests" / "data" / "raster"


def fire_lines(path: Path, code: str = "M700"):
    lines = path.read_text().splitlines()
    return lines, [i for i, l in enumerate(lines) if l.startswith(code + " ")]


def test_raster_bmp_stack(tmp_path):
    out = tmp_path / "badge.gcode"
    r = gweave.raster(EXAMPLES / "layers", out, flip_y=True, head=EXAMPLES / "c6602.toml")
    assert (r["layers"], r["bands_printed"], r["bands_skipped"]) == (8, 29, 3)
    # Regression: the report named the scratch file (`.gweave-XXXX.tmp`) the run wrote first.
    assert r["output"] == str(out)
    assert (r["columns_fired"], r["drops_per_head"]) == (844, [6508])
    assert r["binder_volume_ul"] == pytest.approx(6508 * 160e-6)
    assert r["time"]["method"] == "planner"
    lines, fires = fire_lines(out)
    assert len(fires) == 844
    assert all(lines[i - 1] == "M400" and " P0 S" in lines[i] for i in fires)


def test_raster_options_density_dialect_two_heads(tmp_path):
    out = tmp_path / "two.gcode"
    r = gweave.raster(
        [EXAMPLES / "layers", EXAMPLES / "layers"],
        out,
        heads=2,
        head=EXAMPLES / "c6602_2head.toml",
        density=2,
        dialect="reprap",
        one_way=True,
        fast_estimate=True,
    )
    assert r["heads"] == 2 and r["drops_per_head"] == [2 * 6508, 2 * 6508]
    assert r["fire_commands"] == 2 * r["columns_fired"]
    assert r["time"]["method"] == "feed"
    _, fires = fire_lines(out, "M578")
    assert len(fires) == r["fire_commands"]


def test_raster_sl1_and_errors(tmp_path):
    r = gweave.raster(RDATA / "sphere.sl1", tmp_path / "s.gcode", fast_estimate=True)
    assert (r["layers"], r["drops_per_head"]) == (308, [2199541])
    with pytest.raises(ValueError, match="dialect"):
        gweave.raster(EXAMPLES / "layers", tmp_path / "x.gcode", dialect="klipper")
    with pytest.raises(ValueError, match="no such file"):
        gweave.raster(tmp_path / "missing", tmp_path / "x.gcode")


def test_test_pattern(tmp_path):
    out = tmp_path / "p.gcode"
    r = gweave.raster_test_pattern(out, pattern_columns=2)
    assert r["fire_commands"] == 24
    s = [int(l.split("S")[1]) for l in out.read_text().splitlines() if l.startswith("M700")]
    assert s == [1 << a for a in range(12) for _ in range(2)]
    # The run's header, as the CLI writes it (`gweave raster --test-pattern --pattern-columns 2`).
    first = out.read_text().splitlines()[0]
    assert first.startswith("; gweave ") and first.endswith(" raster --test-pattern --pattern-columns 2 (generated)")


def test_slice_raster_then_raster(tmp_path):
    s = gweave.slice_raster(RDATA / "torus.stl", tmp_path / "layers", layer_height=0.1, dpi=96)
    assert s["grid"]["layers"] == 57 and len(s["files"]) == 57
    r = gweave.raster(tmp_path / "layers", tmp_path / "t.gcode", fast_estimate=True)
    assert r["drops_per_head"] == [sum(s["pixels_per_layer"])]
    # The resolution is checked as the CLI checks --dpi (the library's SliceConfig::with_resolution).
    with pytest.raises(ValueError, match="^dpi = 0 is out of range"):
        gweave.slice_raster(RDATA / "torus.stl", tmp_path / "none", layer_height=0.1, dpi=0)


def test_raster_for_a_machine_is_timed_as_sim_times_it_there(tmp_path):
    """``machine=`` plans the raster's time on the machine's own motion (it was Marlin's defaults,
    0.5 s short of ``sim`` on the binder jet's pistons), and both count 800 us after each fire."""
    out = tmp_path / "badge.gcode"
    r = gweave.raster(EXAMPLES / "layers", out, machine="binder-jet")
    t = gweave.sim(out, machine="binder-jet")["time"]
    assert r["time"]["total_s"] == pytest.approx(t["motion_s"] + t["dwell_s"], abs=1e-6)
    assert t["dwell_s"] == pytest.approx(7 * 0.5 + r["fire_commands"] * 800e-6, abs=1e-9)


def test_raster_for_the_binder_jet_machine_passes_its_recoat_checks(tmp_path):
    """``machine="binder-jet"`` writes the machine's recoat on its canvas, as ``--machine``: the
    virtual printer with the same machine warns of nothing (the default recoat: 14 warnings)."""
    plain = tmp_path / "plain.gcode"
    gweave.raster(EXAMPLES / "layers", plain, fast_estimate=True)
    assert len(gweave.sim(plain, machine="binder-jet")["warnings"]) == 14
    out = tmp_path / "machine.gcode"
    r = gweave.raster(EXAMPLES / "layers", out, machine="binder-jet", fast_estimate=True)
    assert r["drops_per_head"] == [6508]
    text = out.read_text()
    assert "G1 Y195 F300\n" in text and text.splitlines()[0].endswith(" raster --machine binder-jet --fast-estimate (generated)")
    assert gweave.sim(out, machine="binder-jet")["warnings"] == []
    with pytest.raises(ValueError, match="^machine and head: give one of them$"):
        gweave.raster(EXAMPLES / "layers", tmp_path / "x.gcode", machine="binder-jet", head=EXAMPLES / "c6602.toml")
    with pytest.raises(ValueError, match="has no inkjet printhead"):
        gweave.raster(EXAMPLES / "layers", tmp_path / "x.gcode", machine="prusa-mk3")
