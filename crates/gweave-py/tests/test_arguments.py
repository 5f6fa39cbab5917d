"""Inputs validated as the CLI validates them: FileNotFoundError with errno and filename,
TypeError or ValueError naming the parameter, paths as str, bytes or os.PathLike, and `bed=` and
layer ranges read by the engine's own parsers."""

import errno
import os
from pathlib import Path

import pytest

import gweave

MK3S = (
    "M104 S215\nM109 S215\nG28\nG92 E0\nG1 Y-3 F1000\nG1 X60 E9 F1000\nG1 X100 E12.5\n"
    "G1 X120 Y50 Z0.2 F3000\n; bed_shape = 0x-4,250x-4,250x210,0x210\n; max_print_height = 210\n"
)


def test_a_missing_file_is_file_not_found_with_errno_and_filename(tmp_path: Path) -> None:
    missing = tmp_path / "nope.gcode"
    for call in (gweave.stats, gweave.check, gweave.sim, gweave.estimate, gweave.read, gweave.preview):
        with pytest.raises(FileNotFoundError) as e:
            call(missing)
        assert e.value.errno == errno.ENOENT, call
        assert e.value.filename == str(missing), call
    with pytest.raises(FileNotFoundError) as e:
        gweave.sim(Path(gweave.__file__), machine=missing)
    assert e.value.filename == str(missing)


def test_paths_as_str_bytes_and_pathlike(data: Path) -> None:
    path = data / "prusaslicer" / "pr_box_mach3.gcode"
    expected = gweave.stats(str(path))
    assert gweave.stats(path) == expected
    assert gweave.stats(os.fsencode(path)) == expected
    assert next(iter(gweave.read(os.fsencode(path)))).number == 1
    with pytest.raises(TypeError, match=r"^path: expected a path \(str, bytes or os.PathLike\), not int$"):
        gweave.stats(3)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"^output: expected a path"):
        gweave.cat(path, 2.5)  # type: ignore[arg-type]


def test_check_bed_is_read_as_the_cli_reads_it(tmp_path: Path) -> None:
    f = tmp_path / "mk3s.gcode"
    f.write_text(MK3S)
    # Regression: `bed="200,200,200"` was read as a 2 x 0 x 0 bed.
    r = gweave.check(f, bed="200,200,200")
    assert r["bed"] == {"x_mm": [0.0, 200.0], "y_mm": [0.0, 200.0], "z_mm": 200.0}
    # The purge line's three moves at Y = -3.
    assert [(x["line"], x["kind"], x["value_mm"]) for x in r["findings"]] == [
        (5, "outside_bed", -3.0),
        (6, "outside_bed", -3.0),
        (7, "outside_bed", -3.0),
    ]
    assert gweave.check(f, bed=(200, 200, 200))["bed"] == r["bed"]
    # With its origin, and from the file's own settings: PrusaSlicer's purge line passes.
    assert gweave.check(f, bed="0,-4,250,210")["warnings"] == 0
    auto = gweave.check(f)
    assert auto["warnings"] == 0 and auto["bed_from"].startswith("bed_shape = 0x-4,250x-4")
    with pytest.raises(ValueError, match=r'^bed: expected X,Y,Z or X0,Y0,X1,Y1\[,Z\] \(mm\), got "200,200"$'):
        gweave.check(f, bed="200,200")
    with pytest.raises(ValueError, match=r"^max_feed = -1 is out of range: 1 to 100000 mm/min$"):
        gweave.check(f, max_feed=-1)


def test_check_strict_fails_on_warnings(tmp_path: Path) -> None:
    f = tmp_path / "mk3s.gcode"
    f.write_text(MK3S)
    assert gweave.check(f, bed="250,210,210")["failed"] is False
    assert gweave.check(f, bed="250,210,210", strict=True)["failed"] is True


def test_check_holds_a_klipper_file_to_its_cross_section_as_the_cli_does(tmp_path: Path) -> None:
    # A purge of 10 mm of filament over 7 mm: a 3.4 mm² bead, past Klipper's default 0.64 mm²
    # (4 x the file's 0.4 mm nozzle squared), unless the printer raised it.
    f = tmp_path / "purge.gcode"
    f.write_text("; gcode_flavor = klipper\nM104 S215\nG1 X5 Y5 E10\n; nozzle_diameter = 0.4\n")
    found = gweave.check(f)["findings"]
    assert [(x["line"], x["kind"], x["severity"]) for x in found] == [(3, "over_extrusion", "error")]
    assert found[0]["area_mm2"] == 3.402
    assert gweave.check(f, klipper_max_extrude_cross_section=5)["findings"] == []
    with pytest.raises(ValueError, match=r"^klipper_max_extrude_cross_section = 0 is out of range: 0.001 to 1000 mm²$"):
        gweave.check(f, klipper_max_extrude_cross_section=0)


def test_preview_layer_arguments_are_typed(data: Path) -> None:
    path = data / "cura" / "cura_dual.gcode"
    # Regression: `layer="3"` raised IndexError.
    with pytest.raises(TypeError, match="layer"):
        gweave.preview(path, layer="3")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^layers: empty layer range 9-3$"):
        gweave.preview(path, layers=(9, 3))
    _, r = gweave.preview(path, layers="3-4", size=(100, 100), report=True)
    assert r["layers_drawn"] == [3, 4]
    with pytest.raises(ValueError, match="layer and layers"):
        gweave.preview(path, layer=3, layers="3-4")


def test_lenient_reads_past_malformed_lines(tmp_path: Path) -> None:
    f = tmp_path / "bad.gcode"
    f.write_text("M104 S200\nG1 X1 Y1 F600\nG1 X1..2\nG1 X3 E1\n")
    with pytest.raises(ValueError, match=r"bad.gcode:3:5: malformed number after 'X'"):
        gweave.stats(f)
    s = gweave.stats(f, lenient=True)
    assert (s["malformed_lines"], s["first_malformed_line"]) == (1, 3)
    _, r = gweave.preview(f, lenient=True, report=True, size=(100, 100))
    assert r["malformed_lines"] == 1


def test_mix_purge_mm_and_sim_fault(data: Path, tmp_path: Path) -> None:
    src = data / "prusaslicer" / "pr_torus_pva.gcode"
    r = gweave.mix(src, tmp_path / "a.gcode", at_layer=["0=Orange", "5=Blue"], purge_mm=7)
    assert r["purge"]["count"] >= 1 and r["purge"]["filament_mm"] == pytest.approx(7 * r["purge"]["count"])
    off = gweave.mix(src, tmp_path / "b.gcode", at_layer=["0=Orange", "5=Blue"], purge_mm=0)
    assert off["purge"]["filament_mm"] == 0
    with pytest.raises(ValueError, match="^purge_mm = -1 is out of range"):
        gweave.mix(src, tmp_path / "c.gcode", purge_mm=-1)
    # As `gweave sim --fault hotend-cartridge-off@30s`: the hotend never heats, the machine halts.
    sim = gweave.sim(src, fault=["hotend-cartridge-off@30s"])
    assert sim["halted"] is True
    assert [(f["kind"], f["heater"]) for f in sim["thermal_faults"]] == [("heating_failed", {"hotend": 0})]
    with pytest.raises(ValueError, match="^fault: "):
        gweave.sim(data / "prusaslicer" / "pr_box_mach3.gcode", fault=["nonsense"])
