//! Checkpoints: the accumulated state of a render, saved after every pass so that it can be
//! resumed. The file records a hash of everything that determines the image (scene text and
//! the mesh files it names, integrator and parameters, target spp, seed, resolution);
//! resuming with any of them changed is refused. Rendering N spp directly, or k spp and then
//! resuming to N, gives bit-identical images.
//!
//! The file is an LZ4 frame (the sums' many zero bytes compress about four to one), holding,
//! little-endian: magic `RAYLABCK`, version `u32`, settings hash `u64`, width and
//! height `u32`, first pass `u32` (0, or a shard's first), passes done `u32` (counted from the
//! render's first), dropped samples `u64`, first dropped sample (`u8` present flag, then x, y,
//! sample `u32`), then for every pixel in tile order its running sums: 13 `f64` for the block
//! of passes in progress and 13 exact sums of 24 bytes ([`super::exact::Exact`]) for the
//! blocks before, each in the order filter-weighted radiance (3), filter weight (1), splats
//! (3), and the batch means' sums of the passes' estimates (3) and of their squares (3); last,
//! a checksum `u64` (FNV-1a of everything before it, as 64-bit words).
//!
//! A checkpoint is checked before it is used: the checksum (a damaged or edited file), then
//! what a render can produce (at least one pass, a dropped-sample record inside the image,
//! finite sums, non-negative weights), so that a bad file is refused instead of becoming an
//! image of NaN.

use super::accumulator::PixelTotals;
use super::exact::Exact;
use super::{Accumulation, BadSample};
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 8] = b"RAYLABCK";
const VERSION: u32 = 4;

/// Bytes of a pixel's sums.
const PIXEL_BYTES: u64 = 13 * 8 + 13 * 24;

pub use crate::scene::references::stable_hash;

/// Serialises `acc` with the settings hash `hash`, uncompressed (tests).
#[cfg(test)]
pub fn encode(acc: &Accumulation, hash: u64) -> Vec<u8> {
    let mut out = Vec::new();
    write_to(acc, hash, &mut out).expect("writing to memory does not fail");
    out
}

/// FNV-1a over the bytes taken as little-endian 64-bit words (the last one zero-padded): finds
/// damage, at eight bytes a step (a checkpoint of a 4K render is gigabytes).
#[derive(Clone)]
struct Checksum {
    h: u64,
    pending: [u8; 8],
    filled: usize,
}

impl Checksum {
    fn new() -> Checksum {
        Checksum {
            h: 0xcbf2_9ce4_8422_2325,
            pending: [0; 8],
            filled: 0,
        }
    }

    fn word(&mut self, w: u64) {
        self.h ^= w;
        self.h = self.h.wrapping_mul(0x0000_0100_0000_01b3);
    }

    fn update(&mut self, mut bytes: &[u8]) {
        if self.filled > 0 {
            let take = (8 - self.filled).min(bytes.len());
            self.pending[self.filled..self.filled + take].copy_from_slice(&bytes[..take]);
            self.filled += take;
            bytes = &bytes[take..];
            if self.filled < 8 {
                return;
            }
            self.word(u64::from_le_bytes(self.pending));
            self.filled = 0;
        }
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            let mut word = [0u8; 8];
            word.copy_from_slice(w);
            self.word(u64::from_le_bytes(word));
        }
        let rest = words.remainder();
        self.pending[..rest.len()].copy_from_slice(rest);
        self.filled = rest.len();
    }

    fn finish(mut self) -> u64 {
        if self.filled > 0 {
            self.pending[self.filled..].fill(0);
            self.word(u64::from_le_bytes(self.pending));
        }
        self.h
    }
}

/// Writes `acc` with the settings hash `hash` to `out`, pixel by pixel (no copy of the whole
/// state in memory), the checksum last.
fn write_to(acc: &Accumulation, hash: u64, out: &mut impl Write) -> std::io::Result<()> {
    let mut sum = Checksum::new();
    let mut put = |bytes: &[u8], out: &mut dyn Write| -> std::io::Result<()> {
        sum.update(bytes);
        out.write_all(bytes)
    };
    let mut head = Vec::with_capacity(64);
    head.extend_from_slice(MAGIC);
    head.extend_from_slice(&VERSION.to_le_bytes());
    head.extend_from_slice(&hash.to_le_bytes());
    head.extend_from_slice(&acc.width.to_le_bytes());
    head.extend_from_slice(&acc.height.to_le_bytes());
    head.extend_from_slice(&acc.first_pass.to_le_bytes());
    head.extend_from_slice(&acc.spp_done.to_le_bytes());
    head.extend_from_slice(&acc.dropped.count.to_le_bytes());
    let bad = acc.dropped.first.unwrap_or(BadSample {
        x: 0,
        y: 0,
        sample: 0,
    });
    head.push(acc.dropped.first.is_some() as u8);
    for v in [bad.x, bad.y, bad.sample] {
        head.extend_from_slice(&v.to_le_bytes());
    }
    put(&head, out)?;
    let mut record = [0u8; PIXEL_BYTES as usize];
    for t in &acc.tiles {
        for (k, p) in t.pixels.iter().enumerate() {
            let totals = t.totals(k);
            let block = p.sum.to_array().into_iter().chain([p.weight]).chain(
                [p.splat, p.batch, p.batch_sq]
                    .into_iter()
                    .flat_map(|v| v.to_array()),
            );
            let (floats, exact) = record.split_at_mut(13 * 8);
            for (chunk, v) in floats.chunks_exact_mut(8).zip(block) {
                chunk.copy_from_slice(&v.to_le_bytes());
            }
            for (chunk, v) in exact.chunks_exact_mut(24).zip(totals.values()) {
                chunk.copy_from_slice(&v.to_le_bytes());
            }
            put(&record, out)?;
        }
    }
    out.write_all(&sum.finish().to_le_bytes())
}

/// A checkpoint's bytes as they are read, with the checksum of those read so far.
struct Source<R> {
    inner: R,
    sum: Checksum,
}

impl<R: std::io::Read> Source<R> {
    /// Fills `buf` from the file (without the checksum).
    fn fill(&mut self, buf: &mut [u8]) -> Result<()> {
        self.inner.read_exact(buf).map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => anyhow::anyhow!("the file is truncated"),
            _ => anyhow::anyhow!("the file is damaged, or not a raylab checkpoint ({e})"),
        })
    }
    fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut b = [0u8; N];
        self.fill(&mut b)?;
        self.sum.update(&b);
        Ok(b)
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    /// Whether the stored checksum, next in the file, is that of the bytes read so far.
    fn checksum_matches(&mut self) -> Result<bool> {
        let mut stored = [0u8; 8];
        self.fill(&mut stored)?;
        Ok(self.sum.clone().finish() == u64::from_le_bytes(stored))
    }
    /// Whether the file ends here.
    fn at_end(&mut self) -> Result<bool> {
        let mut one = [0u8; 1];
        Ok(self.inner.read(&mut one)? == 0)
    }
    /// Reads the rest of the file, and whether its last 8 bytes are the checksum of all
    /// before them (a checkpoint of other settings, or damaged?).
    fn rest_is_intact(&mut self) -> Result<bool> {
        let mut last = Vec::with_capacity(8);
        let mut buf = vec![0u8; 1 << 16];
        loop {
            let n = self.inner.read(&mut buf)?;
            if n == 0 {
                break;
            }
            last.extend_from_slice(&buf[..n]);
            if last.len() > 8 {
                let cut = last.len() - 8;
                self.sum.update(&last[..cut]);
                last.drain(..cut);
            }
        }
        let Ok(stored) = <[u8; 8]>::try_from(last.as_slice()) else {
            return Ok(false);
        };
        Ok(self.sum.clone().finish() == u64::from_le_bytes(stored))
    }
}

/// Bytes of a checkpoint of `width x height` pixels.
fn checkpoint_bytes(width: u32, height: u32) -> u64 {
    8 + 4 + 8 + 4 + 4 + 4 + 4 + 8 + 1 + 12 + width as u64 * height as u64 * PIXEL_BYTES + 8
}

/// Restores an accumulation for an image of `width x height` rendered with settings hash
/// `hash` from the bytes of `read` as they come (no copy of the file in memory); refuses a
/// file made with other settings, or damaged.
fn decode_from(
    read: impl std::io::Read,
    hash: u64,
    width: u32,
    height: u32,
) -> Result<Accumulation> {
    let mut r = Source {
        inner: read,
        sum: Checksum::new(),
    };
    if &r.take::<8>()? != MAGIC {
        bail!("not a raylab checkpoint");
    }
    let version = r.u32()?;
    if version != VERSION {
        bail!("checkpoint version {version}, this raylab reads version {VERSION}");
    }
    let stored_hash = r.u64()?;
    let (w, h) = (r.u32()?, r.u32()?);
    // Another render's checkpoint, or a damaged one: the checksum tells.
    if stored_hash != hash || (w, h) != (width, height) {
        if !r.rest_is_intact()? {
            bail!("the file is damaged (its checksum does not match)");
        }
        if stored_hash != hash {
            bail!("the scene or the render settings changed since the checkpoint was written (integrator, parameters, spp, seed, resolution, the scene file and the mesh files it names must match)");
        }
        bail!("the checkpoint is {w}x{h}, the render {width}x{height}");
    }
    let mut acc = Accumulation::new(width, height);
    acc.first_pass = r.u32()?;
    acc.spp_done = r.u32()?;
    acc.dropped.count = r.u64()?;
    let has_bad = r.take::<1>()?[0] != 0;
    let bad = BadSample {
        x: r.u32()?,
        y: r.u32()?,
        sample: r.u32()?,
    };
    acc.dropped.first = has_bad.then_some(bad);
    let mut record = [0u8; PIXEL_BYTES as usize];
    let f64_at = |record: &[u8], i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&record[i * 8..i * 8 + 8]);
        f64::from_le_bytes(b)
    };
    let dvec3_at = |record: &[u8], i: usize| {
        glam::DVec3::new(
            f64_at(record, i),
            f64_at(record, i + 1),
            f64_at(record, i + 2),
        )
    };
    for t in &mut acc.tiles {
        for k in 0..t.pixels.len() {
            r.fill(&mut record)?;
            r.sum.update(&record);
            let p = &mut t.pixels[k];
            p.sum = dvec3_at(&record, 0);
            p.weight = f64_at(&record, 3);
            p.splat = dvec3_at(&record, 4);
            p.batch = dvec3_at(&record, 7);
            p.batch_sq = dvec3_at(&record, 10);
            let mut values = [Exact::ZERO; 13];
            for (v, chunk) in values.iter_mut().zip(record[13 * 8..].chunks_exact(24)) {
                let mut b = [0u8; 24];
                b.copy_from_slice(chunk);
                *v = Exact::from_le_bytes(b);
            }
            t.set_totals(k, &PixelTotals::from_values(values));
        }
    }
    if !r.checksum_matches()? {
        bail!("the file is damaged (its checksum does not match)");
    }
    if !r.at_end()? {
        bail!("the file is damaged (bytes follow the checkpoint)");
    }
    check(&acc)?;
    Ok(acc)
}

/// [`decode_from`] a checkpoint in memory (uncompressed: tests).
#[cfg(test)]
pub fn decode(bytes: &[u8], hash: u64, width: u32, height: u32) -> Result<Accumulation> {
    decode_from(bytes, hash, width, height)
}

/// What a render can have produced: at least one pass, dropped samples no more than were
/// taken and the first of them inside the image and the passes, finite sums, non-negative
/// weights and squares.
pub(crate) fn check(acc: &Accumulation) -> Result<()> {
    if acc.passes() == 0 || acc.spp_done <= acc.first_pass || acc.spp_done == u32::MAX {
        bail!("it records passes {} to {}", acc.first_pass, acc.spp_done);
    }
    let taken = acc.passes() as u64 * acc.width as u64 * acc.height as u64;
    if acc.dropped.count > taken {
        bail!(
            "it records {} dropped samples of {taken} taken",
            acc.dropped.count
        );
    }
    if let Some(b) = acc.dropped.first {
        if b.x >= acc.width
            || b.y >= acc.height
            || !(acc.first_pass..acc.spp_done).contains(&b.sample)
        {
            bail!("its first dropped sample lies outside the image or the passes");
        }
    }
    for t in &acc.tiles {
        for (k, p) in t.pixels.iter().enumerate() {
            let totals = t.totals(k);
            let finite = [p.sum, p.splat, p.batch, p.batch_sq]
                .iter()
                .all(|v| v.is_finite())
                && p.weight.is_finite();
            let negative = p.weight < 0.0
                || p.batch_sq.min_element() < 0.0
                || totals.weight.is_negative()
                || totals.batch_sq.0.iter().any(Exact::is_negative);
            if !finite || negative {
                let (x, y) = (t.x0 + k as u32 % t.w, t.y0 + k as u32 / t.w);
                bail!("pixel ({x}, {y}) holds sums no render produces (not finite, or negative weights or squares)");
            }
        }
    }
    Ok(())
}

/// Writes a checkpoint atomically (temporary file in the same folder, then rename).
pub fn save(path: &Path, acc: &Accumulation, hash: u64) -> Result<()> {
    crate::output::atomic::write_atomic(path, |file| {
        let buffered = std::io::BufWriter::with_capacity(1 << 20, file);
        let mut out = lz4_flex::frame::FrameEncoder::new(buffered);
        write_to(acc, hash, &mut out)
            .and_then(|_| out.finish().map_err(std::io::Error::other))
            .and_then(|mut b| b.flush())
            .map_err(|e| {
                anyhow::anyhow!(
                    "{}: the checkpoint: {}",
                    path.display(),
                    crate::output::write_error(&e)
                )
            })
    })
}

/// A reader that counts the bytes read through it.
struct Counted<R> {
    inner: R,
    count: u64,
}

impl<R: std::io::Read> std::io::Read for Counted<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.count += n as u64;
        Ok(n)
    }
}

/// Reads a checkpoint written by [`save`] for the same settings, decoding it as it is
/// decompressed.
pub fn load(path: &Path, hash: u64, width: u32, height: u32) -> Result<Accumulation> {
    // Its size is known from the image's: a larger file is refused unread.
    let size = checkpoint_bytes(width, height);
    let cannot = || format!("{}: cannot read the checkpoint", path.display());
    // LZ4 at worst adds a little to what it compresses.
    let (file, length) =
        crate::files::open_capped(path, size + size / 64 + 4096).with_context(cannot)?;
    use std::io::Read;
    let mut decoder = lz4_flex::frame::FrameDecoder::new(Counted {
        inner: std::io::BufReader::new(file),
        count: 0,
    });
    let acc = decode_from((&mut decoder).take(size + 1), hash, width, height)
        .with_context(|| format!("{}: cannot resume", path.display()))?;
    // The frame must be the whole file.
    if decoder.get_ref().count != length {
        bail!(
            "{}: cannot resume: the file is damaged (bytes follow the checkpoint)",
            path.display()
        );
    }
    Ok(acc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_refuses_other_settings_or_damage() {
        let mut acc = Accumulation::new(20, 17);
        acc.spp_done = 3;
        acc.dropped.count = 2;
        acc.dropped.first = Some(BadSample {
            x: 4,
            y: 5,
            sample: 1,
        });
        let mut pass = crate::render::accumulator::PassPixel::default();
        pass.add(glam::Vec3A::new(1.0, 2.0, 3.0), 0.5);
        pass.splat = glam::DVec3::new(0.25, 0.0, 4.0);
        acc.tiles[1].pixels[7].close_pass(&pass);
        let totals = PixelTotals::default().with_block(&acc.tiles[1].pixels[7]);
        acc.tiles[1].set_totals(7, &totals);
        assert_ne!(acc.tiles[1].totals(7), PixelTotals::default());
        let bytes = encode(&acc, 42);
        let back = decode(&bytes, 42, 20, 17).unwrap();
        assert_eq!(back.film(), acc.film());
        assert_eq!(back.tiles[1].pixels[7], acc.tiles[1].pixels[7]);
        assert_eq!(back.tiles[1].totals(7), acc.tiles[1].totals(7));
        assert_eq!((back.spp_done, back.dropped), (3, acc.dropped));
        assert!(decode(&bytes, 43, 20, 17)
            .unwrap_err()
            .to_string()
            .contains("changed"));
        assert!(decode(&bytes, 42, 20, 18).is_err());
        for len in [bytes.len() - 1, 19, 12] {
            let e = decode(&bytes[..len], 42, 20, 17).unwrap_err().to_string();
            assert!(e.contains("truncated") || e.contains("damaged"), "{e}");
        }
        assert!(decode(b"garbage!", 42, 20, 17).is_err());
        // One flipped bit anywhere is found.
        let mut flipped = bytes.clone();
        flipped[200] ^= 4;
        let e = decode(&flipped, 42, 20, 17).unwrap_err().to_string();
        assert!(e.contains("damaged"), "{e}");
    }

    /// Files with a valid checksum but contents no render makes: refused, not an image of NaN.
    #[test]
    fn refuses_what_no_render_produces() {
        let valid = || {
            let mut acc = Accumulation::new(8, 8);
            acc.spp_done = 2;
            acc
        };
        type Spoil = fn(&mut Accumulation);
        let cases: [(&str, Spoil); 7] = [
            ("passes", |a| a.spp_done = 0),
            ("passes 2 to 2", |a| a.first_pass = 2),
            ("dropped samples", |a| a.dropped.count = 1000),
            ("outside", |a| {
                a.dropped.count = 1;
                a.dropped.first = Some(BadSample {
                    x: 9,
                    y: 0,
                    sample: 0,
                })
            }),
            ("pixel (3, 0)", |a| a.tiles[0].pixels[3].sum.x = f64::NAN),
            ("negative", |a| a.tiles[0].pixels[9].weight = -1.0),
            ("negative", |a| {
                let mut t = a.tiles[0].totals(9);
                t.batch_sq.0[1] = Exact::from_f64(-2.0).unwrap();
                a.tiles[0].set_totals(9, &t);
            }),
        ];
        assert!(decode(&encode(&valid(), 1), 1, 8, 8).is_ok());
        for (message, spoil) in cases {
            let mut acc = valid();
            spoil(&mut acc);
            let e = decode(&encode(&acc, 1), 1, 8, 8).unwrap_err().to_string();
            assert!(e.contains(message), "{message}: {e}");
        }
    }

    #[test]
    fn hash_separates_parts() {
        assert_ne!(stable_hash(&[b"ab", b"c"]), stable_hash(&[b"a", b"bc"]));
        assert_eq!(stable_hash(&[b"scene"]), stable_hash(&[b"scene"]));
    }
}
