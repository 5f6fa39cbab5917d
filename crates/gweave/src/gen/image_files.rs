//! Layer image files: a directory or a file-name glob, sorted naturally (`l2 < l10`).

use std::cmp::Ordering;
use std::path::{Path, PathBuf};

use super::bitmap::BitmapError;

fn io_err(path: &Path, source: std::io::Error) -> BitmapError {
    BitmapError::Io { path: path.to_path_buf(), source }
}

/// Compares names so that digit runs sort by value: `l2.png < l10.png`.
pub(crate) fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let da = a.iter().take_while(|c| c.is_ascii_digit()).count();
                let db = b.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (trim_zeros(&a[..da]), trim_zeros(&b[..db]));
                let ord = na.len().cmp(&nb.len()).then(na.cmp(nb)).then(da.cmp(&db));
                if ord != Ordering::Equal {
                    return ord;
                }
                a = &a[da..];
                b = &b[db..];
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

fn trim_zeros(d: &[u8]) -> &[u8] {
    let z = d.iter().take_while(|&&c| c == b'0').count();
    &d[z..]
}

/// Shell-style match of a file name against a pattern with `*` and `?`.
fn glob_match(pattern: &[u8], name: &[u8]) -> bool {
    match pattern.split_first() {
        None => name.is_empty(),
        Some((b'*', rest)) => (0..=name.len()).any(|i| glob_match(rest, &name[i..])),
        Some((b'?', rest)) => !name.is_empty() && glob_match(rest, &name[1..]),
        Some((c, rest)) => name.first() == Some(c) && glob_match(rest, &name[1..]),
    }
}

/// Lists layer images: a directory (all `.bmp`/`.png`/`.tif`/`.tiff` files in it) or a file-name glob such as
/// `layers/slice_*.png` (wildcards in the last path component only), sorted naturally.
pub(crate) fn list_images(spec: &Path) -> Result<Vec<PathBuf>, BitmapError> {
    let (dir, pattern) = if spec.is_dir() {
        (spec.to_path_buf(), None)
    } else {
        let dir = spec.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let name = spec.file_name().map(|n| n.to_string_lossy().into_owned());
        (dir.to_path_buf(), name)
    };
    let entries = std::fs::read_dir(&dir).map_err(|e| io_err(&dir, e))?;
    let mut found: Vec<(String, PathBuf)> = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| io_err(&dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let keep = match &pattern {
            Some(p) => glob_match(p.as_bytes(), name.as_bytes()),
            None => {
                let lower = name.to_ascii_lowercase();
                [".png", ".bmp", ".tif", ".tiff"].iter().any(|ext| lower.ends_with(ext))
            }
        };
        if keep && entry.path().is_file() {
            found.push((name, entry.path()));
        }
    }
    if found.is_empty() {
        return Err(BitmapError::NoImages(spec.to_path_buf()));
    }
    found.sort_by(|a, b| natural_cmp(&a.0, &b.0));
    Ok(found.into_iter().map(|(_, p)| p).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_sort_and_glob() {
        let mut v = vec!["l10.png", "l2.png", "l1.png", "l02.png", "a.png"];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(v, ["a.png", "l1.png", "l2.png", "l02.png", "l10.png"]);
        assert!(glob_match(b"l*.png", b"l10.png"));
        assert!(!glob_match(b"l*.png", b"l10.bmp"));
        assert!(glob_match(b"l?.png", b"l1.png"));
        let dir = tempfile::tempdir().unwrap();
        for n in ["s10.png", "s9.png", "x.txt"] {
            std::fs::write(dir.path().join(n), b"").unwrap();
        }
        let names = |v: Vec<PathBuf>| -> Vec<String> {
            v.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect()
        };
        assert_eq!(names(list_images(dir.path()).unwrap()), ["s9.png", "s10.png"]);
        assert_eq!(names(list_images(&dir.path().join("s1*")).unwrap()), ["s10.png"]);
        assert!(matches!(list_images(&dir.path().join("q*")), Err(BitmapError::NoImages(_))));
    }
}
