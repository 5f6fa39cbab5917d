"""The core through Python: the same numbers as the Rust tests, from real slicer files."""

import filecmp
import re
import subprocess
import sys

import pytest

import gweave


def test_stats_match_prusaslicer_figures(data):
    s = gweave.stats(data / "prusaslicer" / "pr_bunny_3tool_rel.gcode")
    assert s["slicer"] == "prusaslicer"
    assert s["layers"] == 535
    assert s["tool_changes"] == 793
    ours = [t["extruded_mm"] for t in s["filament"]]
    theirs = s["slicer_figures"]["filament_used_mm"]
    assert theirs == [10979.45, 20959.92, 1594.45]
    for a, b in zip(ours, theirs):
        assert abs(a - b) <= b * 1e-4
    assert s["filament_diameter_mm"] == 1.75


def test_read_gives_words_and_state(data):
    lines = list(gweave.read(data / "cura" / "cura_torus.gcode"))
    assert len(lines) == 18808
    first_layer = next(l for l in lines if l.comment == "LAYER:0")
    assert first_layer.layer == 0 and first_layer.region == "print"
    moves = [l for l in lines if l.is_move and l.extruded > 0 and l.layer == 0]
    assert moves and all(abs(l.position[2] - 0.3) < 1e-9 for l in moves)
    g1 = next(l for l in lines if l.command == "G1" and "X" in l.words)
    assert isinstance(g1.words["X"], float)
    assert lines[-1].region == "end"
    outer = {l.feature for l in lines if l.layer == 3 and l.is_move}
    assert outer == {"inner_wall", "outer_wall", "solid_infill"}


def test_read_follows_the_files_flavour(data):
    """PrusaSlicer's mach3 flavour extrudes with A; the file says so only in its last lines."""
    src = data / "prusaslicer" / "pr_box_mach3.gcode"
    # Extruding moves in XY, as PrusaSlicer counts (retractions and their recoveries stay apart).
    extruded = sum(l.extruded for l in gweave.read(src) if l.extruded > 0 and ("X" in l.words or "Y" in l.words))
    theirs = gweave.stats(src)["slicer_figures"]["filament_used_mm"][0]
    assert theirs == 2604.63 and abs(extruded - theirs) < 0.01


def test_words_strings_and_diagnostics(tmp_path):
    p = tmp_path / "odd.gcode"
    p.write_bytes(b'M291 P"Hello" S2\nG1 X1..2 Y3\nM117 Printing now ; c\n')
    lines = list(gweave.read(p))
    assert lines[0].words == {"P": "Hello", "S": 2.0}
    assert lines[1].diagnostics == [(5, "malformed number after 'X'")]
    assert lines[1].words["Y"] == 3.0 and lines[1].words["X"] is None
    assert lines[2].text == "Printing now" and lines[2].comment == " c"


def test_cat_is_byte_exact_and_never_overwrites_input(data, tmp_path):
    src = data / "slic3r" / "slic3r_cone_2tool.gcode"
    out = tmp_path / "copy.gcode"
    copied = gweave.cat(src, out)
    assert filecmp.cmp(src, out, shallow=False)
    raw = src.read_bytes()
    assert copied == {"lines": raw.count(b"\n"), "bytes": len(raw), "malformed_lines": 0, "first_malformed_line": None}
    # The engine's words, as the CLI shows them: Python rewrote the message that named --in-place.
    with pytest.raises(ValueError) as e:
        gweave.cat(out, out)
    assert str(e.value) == (
        f"refusing to overwrite the input file {out}: the output names the file being read; "
        "name another output file, or replace the input in place"
    )


def test_an_output_naming_the_input_says_which_input_by_its_path(tmp_path, capfd):
    """Regression (a new user's trial): the CLI refused ``-o same.gcode`` with "names the input
    (INPUT)", which reads like a placeholder; both front ends name the input by its path."""
    src = tmp_path / "same.gcode"
    src.write_text("G1 X1\n")
    with pytest.raises(ValueError, match=rf"^refusing to overwrite the input file {re.escape(str(src))}: "):
        gweave.cat(src, tmp_path / "." / "same.gcode")
    assert not (tmp_path / "same.gcode.bak").exists() and src.read_text() == "G1 X1\n"
    capfd.readouterr()
    assert gweave.main(["cat", str(src), "-o", str(src)]) == 1
    err = capfd.readouterr().err
    assert f"-o {src} would overwrite the input file {src}; name another file" in err, err


def test_check_reports_line_and_column(tmp_path):
    p = tmp_path / "bad.gcode"
    p.write_bytes(b"M104 S200\nG1 X10 Y10 F1800\nN7 G1 X5*99\nG1 X500 E1\n")
    report = gweave.check(p, bed=(200, 200, 200))
    kinds = [(f["line"], f["column"], f["kind"]) for f in report["findings"]]
    assert (3, 9, "checksum_mismatch") in kinds
    assert (4, 4, "outside_bed") in kinds
    assert report["errors"] == 1


def test_bad_input_is_a_clear_error_and_no_output(tmp_path):
    p = tmp_path / "bad.gcode"
    p.write_bytes(b"G1 X1\nG1 Y2..3\n")
    out = tmp_path / "out.gcode"
    with pytest.raises(ValueError, match=r"bad.gcode:2:5: malformed number after 'Y'"):
        gweave.cat(p, out)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [p]


def test_console_script_is_the_rust_cli(data, tmp_path):
    src = data / "prusaslicer" / "pr_torus_pva.gcode"
    r = subprocess.run([sys.executable, "-m", "gweave", "stats", str(src), "--json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert '"layers": 28' in r.stdout
    r = subprocess.run([sys.executable, "-m", "gweave", "check", str(tmp_path / "missing.gcode")], capture_output=True, text=True)
    assert r.returncode == 1 and "missing.gcode" in r.stderr
    assert gweave.main(["--version"]) == 0


def test_the_command_is_the_native_executable_and_the_module_has_no_cli():
    # The package carries the CLI's own executable (the wheel's scripts/), not a Python entry
    # point into the extension, which no longer links the CLI crate.
    from gweave import _command

    exe = _command.executable()
    with open(exe, "rb") as f:
        magic = f.read(4)
    if sys.platform.startswith("linux"):
        assert magic == b"\x7fELF", exe
    assert not hasattr(gweave._gweave, "run_cli")
    # Its exit codes come through: 2 for a usage error (clap's), 1 for a failed run.
    assert gweave.main(["--no-such-flag"]) == 2
    assert gweave.main(["stats", "/nonexistent/x.gcode"]) == 1


def test_a_file_cut_mid_number_without_its_footer_looks_truncated(data, tmp_path):
    """Regression (a new user's trial): a file cut at `E1` of `E17.55707`, no final newline,
    passed `check` silently and `purge_shift` appended its footer to it. Its slicer ends every
    file with `; prusaslicer_config = end`: `check` warns where the text stops, the transform
    raises naming the file, line and column and writes nothing, `lenient=True` writes it."""
    text = (data / "prusaslicer" / "pr_cone_2tool.gcode").read_text()
    cut_at = text.index("G1 X112.194 Y106.138 E17.55707") + len("G1 X112.194 Y106.138 E1")
    cut = tmp_path / "cut.gcode"
    cut.write_text(text[:cut_at])
    report = gweave.check(cut)
    assert (report["errors"], report["warnings"], report["failed"]) == (0, 1, False)
    finding = report["findings"][0]
    assert (finding["line"], finding["column"], finding["kind"], finding["footer"]) == (387, 24, "no_footer", "prusaslicer")
    assert gweave.check(cut, strict=True)["failed"]
    out = tmp_path / "out.gcode"
    with pytest.raises(ValueError, match=rf"^{re.escape(str(cut))}:387:24: the file looks truncated: "):
        gweave.purge_shift(cut, out, purge_mm=2)
    assert not out.exists()
    gweave.purge_shift(cut, out, purge_mm=2, lenient=True)
    assert "G1 X112.194 Y106.138 E1\n" in out.read_text()
    # `stats` and `estimate` count and time it to its cut, and say so first.
    said = "the file looks truncated: its last line has no line ending"
    assert gweave.stats(cut)["warnings"][0].startswith(said)
    assert gweave.estimate(cut)["warnings"][0].startswith(said)
    assert "warnings" not in gweave.estimate(data / "prusaslicer" / "pr_cone_2tool.gcode")
