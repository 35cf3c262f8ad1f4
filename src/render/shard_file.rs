//! Shard files: one shard of a render (`render --shard I/N`) as an EXR that any viewer opens
//! (its `R`, `G`, `B` are the image of the shard's own passes or rows, with their `variance`
//! layer), carrying what `raylab merge` needs to rebuild the single run exactly:
//!
//! - the shard's exact per-pixel sums ([`crate::render::exact`]): 13 sums of 192 bits per
//!   pixel, as 78 channels of 32-bit unsigned integers `raylab.VV.L` (sum `VV` in the order
//!   of [`PixelTotals::values`], 32-bit limb `L`, least significant first);
//! - one header attribute, `raylabShard`, saying what it is part of, a line `key=value` each:
//!   `format`, `scene` (hash of the scene file and the files it names) and `scene-name`,
//!   `settings` (everything else that determines the image, as `key=value` words), `version`,
//!   `shard` (`I/N`), `part` (`passes A..B` or `rows A..B`), `spp` (the whole render's
//!   passes), `passes-done`, `dropped`, and the `exposure` and `tonemap` a PNG is made with.
//!   (One attribute: the exr crate writes attributes in hash-map order, so several would make
//!   the bytes of the same shard differ from run to run.)
//!
//! Reading checks the header before any pixel: a file that is not a shard, or declares a size
//! or channels a shard does not have, is refused unread.

use super::exact::Exact;
use crate::output::exr_blocks::{self, BlockReader, Channels, Layout};
use crate::output::{DisplaySettings, Tonemap};
use crate::render::{Accumulation, BadSample, Dropped, Part, PixelTotals, ShardSpec};
use anyhow::{anyhow, bail, Context, Result};
use clap::ValueEnum;
use exr::prelude::*;
use std::path::Path;

/// The layout of the sums; raised when it changes.
const FORMAT: i32 = 1;

/// Channels of the exact sums: 13 sums of six 32-bit limbs.
const SUM_CHANNELS: usize = 13 * 6;

/// What a shard file says it is.
#[derive(Clone, Debug)]
pub struct ShardInfo {
    /// Hash of the scene file and the files it names (hex), and the scene's file name (shown
    /// in messages, not compared).
    pub scene: String,
    pub scene_name: String,
    /// Everything else that determines the image, as `key=value` words.
    pub settings: String,
    pub version: String,
    pub spec: ShardSpec,
    pub part: Part,
    /// Passes of the whole render.
    pub spp: u32,
    /// Passes the shard finished, counted from the render's first.
    pub passes_done: u32,
    pub dropped: Dropped,
    pub display: DisplaySettings,
    pub width: u32,
    pub height: u32,
}

impl ShardInfo {
    /// Whether the shard rendered all of its part.
    pub fn is_complete(&self) -> bool {
        match &self.part {
            Part::Passes(r) => self.passes_done == r.end,
            Part::Rows(_) => self.passes_done == self.spp,
        }
    }
}

/// The header attribute holding a shard's description.
const ATTRIBUTE: &str = "raylabShard";

/// How to make shards, for messages about files that are not.
const HOW: &str = "render shards with `raylab render --shard I/N -o part.exr`";

/// The channel holding limb `limb` of sum `value`.
fn sum_channel(value: usize, limb: usize) -> String {
    format!("raylab.{value:02}.{limb}")
}

/// How shard files are compressed (see docs/cluster.md for the measurement behind it).
const COMPRESSION: Compression = Compression::ZIP16;

/// The channels of a shard file of `passes` passes, in the file's order.
fn shard_channels(passes: u32) -> Channels {
    let mut list: Vec<(String, SampleType)> = ["R", "G", "B"]
        .iter()
        .map(|n| (n.to_string(), SampleType::F32))
        .collect();
    if passes >= 2 {
        for n in ["variance.R", "variance.G", "variance.B"] {
            list.push((n.to_string(), SampleType::F32));
        }
    }
    for c in 0..SUM_CHANNELS {
        list.push((sum_channel(c / 6, c % 6), SampleType::U32));
    }
    Channels::new(list)
}

/// The places of the sum channels in the file's order, in the order of [`sum_channel`]'s
/// numbering; an error names the first missing or mistyped one.
fn sum_places(channels: &Channels, types: impl Fn(usize) -> SampleType) -> Result<Vec<usize>> {
    (0..SUM_CHANNELS)
        .map(|c| {
            let name = sum_channel(c / 6, c % 6);
            match channels.index(&name) {
                Some(i) if types(i) == SampleType::U32 => Ok(i),
                Some(_) => bail!("its channel {name} is not of 32-bit integers"),
                None => bail!("it has no channel {name}"),
            }
        })
        .collect()
}

/// Writes shard `info` of a render, whose state is `acc` (for a shard of rows, only its rows
/// are kept: the others hold partial sums of the rows its filter reaches into), one block of
/// lines at a time.
pub fn write(path: &Path, acc: &Accumulation, info: &ShardInfo) -> Result<()> {
    let kept = |y: u32| match &info.part {
        Part::Rows(rows) => rows.contains(&y),
        Part::Passes(_) => true,
    };
    let n = acc.passes();
    let channels = shard_channels(n);
    let places = |names: [&str; 3]| -> Result<[usize; 3]> {
        let mut out = [0; 3];
        for (o, name) in out.iter_mut().zip(names) {
            *o = channels
                .index(name)
                .ok_or_else(|| anyhow!("a shard has no channel {name}"))?;
        }
        Ok(out)
    };
    let rgb = places(["R", "G", "B"])?;
    let variance = match n >= 2 {
        true => Some(places(["variance.R", "variance.G", "variance.B"])?),
        false => None,
    };
    let sums = sum_places(&channels, |_| SampleType::U32)?;
    let so_far = acc.dropped_so_far();
    let dropped = match so_far.first {
        Some(b) => format!("{} {} {} {}", so_far.count, b.x, b.y, b.sample),
        None => format!("{}", so_far.count),
    };
    let tonemap = info
        .display
        .tonemap
        .to_possible_value()
        .map_or("clamp".to_string(), |v| v.get_name().to_string());
    let lines = [
        ("format", FORMAT.to_string()),
        ("scene", info.scene.clone()),
        ("scene-name", info.scene_name.replace(['\n', '\r'], " ")),
        ("settings", info.settings.clone()),
        ("version", info.version.clone()),
        ("shard", info.spec.to_string()),
        ("part", info.part.to_string()),
        ("spp", info.spp.to_string()),
        ("passes-done", acc.spp_done.to_string()),
        ("dropped", dropped),
        ("exposure", info.display.exposure.to_string()),
        ("tonemap", tonemap),
    ];
    let text: String = lines.iter().map(|(k, v)| format!("{k}={v}\n")).collect();
    let value = AttributeValue::Text(Text::from_bytes_unchecked(text.as_bytes().into()));
    let layout = Layout {
        width: acc.width,
        height: acc.height,
        channels: channels.clone(),
        compression: COMPRESSION,
    };
    crate::output::check_output_path(path)?;
    crate::output::atomic::write_atomic(path, |file| {
        exr_blocks::write(file, &layout, (ATTRIBUTE, value), |block| {
            let y0 = block.y0;
            for line in (0..block.lines).filter(|l| kept(y0 + l)) {
                for x in 0..acc.width {
                    let totals = acc.pixel_totals(x, y0 + line);
                    let (mean, var) = totals.finish(n);
                    let x = x as usize;
                    for c in 0..3 {
                        block.set_f32(line, rgb[c], x, mean[c]);
                        if let Some(v) = &variance {
                            block.set_f32(line, v[c], x, var[c]);
                        }
                    }
                    for (v, sum) in totals.values().iter().enumerate() {
                        for (l, limb) in sum.0.iter().enumerate() {
                            block.set_u32(line, sums[v * 6 + 2 * l], x, *limb as u32);
                            block.set_u32(line, sums[v * 6 + 2 * l + 1], x, (*limb >> 32) as u32);
                        }
                    }
                }
            }
            Ok(())
        })
        .with_context(|| path.display().to_string())
    })
}

/// The most bytes deflate (EXR's ZIP compression) can make of one (1032, rounded up).
const MAX_DEFLATE_RATIO: u64 = 1100;

/// What the shard file at `path` says it is, from its header alone.
pub fn read_info(path: &Path) -> Result<ShardInfo> {
    let (file, file_len) = crate::files::open_capped(path, u64::MAX)?;
    let meta = exr::meta::MetaData::read_from_buffered(std::io::BufReader::new(file), false)
        .map_err(|e| anyhow!("not an EXR file ({e})"))?;
    let [header] = meta.headers.as_slice() else {
        bail!("not a raylab shard (it has {} layers)", meta.headers.len());
    };
    let text = match header.own_attributes.other.get(&Text::from(ATTRIBUTE)) {
        Some(AttributeValue::Text(t)) => String::from_utf8_lossy(t.bytes()).into_owned(),
        _ => bail!("not a raylab shard (no {ATTRIBUTE} attribute: {HOW})"),
    };
    let fields: std::collections::HashMap<&str, &str> =
        text.lines().filter_map(|l| l.split_once('=')).collect();
    let get = |key: &str| -> Result<&str> {
        fields.get(key).copied().ok_or_else(|| {
            anyhow!("its {ATTRIBUTE} attribute has no `{key}`: not a raylab shard ({HOW})")
        })
    };
    let number = |key: &str| -> Result<u32> {
        let t = get(key)?;
        t.parse()
            .map_err(|_| anyhow!("its {key} `{t}` is not a whole number"))
    };
    let format = get("format")?;
    if format != FORMAT.to_string() {
        bail!("a shard of format {format}, this raylab reads format {FORMAT} (merge with the raylab that rendered it)");
    }
    let spec: ShardSpec = get("shard")?.parse().context("its shard")?;
    let part: Part = get("part")?.parse()?;
    let dropped_text = get("dropped")?;
    let words: Vec<u64> = dropped_text
        .split(' ')
        .map(|w| w.parse::<u64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow!("its dropped `{dropped_text}` is malformed"))?;
    let dropped = match words.as_slice() {
        [count] => Dropped {
            count: *count,
            first: None,
        },
        [count, x, y, sample] if [x, y, sample].iter().all(|v| **v <= u32::MAX as u64) => Dropped {
            count: *count,
            first: Some(BadSample {
                x: *x as u32,
                y: *y as u32,
                sample: *sample as u32,
            }),
        },
        _ => bail!("its dropped `{dropped_text}` is malformed"),
    };
    let exposure = get("exposure")?
        .parse::<f32>()
        .ok()
        .filter(|e| e.is_finite())
        .ok_or_else(|| anyhow!("its exposure is not a finite number"))?;
    let tonemap_name = get("tonemap")?;
    let tonemap = Tonemap::from_str(tonemap_name, true)
        .map_err(|_| anyhow!("its tonemap `{tonemap_name}` is unknown"))?;
    let size = header.layer_size;
    let (width, height) = (size.width() as u32, size.height() as u32);
    crate::scene::describe::check_size(width, height).map_err(|e| anyhow!("its image: {e}"))?;
    let expected = 3 + 3 + SUM_CHANNELS;
    let channels = header.channels.list.len();
    if channels != expected && channels != expected - 3 {
        bail!(
            "it has {channels} channels, a shard has {expected} (or {} with one pass)",
            expected - 3
        );
    }
    // What the header claims must fit in the file: a shard's pixels are ZIP-compressed, and
    // deflate packs at most 1032 bytes into one, so a forged header claiming a huge image is
    // refused here, before its pixels are allocated.
    let claimed = width as u64 * height as u64 * channels as u64 * 4;
    if claimed > MAX_DEFLATE_RATIO * file_len + (1 << 20) {
        bail!(
            "its header claims a {width}x{height} image of {channels} channels ({claimed} bytes), more than a file of {file_len} bytes can hold"
        );
    }
    let spp = number("spp")?;
    if spp == 0 || number("passes-done")? > spp {
        bail!("its spp and passes-done are not a render's");
    }
    Ok(ShardInfo {
        scene: get("scene")?.to_string(),
        scene_name: get("scene-name")?.to_string(),
        settings: get("settings")?.to_string(),
        version: get("version")?.to_string(),
        spec,
        part,
        spp,
        passes_done: number("passes-done")?,
        dropped,
        display: DisplaySettings { exposure, tonemap },
        width,
        height,
    })
}

/// A shard file's exact sums, read one block of lines after another.
pub struct Sums {
    reader: BlockReader,
    /// The places of the sum channels (see [`sum_places`]).
    places: Vec<usize>,
}

impl Sums {
    /// Opens the shard file at `path`, described by `info` (its header, read before).
    pub fn open(path: &Path, info: &ShardInfo) -> Result<Sums> {
        let reader = exr_blocks::open(path)?;
        if (reader.width, reader.height) != (info.width, info.height) {
            bail!(
                "its pixels are not the {}x{} its header says",
                info.width,
                info.height
            );
        }
        let types = |i: usize| reader.channels.kind(i);
        let places = sum_places(&reader.channels, types)?;
        Ok(Sums { reader, places })
    }

    /// Lines in a block of the file.
    pub fn lines_per_block(&self) -> u32 {
        self.reader.lines_per_block()
    }

    /// Reads the next block of lines, which the caller expects to be `y0..y0 + lines`.
    pub fn next_block(&mut self, y0: u32, lines: u32) -> Result<SumsBlock> {
        let block = self
            .reader
            .next_block()?
            .ok_or_else(|| anyhow!("its pixels end before line {y0}"))?;
        if (block.y0, block.lines) != (y0, lines) {
            bail!("its pixels are stored in other blocks of lines than the first part's");
        }
        Ok(SumsBlock {
            block,
            places: self.places.clone(),
        })
    }
}

/// A block of lines of a shard file's exact sums.
pub struct SumsBlock {
    block: exr_blocks::Block,
    places: Vec<usize>,
}

impl SumsBlock {
    /// Adds the sums of line `line` of the block to `row`, the line's pixels.
    pub fn add_line(&self, line: u32, row: &mut [PixelTotals]) {
        let rows: Vec<&[u8]> = self
            .places
            .iter()
            .map(|&c| self.block.row(line, c))
            .collect();
        let limb = |c: usize, x: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&rows[c][4 * x..4 * x + 4]);
            u32::from_ne_bytes(b) as u64
        };
        for (x, totals) in row.iter_mut().enumerate() {
            let mut values = [Exact::ZERO; 13];
            for (v, value) in values.iter_mut().enumerate() {
                for (l, word) in value.0.iter_mut().enumerate() {
                    *word = limb(v * 6 + 2 * l, x) | limb(v * 6 + 2 * l + 1, x) << 32;
                }
            }
            totals.add(&PixelTotals::from_values(values));
        }
    }
}
