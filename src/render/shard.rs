//! Shards: one render split into parts that run anywhere (cluster jobs, other machines) and
//! merge into exactly the image of the single run.
//!
//! An integrator whose passes depend only on their number ([`ShardBy::Passes`]) is split by
//! passes: the render's blocks of [`BLOCK`] passes are shared out, shard `i` of `n` taking
//! blocks `[i B / n, (i + 1) B / n)` of the `B` there are, over the whole image. Each pass's
//! per-pixel values are the same whichever machine takes it (samples are seeded by seed,
//! pixel and pass alone), each block is summed in f64 from zero in pass order, and blocks are
//! added exactly ([`super::accumulator`]), so adding the shards' sums gives bit for bit the
//! single run's. An integrator that keeps state per
//! pixel across passes ([`ShardBy::Rows`]: `sppm-pixel`) is split by bands of tile rows
//! instead: shard `i` renders every pass over its band, plus the rows its filter reaches into
//! (rendered, not kept), so that each of its pixels gets every sample the single run gives it,
//! in the same order.

use anyhow::{bail, Result};
use raylab_integrators::Filter;
pub use raylab_integrators::ShardBy;
use std::fmt;
use std::ops::Range;
use std::str::FromStr;

use super::{BLOCK, TILE};

/// Shard `index` of `count` (0-based), as given to `--shard I/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShardSpec {
    pub index: u32,
    pub count: u32,
}

/// The most shards a render is split into.
pub const MAX_SHARDS: u32 = 100_000;

impl FromStr for ShardSpec {
    type Err = anyhow::Error;

    fn from_str(text: &str) -> Result<ShardSpec> {
        let usage = || {
            anyhow::anyhow!(
                "--shard `{text}`: expected I/N, shard I (counting from 0) of N, e.g. --shard 0/4"
            )
        };
        let (i, n) = text.split_once('/').ok_or_else(usage)?;
        let (index, count): (u32, u32) = (
            i.trim().parse().map_err(|_| usage())?,
            n.trim().parse().map_err(|_| usage())?,
        );
        if count == 0 || count > MAX_SHARDS {
            bail!("--shard `{text}`: N must be between 1 and {MAX_SHARDS}");
        }
        if index >= count {
            bail!("--shard `{text}`: shards are numbered 0 to {}", count - 1);
        }
        Ok(ShardSpec { index, count })
    }
}

impl fmt::Display for ShardSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The part of a render one shard does.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Part {
    /// These passes, over the whole image.
    Passes(Range<u32>),
    /// Every pass, over these image rows.
    Rows(Range<u32>),
}

impl Part {
    /// How the render this is part of splits.
    pub fn shard_by(&self) -> ShardBy {
        match self {
            Part::Passes(_) => ShardBy::Passes,
            Part::Rows(_) => ShardBy::Rows,
        }
    }
}

impl fmt::Display for Part {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Part::Passes(r) => write!(f, "passes {}..{}", r.start, r.end),
            Part::Rows(r) => write!(f, "rows {}..{}", r.start, r.end),
        }
    }
}

impl FromStr for Part {
    type Err = anyhow::Error;

    /// The inverse of `Display` (shard files record their part as text).
    fn from_str(text: &str) -> Result<Part> {
        let bad = || anyhow::anyhow!("`{text}` is not a shard's part");
        let (kind, range) = text.split_once(' ').ok_or_else(bad)?;
        let (a, b) = range.split_once("..").ok_or_else(bad)?;
        let (a, b): (u32, u32) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
        if a >= b {
            return Err(bad());
        }
        match kind {
            "passes" => Ok(Part::Passes(a..b)),
            "rows" => Ok(Part::Rows(a..b)),
            _ => Err(bad()),
        }
    }
}

impl ShardSpec {
    /// This shard's part of a render of `spp` passes over an image `height` rows high, split
    /// as `by` says; refused when there are fewer passes or rows of tiles than shards.
    pub fn part(&self, by: ShardBy, spp: u32, height: u32) -> Result<Part> {
        let (i, n) = (self.index as u64, self.count as u64);
        let split = |total: u32| (i * total as u64 / n) as u32..((i + 1) * total as u64 / n) as u32;
        match by {
            ShardBy::Passes => {
                // Whole blocks of passes, so that each block's sums are added where the
                // single run adds them.
                let blocks = spp.div_ceil(BLOCK);
                if blocks < self.count {
                    bail!(
                        "--shard {self}: shards take whole blocks of {BLOCK} passes, so {} shards need at least {} passes; the render has {spp} (raise --spp or use fewer shards)",
                        self.count,
                        (self.count - 1) * BLOCK + 1
                    );
                }
                let b = split(blocks);
                let pass = |block: u32| (block as u64 * BLOCK as u64).min(spp as u64) as u32;
                Ok(Part::Passes(pass(b.start)..pass(b.end)))
            }
            ShardBy::Rows => {
                let tile_rows = height.div_ceil(TILE);
                if tile_rows < self.count {
                    bail!(
                        "--shard {self}: this integrator keeps state per pixel, so it is split by rows of {TILE}-pixel tiles; the {height}-row image has {tile_rows}, fewer than {} shards",
                        self.count
                    );
                }
                let tiles = split(tile_rows);
                Ok(Part::Rows(
                    tiles.start * TILE..(tiles.end * TILE).min(height),
                ))
            }
        }
    }
}

/// The rows a shard of image rows `rows` renders: its own, and those whose samples reach
/// into them through `filter`, whole tiles at a time (so that its tiles are the single run's).
pub fn rendered_rows(rows: &Range<u32>, filter: Filter, height: u32) -> Range<u32> {
    // A sample in row y reaches rows whose centres lie within the filter's radius r of its
    // film position, which is inside [y, y + 1): rows up to y + ceil(r + 0.5) - 1 either
    // way, and one more for rounding. The box filter keeps each sample in its own pixel.
    let reach = match filter {
        Filter::Box => 0,
        _ => (filter.radius() + 0.5).ceil() as u32,
    };
    let down = |y: u32| y.saturating_sub(reach) / TILE * TILE;
    let up = |y: u32| ((y + reach).div_ceil(TILE) * TILE).min(height);
    down(rows.start)..up(rows.end)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses_shard_specs() {
        assert_eq!(
            "2/7".parse::<ShardSpec>().unwrap(),
            ShardSpec { index: 2, count: 7 }
        );
        for bad in ["", "3", "7/7", "-1/3", "a/b", "1/0", "0/100001", "1/2/3"] {
            assert!(bad.parse::<ShardSpec>().is_err(), "{bad}");
        }
    }

    #[test]
    fn parts_cover_the_render_once() {
        for n in 1..=9u32 {
            let mut next = 0;
            let mut rows = 0;
            for i in 0..n {
                let spec = ShardSpec { index: i, count: n };
                match spec.part(ShardBy::Passes, 70, 100).unwrap() {
                    Part::Passes(r) => {
                        assert_eq!(r.start, next);
                        assert_eq!(r.start % BLOCK, 0);
                        assert!(!r.is_empty());
                        next = r.end;
                    }
                    p => panic!("{p}"),
                }
                if n <= 7 {
                    match spec.part(ShardBy::Rows, 10, 100).unwrap() {
                        Part::Rows(r) => {
                            assert_eq!(r.start, rows);
                            assert_eq!(r.start % TILE, 0);
                            rows = r.end;
                        }
                        p => panic!("{p}"),
                    }
                }
            }
            assert_eq!(next, 70);
            if n <= 7 {
                assert_eq!(rows, 100);
            }
        }
        let e = ShardSpec {
            index: 0,
            count: 10,
        }
        .part(ShardBy::Passes, 70, 100)
        .unwrap_err();
        assert!(e.to_string().contains("at least 73 passes"), "{e}");
        let e = ShardSpec { index: 0, count: 8 }
            .part(ShardBy::Rows, 10, 100)
            .unwrap_err();
        assert!(e.to_string().contains("has 7"), "{e}");
        for p in [Part::Passes(3..9), Part::Rows(16..40)] {
            assert_eq!(p.to_string().parse::<Part>().unwrap(), p);
        }
        for bad in ["passes 3..3", "rows", "tiles 0..4", "passes 4..2"] {
            assert!(bad.parse::<Part>().is_err(), "{bad}");
        }
    }

    #[test]
    fn rendered_rows_reach_as_far_as_the_filter() {
        let gaussian: Filter = "gaussian".parse().unwrap();
        assert_eq!(rendered_rows(&(32..48), Filter::Box, 100), 32..48);
        assert_eq!(rendered_rows(&(0..16), gaussian, 100), 0..32);
        assert_eq!(rendered_rows(&(80..100), gaussian, 100), 64..100);
    }
}
