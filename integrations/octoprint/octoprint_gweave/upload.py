"""Upload processing (the ``octoprint.filemanager.preprocessor`` hook).

``plugins.gweave.on_upload`` holds a gweave transform and its arguments, as typed after
``gweave`` on a command line without the input and output: ``purge-shift --purge-mm 2.5`` or
``mix -c /path/mix.toml``. Each uploaded G-code file is written by
``gweave <command> <upload> -o <new> <arguments>`` and the new file is what OctoPrint stores, so it
equals what the CLI writes for the same arguments, byte for byte.

When gweave refuses (a bad argument, a malformed line, a profile that does not parse), the upload
is stored as it came, and the reason is logged, sent to the web interface and kept in the file's
metadata (``gweave.upload``).
"""

from __future__ import annotations

import os
import shlex
import shutil
import tempfile
from typing import List, Optional, Tuple

from octoprint.filemanager.util import DiskFileWrapper

from . import runner

# The commands that read one G-code file and write one: what an upload can go through.
TRANSFORMS = ("mix", "purge-shift", "cat")
# The plugin names the input and the output itself.
OWN_FLAGS = ("-o", "--output", "--in-place", "-i", "--no-backup", "--wizard")


class UploadArgsError(ValueError):
    """``on_upload`` is not a transform the plugin can run."""


def parse(on_upload: str) -> Optional[List[str]]:
    """``on_upload`` as an argument list, or ``None`` when it is empty (uploads stored as they come)."""
    argv = shlex.split(on_upload or "")
    if not argv:
        return None
    if argv[0] not in TRANSFORMS:
        raise UploadArgsError(f"on_upload must start with one of {', '.join(TRANSFORMS)}, not {argv[0]!r}")
    own = [a for a in argv[1:] if a.split("=", 1)[0] in OWN_FLAGS]
    if own:
        raise UploadArgsError(f"on_upload must not name the input or output ({' '.join(own)}): the plugin does")
    return argv


def process(file_object, argv: List[str], *, timeout_s: float) -> Tuple[object, Optional[str]]:
    """Runs the transform on an upload: ``(what to store, None)`` or ``(the upload as it came, why)``.

    Whatever is returned is moved into storage; the temporary folder goes with it.
    """
    tmp = tempfile.mkdtemp(prefix="gweave-upload-")
    try:
        src = getattr(file_object, "path", None)
        if isinstance(file_object, DiskFileWrapper) and src and os.path.isfile(src):
            original = file_object
        else:
            # A stream can be read once: keep it on disk, it is what gets stored on failure.
            src = os.path.join(tmp, "upload.gcode")
            with file_object.stream() as s, open(src, "wb") as f:
                shutil.copyfileobj(s, f)
            original = CleaningDiskFileWrapper(file_object.filename, src, tmp)
        dst = os.path.join(tmp, "processed.gcode")
        try:
            runner.transform(runner.Job(), argv, src, dst, timeout_s=timeout_s)
        except runner.GweaveError as e:
            if original is file_object:
                shutil.rmtree(tmp, ignore_errors=True)
            return original, str(e)
        return CleaningDiskFileWrapper(file_object.filename, dst, tmp), None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


class CleaningDiskFileWrapper(DiskFileWrapper):
    """A processed upload: moved into storage, then its temporary folder removed."""

    def __init__(self, filename: str, path: str, folder: str) -> None:
        DiskFileWrapper.__init__(self, filename, path, move=True)
        self._folder = folder

    def save(self, path, permissions=None):
        try:
            DiskFileWrapper.save(self, path, permissions=permissions)
        finally:
            shutil.rmtree(self._folder, ignore_errors=True)
