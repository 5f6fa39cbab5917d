//! Small files that claim, or inflate to, enormous sizes: Prusa binary G-code whose metadata
//! blocks inflate to 64 MiB, images whose header says 60 000 x 60 000 pixels. Made here, in
//! memory, as the hostile suite makes all its inputs.

use std::io::Write;

use flate2::write::ZlibEncoder;
use flate2::Compression;

/// Binary G-code block types (libbgcode's specification).
pub const PRINTER_METADATA: u16 = 3;
pub const PRINT_METADATA: u16 = 4;
pub const SLICER_METADATA: u16 = 2;
pub const GCODE: u16 = 1;

/// `data` deflated with zlib's wrapper, as libbgcode stores a compressed block.
fn zlib(data: &[u8]) -> Vec<u8> {
    let mut z = ZlibEncoder::new(Vec::new(), Compression::best());
    z.write_all(data).unwrap();
    z.finish().unwrap()
}

/// One block with its CRC32: `data` deflated when `deflate`, stored as it is otherwise; the
/// encoding parameter 0 (INI metadata, plain G-code).
pub fn block(kind: u16, data: &[u8], deflate: bool) -> Vec<u8> {
    let mut b = kind.to_le_bytes().to_vec();
    let body = if deflate { zlib(data) } else { data.to_vec() };
    b.extend_from_slice(&u16::from(deflate).to_le_bytes());
    b.extend_from_slice(&(data.len() as u32).to_le_bytes());
    if deflate {
        b.extend_from_slice(&(body.len() as u32).to_le_bytes());
    }
    b.extend_from_slice(&0u16.to_le_bytes());
    b.extend_from_slice(&body);
    let crc = crc32fast::hash(&b);
    b.extend_from_slice(&crc.to_le_bytes());
    b
}

/// A binary G-code file: the file header (with CRC32s) and `blocks`, in order.
pub fn bgcode(blocks: &[Vec<u8>]) -> Vec<u8> {
    let mut f = b"GCDE".to_vec();
    f.extend_from_slice(&1u32.to_le_bytes());
    f.extend_from_slice(&1u16.to_le_bytes());
    blocks.iter().for_each(|b| f.extend_from_slice(b));
    f
}

/// A valid small binary G-code file, its printer metadata replaced by `printer` (deflated) and
/// `slicer_blocks` slicer metadata blocks of `slicer` (deflated), then `gcode_blocks` G-code
/// blocks: the first `G1 X1`, the others empty.
pub fn bgcode_with(printer: &[u8], slicer: &[u8], slicer_blocks: usize, gcode_blocks: usize) -> Vec<u8> {
    let mut blocks =
        vec![block(PRINTER_METADATA, printer, true), block(PRINT_METADATA, b"filament used [mm]=1\n", true)];
    blocks.extend((0..slicer_blocks).map(|_| block(SLICER_METADATA, slicer, true)));
    blocks.push(block(GCODE, b"M104 S200\nG1 X1 Y1 F600\n", false));
    let empty = block(GCODE, b"", false);
    let mut file = bgcode(&blocks);
    for _ in 1..gcode_blocks {
        file.extend_from_slice(&empty);
    }
    file
}

/// `n` bytes of `=\n`: a metadata block of `n / 2` empty `key=value` items.
pub fn empty_items(n: usize) -> Vec<u8> {
    b"=\n".repeat(n / 2)
}

/// A PNG chunk: length, type, data, CRC32 of type and data.
fn chunk(kind: &[u8; 4], data: &[u8]) -> Vec<u8> {
    let mut c = (data.len() as u32).to_be_bytes().to_vec();
    c.extend_from_slice(kind);
    c.extend_from_slice(data);
    let mut crc = crc32fast::Hasher::new();
    crc.update(kind);
    crc.update(data);
    c.extend_from_slice(&crc.finalize().to_be_bytes());
    c
}

/// A greyscale PNG of `width` x `height` black pixels at `depth` bits: small on disk (a 60 000
/// x 60 000 1-bit one is about 450 KB), its header saying the whole size.
pub fn png(width: u32, height: u32, depth: u8) -> Vec<u8> {
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[depth, 0, 0, 0, 0]);
    let row = vec![0u8; 1 + (width as usize * depth as usize).div_ceil(8)];
    let mut z = ZlibEncoder::new(Vec::new(), Compression::best());
    for _ in 0..height {
        z.write_all(&row).unwrap();
    }
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IDAT", &z.finish().unwrap()));
    png.extend(chunk(b"IEND", b""));
    png
}

/// A BMP header (no pixels at all) that says `width` x `height` at 24 bits a pixel.
pub fn bmp_header(width: i32, height: i32) -> Vec<u8> {
    let mut b = b"BM".to_vec();
    b.extend_from_slice(&(54u32).to_le_bytes());
    b.extend_from_slice(&[0; 4]);
    b.extend_from_slice(&54u32.to_le_bytes());
    b.extend_from_slice(&40u32.to_le_bytes());
    b.extend_from_slice(&width.to_le_bytes());
    b.extend_from_slice(&height.to_le_bytes());
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&24u16.to_le_bytes());
    b.extend_from_slice(&[0; 24]);
    b
}
