# gweave as a Cura post-processing script (Extensions > Post Processing > Modify G-Code > gweave).
#
# Install: copy this file into Cura's `scripts` folder (Help > Show Configuration Folder, then
# `scripts/`; create it if missing) and restart Cura. It needs the gweave Python package in the
# Python that runs Cura, from a checkout of gweave (`pip install ./crates/gweave-py`: the `gweave`
# package on PyPI is not ours, docs/integrations.md); when Cura's own Python cannot import it
# (the AppImage), the `gweave` command on PATH is run instead.
#
# Cura hands a post-processing script the G-code as a list of strings (the header, the start
# G-code, one string per layer, the end G-code) and writes their concatenation. This script
# writes that concatenation to a temporary file, runs `gweave mix` or `gweave purge-shift` on it
# exactly as the command line does, and cuts the result back into the same pieces: each piece
# starts again at its own first line (`;LAYER:12`), which gweave copies byte for byte. So the
# saved file is what the CLI writes on Cura's file, and scripts after this one still find one
# string per layer.

import os
import shutil
import subprocess
import tempfile
from typing import List

from ..Script import Script


class Gweave(Script):
    def getSettingDataString(self) -> str:
        return """{
            "name": "gweave (mixing hotend)",
            "key": "Gweave",
            "metadata": {},
            "version": 2,
            "settings": {
                "mode": {
                    "label": "Mode",
                    "description": "purge-shift: move each tool change earlier by the purge, so the old colour is purged inside the part (gweave purge-shift). mix: define mixes as virtual tools and change them as a mix profile says (gweave mix).",
                    "type": "enum",
                    "options": {"purge-shift": "Purge-shift", "mix": "Mix (profile)"},
                    "default_value": "purge-shift"
                },
                "purge_mm": {
                    "label": "Purge",
                    "description": "Filament each tool change is moved earlier by (gweave purge-shift --purge-mm).",
                    "type": "float",
                    "unit": "mm",
                    "default_value": 2.5,
                    "minimum_value": "0",
                    "enabled": "mode == 'purge-shift'"
                },
                "mix_profile": {
                    "label": "Mix profile",
                    "description": "Path of a gweave mix profile (TOML) on this computer (gweave mix -c).",
                    "type": "str",
                    "default_value": "",
                    "enabled": "mode == 'mix'"
                }
            }
        }"""

    def execute(self, data: List[str]) -> List[str]:
        mode = self.getSettingValueByKey("mode")
        if mode == "mix":
            value = (self.getSettingValueByKey("mix_profile") or "").strip()
            if not value:
                raise ValueError("gweave: set the mix profile (a TOML file) in the script's settings")
        else:
            value = float(self.getSettingValueByKey("purge_mm"))
        tmp = tempfile.mkdtemp(prefix="gweave-cura-")
        try:
            src, dst = os.path.join(tmp, "cura.gcode"), os.path.join(tmp, "gweave.gcode")
            with open(src, "w", encoding="utf-8", newline="") as f:
                f.writelines(data)
            run(mode, value, src, dst)
            with open(dst, encoding="utf-8", newline="") as f:
                out = f.read()
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return split_like(out, data)


def run(mode: str, value, src: str, dst: str) -> None:
    """``gweave purge-shift SRC -o DST --purge-mm MM`` or ``gweave mix SRC -o DST -c PROFILE``.

    Through the Python package (its errors are exceptions with gweave's message, which Cura logs),
    or the ``gweave`` command on PATH when Cura's Python cannot import the package.
    """
    try:
        import gweave
    except ImportError:
        exe = shutil.which("gweave")
        if exe is None:
            raise RuntimeError("gweave: neither the gweave Python package nor the gweave command is installed")
        args = ["mix", src, "-o", dst, "-c", value] if mode == "mix" else ["purge-shift", src, "-o", dst, "--purge-mm", repr(value)]
        done = subprocess.run([exe, *args], capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(done.stderr.strip())
        return
    if mode == "mix":
        gweave.mix(src, dst, config=value)
    else:
        gweave.purge_shift(src, dst, purge_mm=value)


def split_like(text: str, pieces: List[str]) -> List[str]:
    """``text`` cut where each of ``pieces`` after the first begins (at its first line).

    A piece whose first line is not found further on (a transform changed it) stays joined to the
    one before: the concatenation is always ``text``.
    """
    out: List[str] = []
    start = 0
    for piece in pieces[1:]:
        first = piece.split("\n", 1)[0]
        if not first:
            continue
        at = _line_at(text, first + "\n", start) if "\n" in piece else -1
        if at < 0:
            continue
        out.append(text[start:at])
        start = at
    out.append(text[start:])
    return out


def _line_at(text: str, line: str, start: int) -> int:
    """Offset of ``line`` as a whole line in ``text`` at or after ``start``, or -1."""
    at = start
    while True:
        at = text.find(line, at)
        if at < 0 or at == 0 or text[at - 1] == "\n":
            return at
        at += 1
