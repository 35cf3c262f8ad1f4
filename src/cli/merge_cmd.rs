//! `raylab merge`: the shards of a render (`render --shard I/N`) combined into exactly the
//! image the single run writes. The parts are checked before any pixel is read: made by this
//! raylab, from the same scene and settings, split the same way, each shard once, each
//! complete, none missing. Then their exact sums are added (a shard of rows holds zeros
//! outside its rows) and the image is made from them as the single run makes it.

use super::MergeArgs;
use crate::output::{self, plan::FilePlan};
use crate::render::shard_file::{self, ShardInfo};
use crate::render::{Part, PixelTotals};
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

pub fn merge(args: &MergeArgs) -> Result<ExitCode> {
    output::check_output_path(&args.output)?;
    let mut plan = FilePlan::new();
    for part in &args.parts {
        plan.input("a shard", part)?;
    }
    plan.output("the merged image", &args.output)?;
    plan.check()?;
    let start = Instant::now();
    let infos = args
        .parts
        .iter()
        .map(|p| shard_file::read_info(p).with_context(|| format!("{}: cannot merge", p.display())))
        .collect::<Result<Vec<_>>>()?;
    check_parts(&args.parts, &infos)?;

    // The exact sums, block of lines after block of lines: every part is read side by side,
    // one block of each at a time (in any order: the sums are exact), so memory holds the
    // image (mean and variance) and a block per part, whatever the number of parts.
    let first = &infos[0];
    let (width, height) = (first.width, first.height);
    check_room(width, height, args.parts.len())?;
    // Every part stays open while the blocks are read.
    if let Some(limit) = crate::system::open_files_limit() {
        let needed = args.parts.len() as u64 + 16;
        if needed > limit {
            bail!(
                "merging {} parts keeps them all open, and this process may open {limit} files: raise the limit (`ulimit -n {needed}`) and merge again",
                args.parts.len()
            );
        }
    }
    let cannot = |path: &Path| format!("{}: cannot merge", path.display());
    let mut sums = args
        .parts
        .iter()
        .zip(&infos)
        .map(|(path, info)| shard_file::Sums::open(path, info).with_context(|| cannot(path)))
        .collect::<Result<Vec<_>>>()?;
    let lines = sums[0].lines_per_block();
    let mut dropped = crate::render::Dropped::default();
    for info in &infos {
        dropped.add(info.dropped);
    }
    let n = first.spp;
    let mut film = output::Film::new(width, height);
    film.has_variance = n >= 2;
    film.variance_samples = n;
    let w = width as usize;
    let mut totals = vec![PixelTotals::default(); w * lines as usize];
    // Parts are decoded side by side, as many at once as there are threads.
    let at_once = rayon::current_num_threads().max(1);
    for y0 in (0..height).step_by(lines as usize) {
        let rows = lines.min(height - y0);
        let block = &mut totals[..w * rows as usize];
        block.fill(PixelTotals::default());
        for (group, paths) in sums.chunks_mut(at_once).zip(args.parts.chunks(at_once)) {
            let decoded = group
                .par_iter_mut()
                .zip(paths)
                .map(|(part, path)| part.next_block(y0, rows).with_context(|| cannot(path)))
                .collect::<Result<Vec<_>>>()?;
            block.par_chunks_mut(w).enumerate().for_each(|(line, row)| {
                for part in &decoded {
                    part.add_line(line as u32, row);
                }
            });
        }
        let at = y0 as usize * w;
        for (k, t) in block.iter().enumerate() {
            let (mean, var) = t.finish(n);
            film.pixels[at + k] = mean;
            film.variance[at + k] = var;
        }
    }
    drop(totals);
    output::write_image(&args.output, &film, first.display)?;
    if let Some(bad) = dropped.first {
        note!(
            "warning: the render dropped {} non-finite or out-of-range sample(s); first at pixel ({}, {}) sample {}",
            dropped.count,
            bad.x,
            bad.y,
            bad.sample
        );
    }
    if !args.quiet {
        let mean = film.mean();
        note!(
            "merged {} shard(s) of {} ({}x{}, {} spp, {}) in {:.2} s | mean radiance ({:.4}, {:.4}, {:.4}) | wrote {}",
            infos.len(),
            first.scene_name,
            first.width,
            first.height,
            first.spp,
            first.settings,
            start.elapsed().as_secs_f64(),
            mean.x,
            mean.y,
            mean.z,
            args.output.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Refuses a merge whose memory would not fit: the image's mean and variance and their copy
/// while the output is encoded (about 64 bytes a pixel), and a block of lines of each part
/// (its 84 channels and their sums, 16 lines at most).
fn check_room(width: u32, height: u32, parts: usize) -> Result<()> {
    let image = width as u64 * height as u64 * 64;
    let blocks = (parts as u64 + 2) * width as u64 * 16 * (84 * 4 * 2 + 312);
    let needed = image + blocks;
    if let Some((room, what)) = crate::system::memory_limit() {
        if needed > room {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            bail!(
                "merging {parts} parts of {width}x{height} needs {:.1} GiB of memory; only {:.1} GiB is {what}",
                gib(needed),
                gib(room)
            );
        }
    }
    Ok(())
}

/// Checks that the parts are the shards of one render, each once, each complete, and all
/// of them; the error names the part and what differs.
fn check_parts(paths: &[PathBuf], infos: &[ShardInfo]) -> Result<()> {
    let own = env!("CARGO_PKG_VERSION");
    let (first_path, first) = (paths[0].display(), &infos[0]);
    let mut seen: BTreeMap<u32, &Path> = BTreeMap::new();
    for (path, info) in paths.iter().zip(infos) {
        let shown = path.display();
        if info.version != own {
            bail!(
                "{shown}: rendered by raylab {}, and this is raylab {own}: merge with the raylab that rendered the shards",
                info.version
            );
        }
        if info.scene != first.scene {
            bail!(
                "{shown}: rendered from another scene than {first_path}: {} (content {}) against {} (content {})",
                info.scene_name,
                info.scene,
                first.scene_name,
                first.scene
            );
        }
        if info.settings != first.settings {
            bail!(
                "{shown}: rendered with other settings than {first_path}: {}",
                differences(&info.settings, &first.settings)
            );
        }
        if info.spec.count != first.spec.count {
            bail!(
                "{shown}: shard {} of a render split in {}, but {first_path} is shard {} of one split in {}",
                info.spec,
                info.spec.count,
                first.spec,
                first.spec.count
            );
        }
        if (info.width, info.height, info.spp) != (first.width, first.height, first.spp) {
            bail!(
                "{shown}: a {}x{} image of {} passes, {first_path} a {}x{} one of {}",
                info.width,
                info.height,
                info.spp,
                first.width,
                first.height,
                first.spp
            );
        }
        if (info.display.exposure, info.display.tonemap)
            != (first.display.exposure, first.display.tonemap)
        {
            bail!(
                "{shown}: rendered with another --exposure or --tonemap than {first_path}, which a PNG would show"
            );
        }
        let expected = info
            .spec
            .part(info.part.shard_by(), info.spp, info.height)
            .with_context(|| format!("{shown}: its header does not describe a shard"))?;
        if expected != info.part {
            bail!(
                "{shown}: says it holds {}, but shard {} of this render holds {expected}",
                info.part,
                info.spec
            );
        }
        if let Some(other) = seen.insert(info.spec.index, path) {
            if other == path.as_path() {
                bail!("{shown} is given twice: give each shard once");
            }
            bail!(
                "{} and {shown} are both shard {}: give each shard once",
                other.display(),
                info.spec
            );
        }
    }
    for (path, info) in paths.iter().zip(infos) {
        if !info.is_complete() {
            let (start, end) = match &info.part {
                Part::Passes(r) => (r.start, r.end),
                Part::Rows(_) => (0, info.spp),
            };
            bail!(
                "{}: shard {} stopped after pass {} of its passes {start}..{end} (interrupted, out of time, or preempted): resume it (render --shard {} --checkpoint FILE --resume) and merge again",
                path.display(),
                info.spec,
                info.passes_done,
                info.spec
            );
        }
    }
    let missing: Vec<String> = (0..first.spec.count)
        .filter(|i| !seen.contains_key(i))
        .take(20)
        .map(|index| {
            let spec = crate::render::ShardSpec {
                index,
                count: first.spec.count,
            };
            match spec.part(first.part.shard_by(), first.spp, first.height) {
                Ok(part) => format!("{spec} ({part})"),
                Err(_) => spec.to_string(),
            }
        })
        .collect();
    if !missing.is_empty() {
        let absent = first.spec.count as usize - seen.len();
        bail!(
            "{absent} of {} shards missing: {}{}; render them with `raylab render ... --shard I/{}` (the same settings) and merge all {}",
            first.spec.count,
            missing.join(", "),
            if absent > missing.len() { ", ..." } else { "" },
            first.spec.count,
            first.spec.count
        );
    }
    Ok(())
}

/// The `key=value` words of `a` that `b` has otherwise, as `key=A (B in the other)`.
fn differences(a: &str, b: &str) -> String {
    let words = |s: &str| -> BTreeMap<String, String> {
        s.split(' ')
            .map(|w| match w.split_once('=') {
                Some((k, v)) => (k.to_string(), v.to_string()),
                None => (w.to_string(), String::new()),
            })
            .collect()
    };
    let (wa, wb) = (words(a), words(b));
    let mut out = Vec::new();
    for (k, v) in &wa {
        match wb.get(k) {
            Some(o) if o == v => {}
            Some(o) => out.push(format!("{k}={v} where it has {k}={o}")),
            None => out.push(format!("{k}={v}, which it does not have")),
        }
    }
    for k in wb.keys().filter(|k| !wa.contains_key(*k)) {
        out.push(format!("no {k}, which it has"));
    }
    out.join(", ")
}
