//! EXR files written and read one block of scan lines at a time, through the exr crate's block
//! API: memory stays a few blocks whatever the image's size (shard files, with their 84
//! channels, and `raylab merge`, which reads all its parts side by side).
//!
//! A block holds [`Block::lines`] scan lines; each line holds, channel after channel in the
//! file's order (sorted by name, as EXR requires), the line's samples: 4 bytes each
//! (`f32` or `u32`), in native byte order (the crate converts to and from the file's).

use anyhow::{anyhow, bail, Context, Result};
use exr::block::reader::ChunksReader;
use exr::block::writer::ChunksWriter;
use exr::block::{BlockIndex, UncompressedBlock};
use exr::meta::attribute::{ChannelDescription, SampleType};
use exr::meta::header::Header;
use exr::meta::BlockDescription;
use exr::prelude::*;
use std::io::{BufReader, BufWriter, Write};
use std::path::Path;

/// One block of scan lines.
pub struct Block {
    /// Its first line, and how many it holds.
    pub y0: u32,
    pub lines: u32,
    width: usize,
    channels: usize,
    data: Vec<u8>,
}

impl Block {
    /// The byte offset of sample `x` of channel `c` in line `line` of the block.
    #[inline]
    fn at(&self, line: u32, c: usize, x: usize) -> usize {
        ((line as usize * self.channels + c) * self.width + x) * 4
    }

    /// Sets sample `x` of channel `c` (by its place in the file's order) in line `line`.
    #[inline]
    pub fn set_u32(&mut self, line: u32, c: usize, x: usize, v: u32) {
        let i = self.at(line, c, x);
        self.data[i..i + 4].copy_from_slice(&v.to_ne_bytes());
    }

    #[inline]
    pub fn set_f32(&mut self, line: u32, c: usize, x: usize, v: f32) {
        self.set_u32(line, c, x, v.to_bits());
    }

    /// The samples of channel `c` in line `line`, 4 bytes each.
    pub fn row(&self, line: u32, c: usize) -> &[u8] {
        let i = self.at(line, c, 0);
        &self.data[i..i + 4 * self.width]
    }
}

/// The channels of an image, in the file's order: names sorted, with their sample types.
#[derive(Clone, Debug, PartialEq)]
pub struct Channels(Vec<(String, SampleType)>);

impl Channels {
    /// The channels `list`, put in the file's order.
    pub fn new(mut list: Vec<(String, SampleType)>) -> Channels {
        list.sort_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
        Channels(list)
    }

    /// The place of channel `name` in the file's order.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.0.iter().position(|(n, _)| n == name)
    }

    /// The sample type of the channel at place `i`.
    pub fn kind(&self, i: usize) -> SampleType {
        self.0[i].1
    }

    pub fn len(&self) -> usize {
        self.0.len()
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// How a file is laid out: size, channels, compression (blocks of its scan lines).
pub struct Layout {
    pub width: u32,
    pub height: u32,
    pub channels: Channels,
    pub compression: Compression,
}

/// Writes an EXR of one layer with `layout` and one header attribute to `out`: `fill` is
/// given each block in turn, from the top, with every sample zero, and sets its samples.
/// Blocks are compressed on the exr crate's threads and written in increasing line order, so
/// the same pixels make the same bytes.
pub fn write(
    out: &mut std::fs::File,
    layout: &Layout,
    attribute: (&str, AttributeValue),
    mut fill: impl FnMut(&mut Block) -> Result<()>,
) -> Result<()> {
    let channels: SmallVec<[ChannelDescription; 5]> = layout
        .channels
        .0
        .iter()
        .map(|(name, kind)| ChannelDescription::named(name.as_str(), *kind))
        .collect();
    let mut attributes = LayerAttributes::default();
    attributes
        .other
        .insert(Text::from(attribute.0), attribute.1);
    let size = (layout.width as usize, layout.height as usize);
    let header = Header::new(Text::from(""), size, channels)
        .with_encoding(
            layout.compression,
            BlockDescription::ScanLines,
            LineOrder::Increasing,
        )
        .with_attributes(attributes);
    let lines = header.compression.scan_lines_per_block() as u32;
    let mut headers = exr::meta::Headers::new();
    headers.push(header);
    // `fill`'s error, kept here while the crate is told to stop.
    let mut failed: Option<anyhow::Error> = None;
    let (width, channels) = (layout.width as usize, layout.channels.len());
    // Makes every block in turn and hands it to `push`.
    let mut produce = |push: &mut dyn FnMut(usize, UncompressedBlock) -> exr::error::UnitResult| {
        for (index, y0) in (0..layout.height).step_by(lines as usize).enumerate() {
            let n = lines.min(layout.height - y0);
            let mut block = Block {
                y0,
                lines: n,
                width,
                channels,
                data: vec![0u8; n as usize * width * channels * 4],
            };
            if let Err(e) = fill(&mut block) {
                failed = Some(e);
                return Err(exr::error::Error::Aborted);
            }
            let index_of = BlockIndex {
                layer: 0,
                pixel_position: exr::math::Vec2(0, y0 as usize),
                pixel_size: exr::math::Vec2(width, n as usize),
                level: exr::math::Vec2(0, 0),
            };
            push(
                index,
                UncompressedBlock {
                    index: index_of,
                    data: block.data,
                },
            )?;
        }
        Ok(())
    };
    let mut buffered = BufWriter::with_capacity(1 << 20, &mut *out);
    let written =
        exr::block::write(&mut buffered, headers, true, |meta, writer| {
            // Compressed on the crate's threads; uncompressed blocks go straight to the file.
            if layout.compression == Compression::Uncompressed {
                let mut c = writer.sequential_blocks_compressor(&meta);
                produce(&mut |i, b| c.compress_block(i, b))
            } else {
                let mut c = writer.parallel_blocks_compressor(&meta).ok_or(
                    exr::error::Error::NotSupported("no threads to compress on".into()),
                )?;
                produce(&mut |i, b| c.add_block_to_compression_queue(i, b))
            }
        });
    if let Some(e) = failed {
        return Err(e);
    }
    written.map_err(|e| match e {
        exr::error::Error::Io(io) => anyhow!(super::write_error(&io)),
        other => anyhow!("cannot encode the image ({other})"),
    })?;
    buffered
        .flush()
        .map_err(|e| anyhow!(super::write_error(&e)))
}

/// An EXR file read one block of scan lines after another, from the top.
pub struct BlockReader {
    chunks: exr::block::reader::AllChunksReader<BufReader<std::fs::File>>,
    meta: exr::meta::MetaData,
    pub channels: Channels,
    pub width: u32,
    pub height: u32,
    /// The line the next block begins at, and the lines a block holds.
    next_y: u32,
    lines: u32,
}

impl BlockReader {
    /// Reads the header of the EXR `file`: one layer of scan lines, in increasing line order.
    pub fn open(file: std::fs::File) -> Result<BlockReader> {
        let reader = exr::block::read(BufReader::new(file), true)
            .map_err(|e| anyhow!("not an EXR file ({e})"))?;
        let [header] = reader.headers() else {
            bail!("it has {} layers, not one", reader.headers().len());
        };
        if header.blocks != BlockDescription::ScanLines || header.deep {
            bail!("its pixels are not in scan lines");
        }
        if header.line_order == LineOrder::Decreasing {
            bail!("its lines are stored bottom up");
        }
        if header.own_attributes.layer_position != exr::math::Vec2(0, 0) {
            bail!("its data window does not start at (0, 0)");
        }
        let channels = Channels(
            header
                .channels
                .list
                .iter()
                .map(|c| (c.name.to_string(), c.sample_type))
                .collect(),
        );
        let size = header.layer_size;
        let (width, height) = (size.width() as u32, size.height() as u32);
        let lines = header.compression.scan_lines_per_block() as u32;
        let chunks = reader
            .all_chunks(true)
            .map_err(|e| anyhow!("its block table is damaged ({e})"))?;
        let meta = chunks.meta_data().clone();
        Ok(BlockReader {
            chunks,
            meta,
            channels,
            width,
            height,
            next_y: 0,
            lines,
        })
    }

    /// Lines in a block of the file (the last may hold fewer).
    pub fn lines_per_block(&self) -> u32 {
        self.lines
    }

    /// The header's attributes.
    pub fn attributes(&self) -> &LayerAttributes {
        &self.meta.headers[0].own_attributes
    }

    /// The next block, which must follow the one before (`None` after the last).
    pub fn next_block(&mut self) -> Result<Option<Block>> {
        if self.next_y >= self.height {
            return Ok(None);
        }
        let y0 = self.next_y;
        let damaged = |what: String| anyhow!("its pixels are damaged at line {y0} ({what})");
        let chunk = self
            .chunks
            .next()
            .ok_or_else(|| damaged("the file ends".into()))?
            .map_err(|e| damaged(e.to_string()))?;
        let block = UncompressedBlock::decompress_chunk(chunk, &self.meta, true)
            .map_err(|e| damaged(e.to_string()))?;
        let n = self.lines.min(self.height - y0);
        if block.index.pixel_position != exr::math::Vec2(0, y0 as usize)
            || block.index.pixel_size != exr::math::Vec2(self.width as usize, n as usize)
        {
            return Err(damaged(format!(
                "a block of lines {}..{} where lines {y0}..{} belong",
                block.index.pixel_position.y(),
                block.index.pixel_position.y() + block.index.pixel_size.height(),
                y0 + n
            )));
        }
        let expected = n as usize * self.width as usize * self.channels.len() * 4;
        if block.data.len() != expected {
            return Err(damaged(format!(
                "{} bytes where {expected} belong",
                block.data.len()
            )));
        }
        self.next_y += n;
        Ok(Some(Block {
            y0,
            lines: n,
            width: self.width as usize,
            channels: self.channels.len(),
            data: block.data,
        }))
    }
}

/// Opens `path` (a regular file) and reads its header.
pub fn open(path: &Path) -> Result<BlockReader> {
    let (file, _) = crate::files::open_capped(path, u64::MAX)
        .with_context(|| format!("{}: cannot open it", path.display()))?;
    BlockReader::open(file)
}

#[cfg(test)]
mod tests;
