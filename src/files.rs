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

/// Reads a regular file of at most `max` bytes whole, if it fits in the memory this process
/// may still allocate (a file that grows while it is read is cut at `max` and refused).
pub fn read_capped(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    let (file, len) = open_capped(path, max)?;
    if let Some((room, what)) = crate::system::memory_limit() {
        if len > room {
            return Err(Error::new(
                ErrorKind::InvalidInput,
                format!("it is {len} bytes, more than the {room} bytes of memory {what}"),
            ));
        }
    }
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

/// The largest image side read (a 32k x 16k environment map is the largest in common use).
pub const MAX_IMAGE_SIDE: u32 = 65_536;

/// The `image` crate's limits for decoding an image file: at most [`MAX_IMAGE_SIDE`] a side,
/// and no allocation beyond half the memory this process may still use (checked from the
/// header, before the pixels are allocated).
pub fn image_limits() -> image::Limits {
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    let room = crate::system::memory_limit().map_or(u64::MAX, |(room, _)| room / 2);
    limits.max_alloc = Some(room.min(MAX_BINARY));
    limits
}

/// The longest line a text format may have (an OBJ, an MTL file).
pub const MAX_LINE: usize = 1 << 20;

/// A reader of text lines that fails on a line longer than [`MAX_LINE`], so that a line
/// parser never gathers a whole binary file (or `/dev/zero`) into one string.
pub struct LineCapped<R> {
    inner: R,
    /// Bytes consumed since the last newline.
    run: usize,
}

impl<R: std::io::BufRead> LineCapped<R> {
    pub fn new(inner: R) -> Self {
        LineCapped { inner, run: 0 }
    }
}

impl<R: std::io::BufRead> Read for LineCapped<R> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let available = std::io::BufRead::fill_buf(self)?;
        let n = available.len().min(out.len());
        out[..n].copy_from_slice(&available[..n]);
        std::io::BufRead::consume(self, n);
        Ok(n)
    }
}

impl<R: std::io::BufRead> std::io::BufRead for LineCapped<R> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.run > MAX_LINE {
            return Err(Error::new(
                ErrorKind::InvalidData,
                format!("it has a line longer than {MAX_LINE} bytes (is it a text file?)"),
            ));
        }
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        if let Ok(buf) = self.inner.fill_buf() {
            let taken = &buf[..amt.min(buf.len())];
            self.run = match taken.iter().rposition(|b| *b == b'\n') {
                Some(i) => taken.len() - i - 1,
                None => self.run + taken.len(),
            };
        }
        self.inner.consume(amt);
    }
}

/// [`read_capped`], uncompressed if it is gzip-compressed (`scene.pbrt.gz`, `mesh.ply.gz`):
/// at most `max` bytes of content, and no more than half the memory this process may still
/// use (a small file can hold gigabytes of zeros).
pub fn read_uncompressed(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    let bytes = read_capped(path, max)?;
    if !bytes.starts_with(&[0x1f, 0x8b]) {
        return Ok(bytes);
    }
    let room = crate::system::memory_limit().map_or(u64::MAX, |(room, _)| room / 2);
    let cap = max.min(room);
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(&bytes[..])
        .take(cap + 1)
        .read_to_end(&mut out)
        .map_err(|e| {
            Error::new(
                ErrorKind::InvalidData,
                format!("it is gzip-compressed and cannot be uncompressed ({e})"),
            )
        })?;
    if out.len() as u64 > cap {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!("it is gzip-compressed and holds more than {cap} bytes"),
        ));
    }
    Ok(out)
}

/// [`read_uncompressed`] as UTF-8 text (a byte-order mark at the start is skipped).
pub fn read_text_capped(path: &Path, max: u64) -> std::io::Result<String> {
    let bytes = read_uncompressed(path, max)?;
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
        // A long line is an error, not a string of the whole file.
        use std::io::BufRead;
        let long = vec![b'x'; MAX_LINE + 10];
        let mut lines = LineCapped::new(&long[..]).lines();
        let e = lines.next().unwrap().unwrap_err().to_string();
        assert!(e.contains("longer than"), "{e}");
        let text = b"a\nbb\n";
        let lines: Vec<String> = LineCapped::new(&text[..])
            .lines()
            .map(|l| l.unwrap())
            .collect();
        assert_eq!(lines, ["a", "bb"]);
        #[cfg(unix)]
        {
            let e = read_capped(Path::new("/dev/zero"), 100)
                .unwrap_err()
                .to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
    }
}
