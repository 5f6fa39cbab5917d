"""Rotary printing through Python: the same numbers as the CLI and the Rust tests."""

import json
import math
import shutil
import subprocess
import sys

import pytest

import gweave


def test_tube_report_matches_the_wall_and_the_cli(tmp_path):
    r = gweave.rotary_tube(tmp_path / "t.gcode", mandrel_diameter=20, length=30, layer_count=3, preview=tmp_path / "t.png")
    wall = math.pi * ((10 + 3 * 0.2) ** 2 - 10**2) * 30
    assert r["wall_volume_mm3"] == pytest.approx(wall, rel=1e-12)
    assert r["extruded_mm3"] == pytest.approx(wall, rel=0.01)
    assert [l["handedness"] for l in r["layers"]] == ["right", "left", "right"]
    assert [l["radius_mm"] for l in r["layers"]] == pytest.approx([10.1, 10.3, 10.5])
    assert (tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"
    cli = tmp_path / "cli.gcode"
    code = gweave.main(["rotary", "tube", "-o", str(cli), "--mandrel-diameter", "20", "--length", "30", "--layers", "3", "--json"])
    assert code == 0
    assert cli.read_bytes() == (tmp_path / "t.gcode").read_bytes()


def test_tube_keywords_override_the_config(tmp_path):
    toml = tmp_path / "tube.toml"
    toml.write_text("length_mm = 12\nlayers = 5\n[machine]\nmandrel_diameter_mm = 16\n[print]\nbead_width_mm = 0.5\n")
    r = gweave.rotary_tube(tmp_path / "t.gcode", config=toml, layer_count=2, pitch=4.0, interweave=False, feed_convention="combined")
    assert len(r["layers"]) == 2 and r["pitch_mm"] == 4.0 and r["bead_width_mm"] == 0.5
    assert r["machine"]["feed_convention"] == "combined" and r["machine"]["mandrel_diameter_mm"] == 16
    assert {l["handedness"] for l in r["layers"]} == {"right"}
    with pytest.raises(ValueError, match="pitch_mm"):
        gweave.rotary_tube(tmp_path / "bad.gcode", mandrel_diameter=20, pitch=0.1)


def test_wrap_closes_every_layer(data, tmp_path):
    r = gweave.rotary_wrap(
        data / "rotary" / "plate.gcode", tmp_path / "s.gcode", mandrel_diameter=30, seam_rotation=7.5, axes="X,A,Z"
    )
    assert len(r["layers"]) == 10
    bead_deg = 360 * 0.45 / (math.pi * 30)
    for k, layer in enumerate(r["layers"]):
        assert layer["span_deg"] + bead_deg == pytest.approx(360, abs=0.005)
        assert layer["seam_deg"] == pytest.approx(7.5 * k)
        assert layer["radius_mm"] == pytest.approx(15 + 0.2 * (k + 1))


def test_wrap_replaces_its_input_only_when_asked_as_the_cli(data, tmp_path):
    """Regression: ``rotary_wrap`` had no ``in_place`` (the CLI's ``--in-place``), and refusing an
    output that is the input told a Python caller to "use --in-place"."""
    src = tmp_path / "plate.gcode"
    shutil.copy(data / "rotary" / "plate.gcode", src)
    original = src.read_bytes()
    with pytest.raises(ValueError, match=r"refusing to overwrite the input file .*: the output names the file being read; name another output file, or replace the input in place"):
        gweave.rotary_wrap(src, src, mandrel_diameter=30)
    with pytest.raises(ValueError, match="give an output path or in_place=True"):
        gweave.rotary_wrap(src, mandrel_diameter=30)
    assert src.read_bytes() == original
    gweave.rotary_wrap(src, tmp_path / "sleeve.gcode", mandrel_diameter=30)
    src.chmod(0o444)
    with pytest.raises(ValueError, match="read-only: it is replaced in place only when forced"):
        gweave.rotary_wrap(src, in_place=True, mandrel_diameter=30)
    assert src.read_bytes() == original
    report = gweave.rotary_wrap(src, in_place=True, force=True, mandrel_diameter=30)
    assert len(report["layers"]) == 10
    assert (tmp_path / "plate.gcode.bak").read_bytes() == original
    assert src.read_bytes() == (tmp_path / "sleeve.gcode").read_bytes()


def test_cone_path_points_follow_the_radius_table():
    cone = gweave.HelicalPath(0, 30, radius=[(0, 10.1), (30, 5.1)], pitch=0.4)
    pts = cone.points(chord_tol=0.01)
    assert pts[0] == pytest.approx((0, 0, 10.1)) and pts[-1][0] == pytest.approx(30)
    for axial, theta, radius in pts:
        assert radius == pytest.approx(10.1 - axial / 6, abs=1e-9)
    # 30 mm at 0.4 mm per turn: 75 turns, right-handed (the angle grows with the axial position).
    assert pts[-1][1] == pytest.approx(75 * 360, rel=1e-9)


def test_callable_profiles_and_their_errors(tmp_path):
    wavy = gweave.HelicalPath(10, 0, radius=lambda x: 10 + 0.5 * math.sin(x), pitch=lambda x: 1 + x / 10, handedness="left")
    pts = wavy.points(segments_per_turn=36)
    assert all(abs(r - (10 + 0.5 * math.sin(a))) < 1e-9 for a, _, r in pts)
    # Backwards and left-handed: the angle grows while the axial position falls.
    assert pts[-1][0] == pytest.approx(0) and pts[-1][1] > 0
    s = gweave.write_helical_paths([wavy], tmp_path / "w.gcode", mandrel_diameter=19, speed=15)
    assert s["filament_mm"] > 0 and s["print_time_s"] > 0

    def broken(x):
        raise ZeroDivisionError("profile says no")

    with pytest.raises(ZeroDivisionError, match="profile says no"):
        gweave.HelicalPath(0, 5, radius=broken, pitch=1.0).points()
    with pytest.raises(ValueError, match="handedness"):
        gweave.HelicalPath(0, 5, radius=10, pitch=1, handedness="up")


def test_wrap_keywords_read_a_config_as_the_cli_flags_do(data, tmp_path):
    # A file without the [machine] table's required diameter, completed by the keyword, with a
    # switch turned off and values replaced: the same options value as the CLI's flags.
    toml = tmp_path / "wrap.toml"
    toml.write_text("chord_tolerance_mm = 0.05\n[unwrap]\nseam_rotation_per_layer_deg = 3\n")
    plate = data / "rotary" / "plate.gcode"
    r = gweave.rotary_wrap(
        plate, tmp_path / "py.gcode", config=toml, mandrel_diameter=30, seam_rotation=7.5, axes="X,Y,Z",
        rotary_unit="mm", feed_convention="combined",
    )
    assert r["machine"]["mandrel_diameter_mm"] == 30 and r["chord_tolerance_mm"] == 0.05
    assert r["seam_rotation_per_layer_deg"] == 7.5 and r["machine"]["axes"] == "XYZ"
    cli = tmp_path / "cli.gcode"
    # In any order and spelling: both headers are written from the options value.
    flags = ["--seam-rotation", "7.5", "-c", str(toml), "--feed", "combined", "--axes", "x,y,z", "--rotary-unit", "mm",
             "--mandrel-diameter", "30"]
    assert gweave.main(["rotary", "wrap", str(plate), "-o", str(cli), *flags, "-q"]) == 0
    assert cli.read_bytes() == (tmp_path / "py.gcode").read_bytes()
    # Regression (engine errors named CLI flags): a Python caller was told to give --mandrel-diameter.
    with pytest.raises(ValueError, match=r"^no mandrel diameter: give one \(1 to 1000 mm\)") as refused:
        gweave.rotary_wrap(plate, tmp_path / "none.gcode")
    assert "--" not in str(refused.value)
    with pytest.raises(ValueError, match=r"^rotary_unit: unknown variant `inch`, expected one of `deg`, `degrees`, `mm`$"):
        gweave.rotary_wrap(plate, tmp_path / "bad.gcode", mandrel_diameter=30, rotary_unit="inch")


def test_the_report_names_the_written_file_not_the_scratch_file(data, tmp_path):
    """Regression (issue 40): Python's rotary reports named the scratch file the job wrote
    first (`.gweave-*.tmp`); the one job names the output, as the CLI's --json does."""
    out = tmp_path / "w.gcode"
    assert gweave.rotary_wrap(data / "rotary" / "plate.gcode", out, mandrel_diameter=30)["output"] == str(out)
    tube = tmp_path / "t.gcode"
    assert gweave.rotary_tube(tube, mandrel_diameter=20, length=5, layer_count=1)["output"] == str(tube)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.gcode", "w.gcode"]


def test_keep_arc_length_false_turns_a_configs_off_for_a_helical_wrap(data, tmp_path):
    """Regression (issue 40): a switch given as False (restoring the default over the config)
    was counted as given, and `helical=True` refused as conflicting with it."""
    toml = tmp_path / "wrap.toml"
    toml.write_text("[unwrap]\nkeep_arc_length = true\n")
    out = tmp_path / "h.gcode"
    r = gweave.rotary_wrap(data / "rotary" / "plate.gcode", out, config=toml, mandrel_diameter=30,
                           keep_arc_length=False, helical=True)
    assert r["helical"] and not r["keep_arc_length"]
    assert out.read_text().splitlines()[0].endswith(" rotary wrap --mandrel-diameter 30 -c " f"{toml} --helical (generated)")


def test_axes_take_the_cli_spellings_xaz_and_x_comma_a_comma_z(data, tmp_path):
    """Regression (issue 40): Python split ``axes`` itself and refused ``"XAZ"``, which
    ``--axes`` takes; the engine's one parser reads both front ends' text now."""
    plate = data / "rotary" / "plate.gcode"
    written = {}
    for axes in ["XYZ", "x,y,z", ("X", "Y", "Z")]:
        out = tmp_path / f"py-{len(written)}.gcode"
        r = gweave.rotary_wrap(plate, out, mandrel_diameter=30, axes=axes)
        assert r["machine"]["axes"] == "XYZ", axes
        written[str(axes)] = out.read_bytes()
    for axes in ["XYZ", "x,y,z"]:
        cli = tmp_path / f"cli-{axes}.gcode"
        assert gweave.main(["rotary", "wrap", str(plate), "-o", str(cli), "--mandrel-diameter", "30", "--axes", axes, "-q"]) == 0
        assert cli.read_bytes() == written[axes]
    assert len(set(written.values())) == 1
    tube = gweave.rotary_tube(tmp_path / "t.gcode", mandrel_diameter=20, length=5, layer_count=1, axes="XAY")
    assert tube["machine"]["axes"] == "XAY"
    path = gweave.HelicalPath(0, 5, radius=10.1, pitch=0.4)
    gweave.write_helical_paths([path], tmp_path / "h.gcode", mandrel_diameter=20, axes="XBZ", rotary_unit="deg")
    assert " B" in (tmp_path / "h.gcode").read_text()
    with pytest.raises(ValueError, match=r"^axes: takes 3 letters \(X,A,Z\), not \"XA\""):
        gweave.rotary_wrap(plate, tmp_path / "bad.gcode", mandrel_diameter=30, axes="XA")
