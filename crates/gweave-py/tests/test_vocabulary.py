"""Python like the CLI: every flag of every command has its keyword (same name, `-` as `_`) or a
stated reason why not, and every keyword is a flag or a positional argument. The table below is
the map (docs/pipeline.md, "One vocabulary"); this test fails when either side drifts."""

import inspect
import re
from typing import Dict

import pytest

import gweave
from gweave import _gweave

# Flags every command shares that have no place in a function call: the report is the return
# value, and nothing is drawn on a terminal.
COMMON = {
    "json": "the return value is the report",
    "report": "the return value is the report",
    "quiet": "no progress bar or summary in Python",
    "help": "Python's help()",
    "version": "gweave.__version__",
}

# Output flags of transforms: `-o` is the `output` argument, `--no-backup` is `backup=False`.
# `--format` chooses standard output's container (`-o -`); Python writes files, whose names say it.
FORMAT = {"format": "- standard output's container: Python writes files, whose names say it"}
TARGET = {"output": "output", "in-place": "in_place", "no-backup": "backup", "force": "force", **FORMAT}


def declared(command: str) -> Dict[str, str]:
    """The flags of a job's options as the engine declares them (`_gweave.job_options`), each
    to its keyword: a new option of a job needs no line here."""
    return {o["flag"][2:]: o["name"] for o in _gweave.job_options(command)}


# command -> (function, {flag: keyword, or "-" and the reason}, positional arguments)
MAP = {
    "stats": ("stats", {"filament-diameter": "filament_diameter", "lenient": "lenient"}, ["path"]),
    "check": (
        "check",
        {
            "bed": "bed",
            "machine": "machine",
            "max-feed": "max_feed",
            "klipper-max-extrude-cross-section": "klipper_max_extrude_cross_section",
            "strict": "strict",
        },
        ["path"],
    ),
    "cat": ("cat", {**TARGET, "lenient": "lenient"}, ["path"]),
    "sim": ("sim", declared("sim"), ["path"]),
    "estimate": ("estimate", declared("estimate"), ["path"]),
    "raster": ("raster", {"output": "output", **FORMAT, **declared("raster")}, ["inputs"]),
    "slice-raster": (
        "slice_raster",
        {"layer-height": "layer_height", "dpi": "dpi", "pixel-mm": "pixel_mm", "margin": "margin", "output": "out_dir"},
        ["stl"],
    ),
    "rotary wrap": ("rotary_wrap", {**TARGET, "preview": "preview", "lenient": "lenient", **declared("rotary wrap")}, ["input"]),
    "rotary tube": ("rotary_tube", {"output": "output", **FORMAT, "preview": "preview", **declared("rotary tube")}, []),
    "mix": (
        "mix",
        {
            **TARGET,
            "lenient": "lenient",
            **declared("mix"),
            "palette-png": "- a picture: gweave.main(['mix', '--palette-png', ...])",
            "wizard": "- asks questions on a terminal",
            "predict": "- gweave.predict_colour(ratios, profile)",
            "calibration-card": "- a file: gweave.main(['mix', '--calibration-card', ...])",
            "card-png": "- a picture of the card: gweave.main(['mix', '--calibration-card', ..., '--card-png', ...])",
            "fit": "- a file: gweave.main(['mix', '--fit', ...])",
        },
        ["path"],
    ),
    "preview": ("preview", {"output": "output", "lenient": "lenient", **declared("preview")}, ["path"]),
}

# A transform of the engine's registry without a row above (purge-shift, a new one) maps as its
# declaration says: the shared flags, and each option's flag to its keyword.
for _command in _gweave.transforms():
    MAP.setdefault(_command, (_command.replace("-", "_"), {**TARGET, "lenient": "lenient", **declared(_command)}, ["path"]))

# Keywords with no flag: what a function returns instead of printing.
PYTHON_ONLY = {("preview", "report"): "return the report with the bytes"}


def cli_flags(capfd: pytest.CaptureFixture[str], command: str) -> set:
    capfd.readouterr()
    assert gweave.main([*command.split(), "--help"]) == 0
    text = capfd.readouterr().out
    return set(re.findall(r"^\s+(?:-\w, )?--([a-z0-9-]+)", text, re.MULTILINE))


@pytest.mark.parametrize("command", sorted(MAP))
def test_every_flag_has_its_keyword(capfd: pytest.CaptureFixture[str], command: str) -> None:
    function, table, positional = MAP[command]
    flags = cli_flags(capfd, command) - set(COMMON)
    assert flags == set(table), f"gweave {command}: flags not in the map {flags - set(table)}, gone {set(table) - flags}"
    params = inspect.signature(getattr(gweave, function)).parameters
    mapped = {k for k in table.values() if not k.startswith("-")}
    extra = {p for p in params if (function, p) in PYTHON_ONLY}
    assert set(params) == mapped | set(positional) | extra, (
        f"gweave.{function}: keywords without a flag {set(params) - mapped - set(positional) - extra}, "
        f"flags without a keyword {mapped - set(params)}"
    )
    for flag, keyword in table.items():
        if keyword.startswith("-") or keyword in ("backup", "interweave", "out_dir", "output"):
            continue
        assert keyword == flag.replace("-", "_"), f"--{flag} is {keyword}= in Python"
