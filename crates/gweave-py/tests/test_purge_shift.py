"""purge-shift through Python: the same numbers as the Rust tests and the CLI."""

import pytest

import gweave


def test_slic3r_first_change_is_split_by_hand(data, tmp_path):
    out = tmp_path / "cone.gcode"
    r = gweave.purge_shift(data / "slic3r" / "slic3r_cone_2tool.gcode", out, purge_mm=2.5)
    assert len(r["changes"]) == 108
    c = r["changes"][0]
    # Output lines count the run's header on top.
    assert c["change_lines"] == [553] and c["output_line"] == 512
    assert c["achieved_mm"] == 2.5 and c["split"]["line"] == 509
    lines = out.read_text().splitlines()
    # 24.30781 - 2.5 = 21.80781, inside the move from E21.79225 to E21.85317; T0's 10 mm
    # tool-change retraction goes with the change (T1, never used, has none to undo).
    assert lines[509:515] == [
        "G1 X104.44317 Y87.09572 E21.80781",
        "G1 E11.80781 F2400",
        "T1",
        "G92 E21.80781",
        "G1 F1800",
        "G1 X104.913 Y87.264 E21.85317",
    ]
    assert c["retraction"]["old_mm"] == -10 and c["retraction"]["dropped_mm"] == 10


def test_config_and_keywords(cura_one_nozzle, tmp_path):
    cfg = tmp_path / "purge.toml"
    cfg.write_text("purge_mm = 2.5\n[[pair]]\nfrom = 1\nto = 0\npurge_mm = 1.0\n")
    r = gweave.purge_shift(cura_one_nozzle, tmp_path / "o.gcode", config=cfg, cross_layers=True)
    assert {c["requested_mm"] for c in r["changes"] if c["from_tool"] == 1} == {1.0}
    assert all(abs(c["achieved_mm"] + c["shortfall_mm"] - c["requested_mm"]) < 1e-9 for c in r["changes"])


def test_fallbacks_purge_the_shortfall(data, tmp_path):
    src = data / "slic3r" / "slic3r_cone_2tool.gcode"
    out = tmp_path / "tower.gcode"
    r = gweave.purge_shift(src, out, purge_mm=2.5, fallback="tower", tower_at=(150, 20))
    assert all(c["shortfall_mm"] == 0 and c["achieved_mm"] == 2.5 for c in r["changes"])
    assert abs(r["moved_mm"] - 241.02) < 0.01 and abs(r["fallback_mm"] - 28.98) < 0.01
    towers = [c for c in r["changes"] if c["fallback_mm"] > 0]
    assert len(towers) == 29 and all(c["fallback_lines"] > 0 for c in towers)
    text = out.read_text()
    assert text.count("; gweave purge-shift: purge T") == 29
    assert "\nG0 X150 Y20 F6000\n" in text
    b = gweave.purge_shift(src, tmp_path / "block.gcode", purge_mm=2.5, fallback="block")
    assert b["fallback_mm"] == r["fallback_mm"] and b["moved_mm"] == r["moved_mm"]
    # A corner is two numbers, as for `--tower-at X,Y`.
    for corner in [(150,), (150, 20, 0)]:
        with pytest.raises(ValueError, match=r"^tower_at: takes 2 values \(X,Y\), not [13]$"):
            gweave.purge_shift(src, tmp_path / "x.gcode", purge_mm=2.5, fallback="tower", tower_at=corner)


def test_refusals(data, tmp_path):
    with pytest.raises(ValueError, match="unknown fallback"):
        gweave.purge_shift(data / "cura" / "cura_dual.gcode", tmp_path / "o.gcode", purge_mm=2, fallback="wipe")
    with pytest.raises(ValueError, match="no purge amount"):
        gweave.purge_shift(data / "cura" / "cura_dual.gcode", tmp_path / "o.gcode")
    assert not (tmp_path / "o.gcode").exists()


def test_a_file_for_a_nozzle_per_tool_is_refused(data, tmp_path):
    """Regression: Cura's dual-extrusion changes were moved before the file heated the new
    nozzle (13 cold extrusions on the virtual dual extruder): refused, nothing written."""
    dual = data / "cura" / "cura_dual.gcode"
    want = (
        rf"^{dual}:4249: here, at the first command after the temperatures, T0's nozzle is at 200 °C "
        r"\(set on line 4247\) and T1's at 215 °C \(line 3974\): "
        r"the file heats a nozzle per tool\. purge-shift moves colour changes on one nozzle .* "
        r"or run `gweave mix` on it first and purge-shift mix's output$"
    )
    with pytest.raises(ValueError, match=want):
        gweave.purge_shift(dual, tmp_path / "o.gcode", purge_mm=2.5)
    assert list(tmp_path.iterdir()) == []
