"""Prusa binary G-code checked against libbgcode itself (pybgcode, Prusa's reference
implementation), both ways: files libbgcode writes, with every compression and encoding it
offers, read by gweave as the text libbgcode's own converter makes of them; files gweave writes
pass libbgcode's checks and decode to the same text; a transform from .bgcode to .bgcode keeps
the metadata and thumbnails."""

import base64
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

import gweave

pybgcode = pytest.importorskip("pybgcode")
from pybgcode import _bgcode  # noqa: E402  (after the skip)

COMPRESSIONS = ["none", "Deflate", "Heatshrink_11_4", "Heatshrink_12_4"]
ENCODINGS = ["none", "MeatPack", "MeatPackComments"]


def cli(*args: str) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "gweave", *args], capture_output=True)
    assert r.returncode == 0, r.stderr.decode()
    return r


def png(width: int, height: int) -> bytes:
    """A small valid PNG (grey), for a thumbnail."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\x00" + bytes([128]) * width for _ in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def with_thumbnail(src: Path, dst: Path) -> None:
    """A PrusaSlicer file with a thumbnail block after its first line, as PrusaSlicer writes one."""
    data = base64.b64encode(png(16, 12)).decode()
    block = f";\n; thumbnail begin 16x12 {len(data)}\n" + "".join(
        f"; {data[i:i + 78]}\n" for i in range(0, len(data), 78)) + "; thumbnail end\n;\n\n"
    first, rest = src.read_text().split("\n", 1)
    dst.write_text(f"{first}\n\n{block}{rest}")


def to_binary(src: Path, dst: Path, compression: str = "Heatshrink_12_4", encoding: str = "MeatPackComments") -> None:
    cfg = pybgcode.get_config()
    cfg.compression.gcode = getattr(_bgcode.CompressionType, compression)
    cfg.gcode_encoding = getattr(_bgcode.GCodeEncodingType, encoding)
    fin, fout = pybgcode.open(str(src), "r"), pybgcode.open(str(dst), "wb")
    try:
        assert pybgcode.from_ascii_to_binary(fin, fout, cfg) == pybgcode.EResult.Success
    finally:
        pybgcode.close(fout)
        pybgcode.close(fin)


def to_text(src: Path, dst: Path) -> bytes:
    """libbgcode's text of a binary file, checksums verified."""
    fin, fout = pybgcode.open(str(src), "rb"), pybgcode.open(str(dst), "w")
    try:
        assert pybgcode.from_binary_to_ascii(fin, fout, True) == pybgcode.EResult.Success
    finally:
        pybgcode.close(fout)
        pybgcode.close(fin)
    return dst.read_bytes()


def to_text_file(src: Path, dst: Path) -> Path:
    to_text(src, dst)
    return dst


def blocks(path: Path) -> list:
    """Every block's type, each checksum verified by libbgcode."""
    f = pybgcode.open(str(path), "rb")
    try:
        assert _bgcode.is_valid_binary_gcode(f, True) == pybgcode.EResult.Success
        kinds = []
        res, header = pybgcode.get_header(f)
        assert res == pybgcode.EResult.Success
        while True:
            bh = _bgcode.BlockHeader()
            if _bgcode.read_next_block_header(f, header, bh) != pybgcode.EResult.Success:
                break
            assert _bgcode.verify_block_checksum(f, header, bh) == pybgcode.EResult.Success, f"block {len(kinds) + 1}"
            kinds.append(bh.type)
        return kinds
    finally:
        pybgcode.close(f)


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize("compression", COMPRESSIONS)
def test_files_libbgcode_writes_read_as_its_text(data, tmp_path, compression, encoding):
    src = tmp_path / "thumb.gcode"
    with_thumbnail(data / "prusaslicer" / "pr_torus_pva.gcode", src)
    binary = tmp_path / "x.bgcode"
    to_binary(src, binary, compression, encoding)
    reference = to_text(binary, tmp_path / "ref.gcode")
    assert cli("cat", str(binary), "-o", "-").stdout == reference
    assert gweave.stats(binary) == gweave.stats(tmp_path / "ref.gcode")


def test_files_gweave_writes_pass_libbgcode(data, tmp_path):
    src = data / "prusaslicer" / "pr_bunny_3tool_rel.gcode"
    out = tmp_path / "g.bgcode"
    cli("cat", str(src), "-o", str(out))
    assert len(blocks(out)) > 10
    theirs = to_text(out, tmp_path / "theirs.gcode")
    assert cli("cat", str(out), "-o", "-").stdout == theirs
    # Their text is ours, empty lines aside, with the settings block after the G-code.
    lines = [line for line in src.read_bytes().split(b"\n") if line.strip(b" \t") not in (b"", b";")]
    gcode = b"".join(l + b"\n" for l in lines)
    settings = gcode.index(b"; prusaslicer_config = begin")
    assert gcode[:settings] in theirs
    assert theirs.endswith(b"\n" + gcode[settings:] + b"\n")


def test_a_transform_keeps_metadata_and_thumbnails(data, tmp_path):
    src = tmp_path / "thumb.gcode"
    with_thumbnail(data / "prusaslicer" / "pr_torus_pva.gcode", src)
    before, after = tmp_path / "in.bgcode", tmp_path / "out.bgcode"
    to_binary(src, before)
    cli("purge-shift", str(before), "-o", str(after), "--purge", "5")
    assert blocks(after)[-1] == int(_bgcode.EBlockType.GCode)

    def metadata(path: Path) -> dict:
        f = pybgcode.open(str(path), "rb")
        try:
            thumbs = [(t["meta"].format, t["meta"].width, t["meta"].height, bytes(t["bytes"])) for t in pybgcode.read_thumbnails(f)]
            return {kind: pybgcode.read_metadata(f, kind) for kind in ("file", "printer", "print", "slicer")} | {"thumbnails": thumbs}
        finally:
            pybgcode.close(f)

    kept, was = metadata(after), metadata(before)
    # File and slicer metadata and the thumbnails are carried over as they were; the printer and
    # print blocks keep their keys and every value but the figures of the file as written
    # (filament used, weight, cost, times), which the transform rewrites.
    for kind in ("file", "slicer", "thumbnails"):
        assert kept[kind] == was[kind], kind

    def settings(block: dict) -> dict:
        figures = ("used", "weight", "cost", "time")
        return {k: v for k, v in block.items() if not any(f in k for f in figures)}

    for kind in ("printer", "print"):
        assert kept[kind].keys() == was[kind].keys(), kind
        assert settings(kept[kind]) == settings(was[kind]), kind
    assert kept["thumbnails"][0][:3] == (0, 16, 12)
    assert "gcode_flavor" in kept["slicer"]
    # The G-code is purge-shift's: the same as from the text it stands for.
    text_out = tmp_path / "out.gcode"
    cli("purge-shift", str(to_text_file(before, tmp_path / "in.gcode")), "-o", str(text_out), "--purge", "5")
    ours = cli("cat", str(after), "-o", "-").stdout
    assert ours == to_text(after, tmp_path / "after.gcode")

    def non_empty(text: bytes) -> list:
        return [line for line in text.split(b"\n") if line.strip(b" \t") not in (b"", b";")]

    # The run's header is one line in both; in the binary file it follows the file metadata
    # libbgcode writes as the text's first comments, so it is compared apart.
    header = [l for l in non_empty(ours) if l.startswith(b"; gweave ")]
    assert header == [l for l in non_empty(text_out.read_bytes()) if l.startswith(b"; gweave ")]
    assert len(header) == 1
    without = lambda text: [l for l in non_empty(text) if not l.startswith(b"; gweave ")]  # noqa: E731
    assert without(ours) == without(text_out.read_bytes())
    assert non_empty(ours) != non_empty((tmp_path / "in.gcode").read_bytes()), "purge-shift moved no change"


def read_metadata(path: Path) -> dict:
    f = pybgcode.open(str(path), "rb")
    try:
        return {kind: pybgcode.read_metadata(f, kind) for kind in ("file", "printer", "print", "slicer")}
    finally:
        pybgcode.close(f)


def test_a_text_files_metadata_fills_the_printer_and_print_blocks(data, tmp_path):
    """Text to .bgcode: the printer and print blocks carry what PrusaSlicer puts there, the
    settings from the file's settings block and the figures gweave wrote into the footer."""
    src = data / "prusaslicer" / "pr_bunny_3tool_rel.gcode"
    binary, text = tmp_path / "out.bgcode", tmp_path / "out.gcode"
    cli("purge-shift", str(src), "-o", str(binary), "--purge", "5")
    cli("purge-shift", str(src), "-o", str(text), "--purge", "5")
    assert len(blocks(binary)) > 3

    def comments(path: Path) -> dict:
        pairs = [l[2:].split(" = ", 1) for l in path.read_text().splitlines() if l.startswith("; ") and " = " in l]
        return dict(pairs)

    settings, footer = comments(src), comments(text)
    meta = read_metadata(binary)
    for key in ("printer_model", "filament_type", "nozzle_diameter", "bed_temperature", "fill_density",
                "layer_height", "temperature"):
        assert meta["printer"][key] == settings[key], key
    for key in ("filament used [mm]", "estimated printing time (normal mode)"):
        assert meta["printer"][key] == footer[key], key
    for key in ("filament used [mm]", "filament used [cm3]", "total filament used [g]",
                "estimated printing time (normal mode)", "estimated printing time (silent mode)"):
        assert meta["print"][key] == footer[key], key
    assert meta["slicer"]["gcode_flavor"] == settings["gcode_flavor"]


def test_a_pipe_carries_binary_gcode(data, tmp_path):
    """`-o - --format bgcode` through a real shell pipe writes the bytes `-o x.bgcode` writes."""
    src = data / "prusaslicer" / "pr_torus_pva.gcode"
    named, piped = tmp_path / "named.bgcode", tmp_path / "piped.bgcode"
    cli("purge-shift", str(src), "--purge", "5", "-o", str(named))
    gw = f"{sys.executable} -m gweave"
    subprocess.run(f"cat '{src}' | {gw} purge-shift - --purge 5 -o - --format bgcode | cat > '{piped}'",
                   shell=True, check=True)
    assert piped.read_bytes()[:4] == b"GCDE"
    assert len(blocks(piped)) > 3
    assert to_text(piped, tmp_path / "p.gcode") == to_text(named, tmp_path / "n.gcode")
    # gzip through a pipe too, and cat's text back out of it.
    gz = subprocess.run(f"{gw} cat '{src}' -o - --format gz | gzip -dc", shell=True, check=True,
                        capture_output=True).stdout
    assert gz == cli("cat", str(src), "-o", "-").stdout
    # A file's name must agree with --format.
    r = subprocess.run([sys.executable, "-m", "gweave", "cat", str(src), "-o", str(tmp_path / "x.gcode"),
                        "--format", "bgcode"], capture_output=True)
    assert r.returncode != 0
    assert b"is named for text" in r.stderr
