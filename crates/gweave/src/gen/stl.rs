//! STL meshes (binary and ASCII), read into memory as a triangle soup.
//!
//! Binary STL: an 80-byte header, a little-endian `u32` triangle count, then 50 bytes per
//! triangle (normal, three vertices as `f32` xyz, a `u16` attribute). ASCII STL:
//! `solid ... facet normal .. outer loop vertex x y z (x3) endloop endfacet ... endsolid`.
//! A file is taken as binary when its length is exactly `84 + 50 n` (some binary exporters
//! start the header with `solid`), otherwise as ASCII if it starts with `solid`.
//! Normals are ignored: the slicer uses even-odd filling, which does not need them.

use std::io::Write;
use std::path::Path;

use thiserror::Error;

/// Errors from reading STL.
#[derive(Debug, Error)]
pub enum StlError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A binary STL shorter than its triangle count says.
    #[error("binary STL truncated: {len} bytes for {count} triangles")]
    Truncated {
        /// The file's length in bytes.
        len: usize,
        /// The triangle count in its header.
        count: u64,
    },
    /// An ASCII STL line cannot be read.
    #[error("ASCII STL line {line}: {message}")]
    Parse {
        /// The line number, from 1.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// Neither a binary nor an ASCII STL.
    #[error("not an STL file")]
    NotStl,
}

/// A triangle as three vertices in mm.
pub type Triangle = [[f32; 3]; 3];

/// A triangle soup.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// The triangles, in file order.
    pub triangles: Vec<Triangle>,
}

impl Mesh {
    /// Axis-aligned bounds `(min, max)`, or None for an empty mesh.
    pub fn bounds(&self) -> Option<([f64; 3], [f64; 3])> {
        let mut it = self.triangles.iter().flatten();
        let first = it.next()?.map(f64::from);
        Some(it.fold((first, first), |(mut lo, mut hi), v| {
            for a in 0..3 {
                lo[a] = lo[a].min(f64::from(v[a]));
                hi[a] = hi[a].max(f64::from(v[a]));
            }
            (lo, hi)
        }))
    }

    /// Writes binary STL (zero normals; readers recompute them from the winding).
    pub fn write_binary<W: Write>(&self, mut out: W) -> std::io::Result<()> {
        let mut header = [0u8; 80];
        header[..13].copy_from_slice(b"gweave binary");
        out.write_all(&header)?;
        out.write_all(&(self.triangles.len() as u32).to_le_bytes())?;
        for t in &self.triangles {
            out.write_all(&[0u8; 12])?;
            for v in t {
                for c in v {
                    out.write_all(&c.to_le_bytes())?;
                }
            }
            out.write_all(&[0, 0])?;
        }
        Ok(())
    }

    /// Writes ASCII STL.
    pub fn write_ascii<W: Write>(&self, mut out: W) -> std::io::Result<()> {
        writeln!(out, "solid gweave")?;
        for t in &self.triangles {
            writeln!(out, "  facet normal 0 0 0\n    outer loop")?;
            for v in t {
                writeln!(out, "      vertex {} {} {}", v[0], v[1], v[2])?;
            }
            writeln!(out, "    endloop\n  endfacet")?;
        }
        writeln!(out, "endsolid gweave")
    }
}

/// Reads an STL file.
pub fn read_stl(path: &Path) -> Result<Mesh, StlError> {
    let data = std::fs::read(path).map_err(|source| StlError::Io { path: path.to_path_buf(), source })?;
    parse_stl(&data)
}

/// Parses STL bytes, binary or ASCII.
pub(crate) fn parse_stl(data: &[u8]) -> Result<Mesh, StlError> {
    if data.len() >= 84 {
        let count = u64::from(u32::from_le_bytes([data[80], data[81], data[82], data[83]]));
        if data.len() as u64 == 84 + 50 * count {
            return Ok(parse_binary(&data[84..]));
        }
    }
    let text_start = data.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(0);
    if data[text_start..].starts_with(b"solid") {
        return parse_ascii(data);
    }
    if data.len() >= 84 {
        let count = u64::from(u32::from_le_bytes([data[80], data[81], data[82], data[83]]));
        return Err(StlError::Truncated { len: data.len(), count });
    }
    Err(StlError::NotStl)
}

fn parse_binary(body: &[u8]) -> Mesh {
    let f = |b: &[u8], i: usize| f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    let triangles = body
        .chunks_exact(50)
        .map(|rec| {
            let mut t = [[0f32; 3]; 3];
            for (v, vert) in t.iter_mut().enumerate() {
                for (a, c) in vert.iter_mut().enumerate() {
                    *c = f(rec, 12 + 12 * v + 4 * a);
                }
            }
            t
        })
        .collect();
    Mesh { triangles }
}

fn parse_ascii(data: &[u8]) -> Result<Mesh, StlError> {
    let text = String::from_utf8_lossy(data);
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut triangles = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("vertex") => {
                let mut v = [0f32; 3];
                for c in &mut v {
                    *c = words.next().and_then(|w| w.parse().ok()).ok_or_else(|| StlError::Parse {
                        line: n + 1,
                        message: "vertex needs three numbers".into(),
                    })?;
                }
                vertices.push(v);
            }
            Some("endloop") => {
                if vertices.len() != 3 {
                    return Err(StlError::Parse {
                        line: n + 1,
                        message: format!("loop with {} vertices", vertices.len()),
                    });
                }
                triangles.push([vertices[0], vertices[1], vertices[2]]);
                vertices.clear();
            }
            _ => {}
        }
    }
    Ok(Mesh { triangles })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri_mesh() -> Mesh {
        Mesh {
            triangles: vec![
                [[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0, 2.0, 3.25]],
                [[-1.0, 0.0, 0.0], [1.0, 4.0, 0.0], [0.0, 0.5, -2.0]],
            ],
        }
    }

    #[test]
    fn binary_and_ascii_roundtrip() {
        let m = tri_mesh();
        let mut bin = Vec::new();
        m.write_binary(&mut bin).unwrap();
        assert_eq!(bin.len(), 84 + 100);
        assert_eq!(parse_stl(&bin).unwrap(), m);
        let mut ascii = Vec::new();
        m.write_ascii(&mut ascii).unwrap();
        assert_eq!(parse_stl(&ascii).unwrap(), m);
        assert_eq!(m.bounds().unwrap(), ([-1.0, 0.0, -2.0], [1.5, 4.0, 3.25]));
        // A binary file whose header starts with "solid" is still binary.
        bin[..5].copy_from_slice(b"solid");
        assert_eq!(parse_stl(&bin).unwrap(), m);
    }

    #[test]
    fn bad_input() {
        let m = tri_mesh();
        let mut bin = Vec::new();
        m.write_binary(&mut bin).unwrap();
        bin.truncate(120);
        assert!(matches!(parse_stl(&bin), Err(StlError::Truncated { count: 2, .. })));
        assert!(matches!(
            parse_stl(b"solid x\nfacet\nouter loop\nvertex 1 2\n"),
            Err(StlError::Parse { line: 4, .. })
        ));
        assert!(matches!(
            parse_stl(b"solid x\nouter loop\nvertex 1 2 3\nendloop\n"),
            Err(StlError::Parse { line: 4, .. })
        ));
        assert!(matches!(parse_stl(b"hello"), Err(StlError::NotStl)));
        assert_eq!(Mesh::default().bounds(), None);
    }
}
