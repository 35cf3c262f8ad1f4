//! Mitsuba's binary volume grids (`.vol`): the format of its `gridvolume` and `sdfgrid`
//! data. A 48-byte header (`VOL`, version 3, encoding 1 = float32, the resolution in `x`, `y`,
//! `z`, the channel count, a bounding box of six floats), then the values, little-endian,
//! `x` fastest, then `y`, then `z`, channels innermost.

use std::path::Path;

/// A grid of values as a `.vol` file holds it.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumeGrid {
    /// Resolution in `x`, `y`, `z`.
    pub resolution: [usize; 3],
    pub channels: usize,
    /// The box the file says the grid spans (min, max).
    pub bounds: ([f32; 3], [f32; 3]),
    /// `values[((z * ny + y) * nx + x) * channels + c]`.
    pub values: Vec<f32>,
}

/// The largest grid read: 2^28 values (1 GiB of floats).
const MAX_VALUES: u64 = 1 << 28;

/// Loads a `.vol` file.
pub fn load_volume_grid(file: &Path) -> Result<VolumeGrid, String> {
    let bytes = crate::files::read_uncompressed(file, crate::files::MAX_BINARY)
        .map_err(|e| format!("cannot load volume grid `{}`: {e}", file.display()))?;
    parse_volume_grid(&bytes)
        .map_err(|e| format!("cannot load volume grid `{}`: {e}", file.display()))
}

/// Reads a `.vol` file's bytes.
pub fn parse_volume_grid(bytes: &[u8]) -> Result<VolumeGrid, String> {
    if bytes.len() < 48 {
        return Err(format!(
            "{} bytes, shorter than its 48-byte header",
            bytes.len()
        ));
    }
    if &bytes[..3] != b"VOL" || bytes[3] != 3 {
        return Err("not a Mitsuba volume grid (`VOL`, version 3)".into());
    }
    let int =
        |at: usize| i32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let float =
        |at: usize| f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    if int(4) != 1 {
        return Err(format!("encoding {} (only 1, float32, is read)", int(4)));
    }
    let dims = [int(8), int(12), int(16), int(20)];
    if dims.iter().any(|&d| d <= 0) {
        return Err(format!(
            "a resolution of {} x {} x {} with {} channels",
            dims[0], dims[1], dims[2], dims[3]
        ));
    }
    let count = dims
        .iter()
        .try_fold(1u64, |n, &d| n.checked_mul(d as u64))
        .unwrap_or(u64::MAX);
    if count > MAX_VALUES {
        return Err(format!(
            "{count} values, more than the {MAX_VALUES} raylab reads"
        ));
    }
    let want = 48 + 4 * count;
    if bytes.len() as u64 != want {
        return Err(format!(
            "{} bytes, but its header says {want} ({} x {} x {} values of {} channels)",
            bytes.len(),
            dims[0],
            dims[1],
            dims[2],
            dims[3]
        ));
    }
    let values: Vec<f32> = bytes[48..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("value {i} is not finite"));
    }
    Ok(VolumeGrid {
        resolution: [dims[0] as usize, dims[1] as usize, dims[2] as usize],
        channels: dims[3] as usize,
        bounds: (
            [float(24), float(28), float(32)],
            [float(36), float(40), float(44)],
        ),
        values,
    })
}

#[cfg(test)]
pub(crate) fn encode(resolution: [usize; 3], channels: usize, values: &[f32]) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [
        1,
        resolution[0] as i32,
        resolution[1] as i32,
        resolution[2] as i32,
        channels as i32,
    ] {
        b.extend(v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend(v.to_le_bytes());
    }
    for v in values {
        b.extend(v.to_le_bytes());
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_reads_back_and_damage_is_refused() {
        let values: Vec<f32> = (0..24).map(|i| i as f32).collect();
        let bytes = encode([2, 3, 4], 1, &values);
        let g = parse_volume_grid(&bytes).unwrap();
        assert_eq!((g.resolution, g.channels), ([2, 3, 4], 1));
        assert_eq!(g.values, values);
        assert!(parse_volume_grid(&bytes[..60])
            .unwrap_err()
            .contains("header says"));
        let mut bad = bytes.clone();
        bad[8] = 0;
        assert!(parse_volume_grid(&bad).is_err());
        let mut huge = bytes.clone();
        huge[8..12].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(parse_volume_grid(&huge).unwrap_err().contains("more than"));
        // Every dimension at its largest: the count saturates rather than overflows.
        for at in [8, 12, 16, 20] {
            huge[at..at + 4].copy_from_slice(&i32::MAX.to_le_bytes());
        }
        assert!(parse_volume_grid(&huge).unwrap_err().contains("more than"));
        assert!(parse_volume_grid(b"VOL").is_err());
    }
}
