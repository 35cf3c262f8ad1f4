//! Portable FloatMap images (`.pfm`: Debevec's format, which pbrt-v4 scenes use for
//! environment maps): a text header `PF` (RGB) or `Pf` (grey), the width and the height, and a
//! scale whose sign gives the byte order (negative: little-endian) and whose magnitude
//! multiplies every value (as pbrt-v4 reads it); then 32-bit floats, rows from the bottom.
//!
//! Read here rather than through a crate: the `image` crate has no PFM decoder, and
//! `zune-ppm` 0.5 swaps the wrong rows of an image of odd height when it turns them over.

/// Whether `bytes` start like a PFM file.
pub fn is_pfm(bytes: &[u8]) -> bool {
    bytes.len() >= 3
        && bytes[0] == b'P'
        && matches!(bytes[1], b'F' | b'f')
        && bytes[2].is_ascii_whitespace()
}

/// The image in `bytes` as RGB floats, rows from the top: `(width, height, values)`. A grey
/// image has its value in all three channels. `room` is the memory the values may take.
pub fn decode(bytes: &[u8], room: Option<u64>) -> Result<(u32, u32, Vec<f32>), String> {
    if !is_pfm(bytes) {
        return Err("not a PFM file (it starts with neither `PF` nor `Pf`)".into());
    }
    let channels = if bytes[1] == b'F' { 3 } else { 1 };
    // Three header fields after the magic, each ended by whitespace; the last by exactly one.
    let mut pos = 2;
    let mut field = |what: &str| -> Result<String, String> {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() && pos - start < 64 {
            pos += 1;
        }
        if pos >= bytes.len() || !bytes[pos].is_ascii_whitespace() {
            return Err(format!("the header ends before its {what}"));
        }
        let text = std::str::from_utf8(&bytes[start..pos])
            .map_err(|_| format!("the {what} is not a number"))?
            .to_string();
        pos += 1;
        Ok(text)
    };
    let width: u32 = field("width")?
        .parse()
        .map_err(|_| "the width is not a whole number".to_string())?;
    let height: u32 = field("height")?
        .parse()
        .map_err(|_| "the height is not a whole number".to_string())?;
    let scale: f32 = field("scale")?
        .parse()
        .map_err(|_| "the scale is not a number".to_string())?;
    if width == 0 || height == 0 {
        return Err(format!("it is {width} x {height} pixels"));
    }
    if !(scale.is_finite() && scale != 0.0) {
        return Err(format!(
            "the scale is {scale}: it must be a finite number, not 0"
        ));
    }
    let count = width as u64 * height as u64 * channels as u64;
    let data = &bytes[pos..];
    if (data.len() as u64) < count * 4 {
        return Err(format!(
            "it is {width} x {height} pixels of {channels} channel(s), {} bytes, but the file holds {} after its header",
            count * 4,
            data.len()
        ));
    }
    let need = width as u64 * height as u64 * 12;
    if let Some(room) = room {
        if need > room {
            return Err(format!(
                "it is {width} x {height} pixels, which take {need} bytes as floats, more than the {room} bytes raylab may use"
            ));
        }
    }
    let little = scale < 0.0;
    let magnitude = scale.abs();
    // The values, in the file's order (its length checked above).
    let values: Vec<f32> = data[..count as usize * 4]
        .chunks_exact(4)
        .map(|c| {
            let b = [c[0], c[1], c[2], c[3]];
            let v = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
            v * magnitude
        })
        .collect();
    let value = |i: usize| values[i];
    let (w, h) = (width as usize, height as usize);
    let mut out = Vec::with_capacity(w * h * 3);
    for row in (0..h).rev() {
        for x in 0..w {
            let i = (row * w + x) * channels;
            if channels == 3 {
                out.extend([value(i), value(i + 1), value(i + 2)]);
            } else {
                out.extend([value(i); 3]);
            }
        }
    }
    Ok((width, height, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pfm(magic: &str, w: usize, h: usize, scale: &str, values: &[f32], little: bool) -> Vec<u8> {
        let mut b = format!("{magic}\n{w} {h}\n{scale}\n").into_bytes();
        for v in values {
            b.extend(if little {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            });
        }
        b
    }

    /// Rows come out from the top (the file's last row first), at any height, in either
    /// byte order, scaled by the header's magnitude; grey fills all three channels.
    #[test]
    fn rows_are_turned_over_and_values_scaled() {
        for h in [1usize, 2, 3, 5] {
            // Row r from the bottom holds r in every channel.
            let values: Vec<f32> = (0..h).flat_map(|r| [r as f32; 3]).collect();
            for (scale, little) in [("-1.0", true), ("1.0", false)] {
                let (w, hh, out) = decode(&pfm("PF", 1, h, scale, &values, little), None).unwrap();
                assert_eq!((w, hh as usize), (1, h));
                let want: Vec<f32> = (0..h).rev().flat_map(|r| [r as f32; 3]).collect();
                assert_eq!(out, want, "height {h}, scale {scale}");
            }
        }
        let (_, _, out) = decode(&pfm("Pf", 2, 1, "-2", &[1.5, 0.25], true), None).unwrap();
        assert_eq!(out, vec![3.0, 3.0, 3.0, 0.5, 0.5, 0.5]);
    }

    #[test]
    fn bad_files_are_refused_with_a_reason() {
        let short = pfm("PF", 4, 4, "-1", &[0.0; 5], true);
        assert!(decode(&short, None).unwrap_err().contains("bytes"));
        assert!(decode(b"PF\n0 4\n-1\n", None)
            .unwrap_err()
            .contains("0 x 4"));
        assert!(decode(b"PF\n4 4\nnan\n", None)
            .unwrap_err()
            .contains("scale"));
        assert!(decode(b"PF\n4", None).unwrap_err().contains("header"));
        assert!(decode(b"PF\n-3 4\n1\n", None)
            .unwrap_err()
            .contains("width"));
        let big = pfm("PF", 1000, 1000, "-1", &[0.0; 3_000_000], true);
        assert!(decode(&big, Some(1_000_000))
            .unwrap_err()
            .contains("more than"));
        assert!(!is_pfm(b"P6\n"));
    }
}
