"""Sizes given from Python held to the CLI's ranges under the keyword's name (issue 36): a
negative picture size was an OverflowError that named no argument."""

import re
from pathlib import Path

import pytest

import gweave


def test_preview_size_out_of_range_names_the_keyword(tmp_path: Path) -> None:
    path = tmp_path / "a.gcode"
    path.write_text("M104 S200\nM109 S200\nG1 X1 Y1 E1 F600\nG1 X20 Y5 E2\n")
    # Each side held to the range, the keyword named (the CLI names --size).
    cases = (((-1, 5), "-1"), ((800, 5), "5"), ((10**12, 600), "1e12"))
    for size, value in cases:
        message = rf"^size = {re.escape(value)} is out of range: 16 to 16384 px$"
        with pytest.raises(ValueError, match=message):
            gweave.preview(path, size=size)
    # In range, the picture is drawn at that size.
    png = gweave.preview(path, size=(64, 48))
    assert isinstance(png, bytes) and png[16:24] == (64).to_bytes(4, "big") + (48).to_bytes(4, "big")
