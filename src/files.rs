//! Reading the files raylab is given: only regular files (a pipe or a device as a scene, a
//! mesh or a buffer would block forever or never end), and never more than a cap that says
//! what the file is for, so that a valid-looking name cannot exhaust memory.

use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// The largest scene description read (RON text, an MTL file).
pub const MAX_TEXT: u64 = 64 << 20;
/// The largest mesh file, glTF buffer or image read.
pub const MAX_BINARY: u64 = 4 << 30;

/// Opens `path` for reading if it is a regular file of at most `max` bytes; the error says
/// why not, for the caller to put after the file's name.
pub fn open_capped(path: &Path, max: u64) -> std::io::Result<(std::fs::File, u64)> {
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(Error::new(ErrorKind::InvalidInput, "it is a folder"));
    }
    if !meta.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            "it is not a regular file (a pipe, a device or a socket)",
        ));
    }
    if meta.len() > max {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "it is {} bytes, more than the {} this kind of file may have",
                meta.len(),
                max
            ),
        ));
    }
    Ok((std::fs::File::open(path)?, meta.len()))
}

/// Reads a regular file of at most `max` bytes whole (a file that grows while it is read is
/// cut at `max` and refused).
pub fn read_capped(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    let (file, len) = open_capped(path, max)?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("it grew beyond {max} bytes while being read"),
        ));
    }
    Ok(bytes)
}

/// [`read_capped`] as UTF-8 text (a byte-order mark at the start is skipped).
pub fn read_text_capped(path: &Path, max: u64) -> std::io::Result<String> {
    let bytes = read_capped(path, max)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        // Where, as an editor shows it.
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = valid.iter().filter(|b| **b == b'\n').count() + 1;
        let start = valid.iter().rposition(|b| *b == b'\n').map_or(0, |i| i + 1);
        let column = String::from_utf8_lossy(&valid[start..]).chars().count() + 1;
        Error::new(
            ErrorKind::InvalidData,
            format!("it is not UTF-8 text (line {line}, column {column})"),
        )
    })?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_sizes_refuses_odd_files_and_skips_a_bom() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        std::fs::write(&f, "\u{feff}hello").unwrap();
        assert_eq!(read_text_capped(&f, 100).unwrap(), "hello");
        std::fs::write(&f, b"ab\ncd\xffe").unwrap();
        let e = read_text_capped(&f, 100).unwrap_err().to_string();
        assert!(e.contains("line 2, column 3"), "{e}");
        let e = read_capped(&f, 3).unwrap_err().to_string();
        assert!(e.contains("more than the 3"), "{e}");
        assert!(read_capped(dir.path(), 100)
            .unwrap_err()
            .to_string()
            .contains("folder"));
        #[cfg(unix)]
        {
            let e = read_capped(Path::new("/dev/zero"), 100)
                .unwrap_err()
                .to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
    }
}
