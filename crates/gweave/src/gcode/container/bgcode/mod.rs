//! Prusa binary G-code (`.bgcode`), as libbgcode's specification defines it
//! (doc/specifications.md in prusa3d/libbgcode): a 10-byte file header (`GCDE`, version 1, the
//! checksum type), then blocks in a fixed order: file metadata (optional), printer metadata,
//! thumbnails (optional), print metadata, slicer metadata, G-code. Each block is a header (type,
//! compression, sizes), parameters (the encoding, or a thumbnail's format and size), the data,
//! and a CRC32 of all three when the file header asks for one. Integers are little-endian.
//!
//! gweave reads such a file as the text libbgcode's `from_binary_to_ascii` makes of it: the
//! metadata as `; key = value` comments and the thumbnails as PrusaSlicer's base64 comment
//! blocks before the G-code, the print and slicer metadata after it (`text`). So `stats`
//! finds the slicer's figures and flavour where it finds them in a text file, and
//! `gweave cat x.bgcode -o x.gcode` writes what libbgcode's converter writes.
//!
//! Blocks are read and written one at a time ([`read`], `write`); a block may hold at most
//! [`MAX_BLOCK`] bytes, so memory stays bounded whatever the file's size.

pub mod read;
pub(crate) mod summary;
pub(crate) mod text;
pub(crate) mod write;

use std::io::{self, Read};

/// The file's first four bytes.
pub const MAGIC: &[u8; 4] = b"GCDE";
/// The version of the specification this module implements.
pub const VERSION: u32 = 1;
/// The largest block (stored or decoded) read: libbgcode and PrusaSlicer write G-code blocks of
/// at most 64 KiB and thumbnails of a few hundred KiB; a larger size is a damaged header or a
/// bomb (one G-code block of 64 MiB, 98 KB deflated, took 143 MB: stored, decoded and handed
/// on at once).
pub const MAX_BLOCK: u32 = 8 << 20;
/// The most bytes every block before the G-code may hold together (metadata and thumbnails,
/// stored or decoded): they are kept for the whole run (rendered as text before and after the
/// G-code, carried into a binary output), so a 65 KB file whose printer metadata inflates to
/// 64 MiB must not be taken in. PrusaSlicer's settings are about 60 KiB, its thumbnails a few
/// hundred; a block that would pass the limit is refused from its header, before it is read.
pub const MAX_PREAMBLE: u64 = 8 << 20;
/// The most `key=value` items one metadata block may hold (PrusaSlicer's settings have about
/// 700); each takes about 50 bytes of memory beyond its text, so 4 MiB of `=\n` lines would
/// otherwise take 100 MB.
pub const MAX_METADATA_ITEMS: usize = 10_000;
/// The most thumbnails read (PrusaSlicer writes one per size asked for, two to four).
pub const MAX_THUMBNAILS: usize = 16;
/// The most slicer metadata blocks read: the specification has one, libbgcode reads an INI and
/// a JSON one.
pub const MAX_SLICER_BLOCKS: usize = 2;

/// Block types (the header's first field).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Type 0: the file's metadata (producer).
    FileMetadata,
    /// Type 1: G-code text.
    GCode,
    /// Type 2: the slicer's settings.
    SlicerMetadata,
    /// Type 3: the printer's metadata (what the printer shows).
    PrinterMetadata,
    /// Type 4: the print's metadata (time, filament).
    PrintMetadata,
    /// Type 5: a thumbnail image.
    Thumbnail,
}

impl Kind {
    fn from_u16(v: u16) -> Option<Kind> {
        Some(match v {
            0 => Kind::FileMetadata,
            1 => Kind::GCode,
            2 => Kind::SlicerMetadata,
            3 => Kind::PrinterMetadata,
            4 => Kind::PrintMetadata,
            5 => Kind::Thumbnail,
            _ => return None,
        })
    }

    fn code(self) -> u16 {
        match self {
            Kind::FileMetadata => 0,
            Kind::GCode => 1,
            Kind::SlicerMetadata => 2,
            Kind::PrinterMetadata => 3,
            Kind::PrintMetadata => 4,
            Kind::Thumbnail => 5,
        }
    }

    /// The block type as messages name it.
    pub fn name(self) -> &'static str {
        match self {
            Kind::FileMetadata => "file metadata",
            Kind::GCode => "G-code",
            Kind::SlicerMetadata => "slicer metadata",
            Kind::PrinterMetadata => "printer metadata",
            Kind::PrintMetadata => "print metadata",
            Kind::Thumbnail => "thumbnail",
        }
    }

    /// Bytes of parameters after the header: a thumbnail's format, width and height, every
    /// other block's encoding.
    fn params_len(self) -> usize {
        if self == Kind::Thumbnail {
            6
        } else {
            2
        }
    }
}

/// Block compressions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Stored as is.
    None,
    /// zlib's deflate, with its zlib wrapper (libbgcode calls `deflateInit`).
    Deflate,
    /// Heatshrink with window 11 and lookahead 4 bits.
    Heatshrink11,
    /// Heatshrink with window 12 and lookahead 4 bits.
    Heatshrink12,
}

impl Compression {
    fn from_u16(v: u16) -> Option<Compression> {
        Some(match v {
            0 => Compression::None,
            1 => Compression::Deflate,
            2 => Compression::Heatshrink11,
            3 => Compression::Heatshrink12,
            _ => return None,
        })
    }

    fn code(self) -> u16 {
        match self {
            Compression::None => 0,
            Compression::Deflate => 1,
            Compression::Heatshrink11 => 2,
            Compression::Heatshrink12 => 3,
        }
    }
}

/// A block's header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// The block type.
    pub kind: Kind,
    /// How the data is compressed.
    pub compression: Compression,
    /// Size of the data uncompressed, bytes.
    pub uncompressed: u32,
    /// The stored size (the uncompressed size when not compressed).
    pub stored: u32,
}

impl Header {
    /// The header's bytes: 8, or 12 with a compressed size.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(12);
        b.extend_from_slice(&self.kind.code().to_le_bytes());
        b.extend_from_slice(&self.compression.code().to_le_bytes());
        b.extend_from_slice(&self.uncompressed.to_le_bytes());
        if self.compression != Compression::None {
            b.extend_from_slice(&self.stored.to_le_bytes());
        }
        b
    }
}

/// One block as stored: header, parameters and data, ready to be copied into another file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Block {
    /// The block's header.
    pub header: Header,
    /// The parameters after the header (encoding, or a thumbnail's format and size).
    pub params: Vec<u8>,
    /// The data as stored (compressed when the header says so).
    pub data: Vec<u8>,
}

impl Block {
    /// A block of `data` stored uncompressed.
    pub fn plain(kind: Kind, params: Vec<u8>, data: Vec<u8>) -> Block {
        let n = data.len() as u32;
        Block {
            header: Header { kind, compression: Compression::None, uncompressed: n, stored: n },
            params,
            data,
        }
    }

    /// The block's bytes, with its CRC32 when `checksum`.
    pub fn to_bytes(&self, checksum: bool) -> Vec<u8> {
        let mut b = self.header.to_bytes();
        b.extend_from_slice(&self.params);
        b.extend_from_slice(&self.data);
        if checksum {
            let crc = crc32fast::hash(&b);
            b.extend_from_slice(&crc.to_le_bytes());
        }
        b
    }

    /// The encoding parameter of a metadata or G-code block.
    pub fn encoding(&self) -> u16 {
        u16::from_le_bytes([self.params[0], self.params[1]])
    }
}

/// Metadata: `key=value` lines (libbgcode's INI encoding, 0), or one JSON text (encoding 1,
/// PrusaSlicer's newer slicer settings) with an empty key.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Metadata {
    /// JSON text (encoding 1) rather than `key=value` lines.
    pub json: bool,
    /// The `key=value` pairs in order (one pair with an empty key for JSON).
    pub items: Vec<(String, String)>,
}

impl Metadata {
    /// Decodes a metadata block's data. Lines without `=` are skipped; more than
    /// [`MAX_METADATA_ITEMS`] items are refused (counted before any is kept).
    pub fn parse(data: &[u8], encoding: u16) -> io::Result<Metadata> {
        let text = String::from_utf8_lossy(data);
        match encoding {
            0 => {
                let pairs = || text.split('\n').filter_map(|l| l.split_once('='));
                let count = pairs().take(MAX_METADATA_ITEMS + 1).count();
                if count > MAX_METADATA_ITEMS {
                    return Err(invalid(format!(
                        "more than {MAX_METADATA_ITEMS} key=value items: not metadata a slicer writes"
                    )));
                }
                let items = pairs().map(|(k, v)| (k.to_owned(), v.to_owned())).collect();
                Ok(Metadata { json: false, items })
            }
            1 => Ok(Metadata { json: true, items: vec![(String::new(), text.into_owned())] }),
            e => Err(invalid(format!("unknown metadata encoding {e}"))),
        }
    }

    /// The block data for these items.
    pub fn encode(&self) -> Vec<u8> {
        if self.json {
            return self.items.first().map(|(_, v)| v.as_bytes().to_vec()).unwrap_or_default();
        }
        self.items.iter().flat_map(|(k, v)| [k.as_bytes(), b"=", v.as_bytes(), b"\n"].concat()).collect()
    }

    /// The value of `key`, if present.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.items.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// A metadata block of these items, uncompressed, INI or JSON.
    pub fn to_block(&self, kind: Kind) -> Block {
        Block::plain(kind, u16::from(self.json).to_le_bytes().to_vec(), self.encode())
    }
}

/// A thumbnail: its block as stored (copied as it is) and what its parameters say.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Thumbnail {
    /// The block as stored.
    pub block: Block,
    /// 0 PNG, 1 JPG, 2 QOI.
    pub format: u16,
    /// Width, px.
    pub width: u16,
    /// Height, px.
    pub height: u16,
}

/// Everything before the first G-code block.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Preamble {
    /// Whether the blocks carry CRC32 checksums.
    pub checksum: bool,
    /// The file metadata block (producer), if any.
    pub file: Option<Metadata>,
    /// The printer metadata block.
    pub printer: Metadata,
    /// The thumbnails, in file order.
    pub thumbnails: Vec<Thumbnail>,
    /// The print metadata block.
    pub print: Metadata,
    /// The slicer metadata blocks (libbgcode reads up to two: INI and JSON).
    pub slicer: Vec<Metadata>,
}

/// The 10-byte file header.
pub fn file_header(checksum: bool) -> [u8; 10] {
    let mut h = [0u8; 10];
    h[..4].copy_from_slice(MAGIC);
    h[4..8].copy_from_slice(&VERSION.to_le_bytes());
    h[8..].copy_from_slice(&u16::from(checksum).to_le_bytes());
    h
}

fn invalid(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, message)
}

/// Fills `buf` from `r`; returns how many bytes came before the end of the input.
fn read_full(r: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}
