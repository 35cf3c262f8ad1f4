//! `raylab merge`: the shards of a render (`render --shard I/N`) combined into exactly the
//! image the single run writes. The parts are checked before any pixel is read: made by this
//! raylab, from the same scene and settings, split the same way, each shard once, each
//! complete, none missing. Then their exact sums are added (a shard of rows holds zeros
//! outside its rows) and the image is made from them as the single run makes it.

use super::MergeArgs;
use crate::output::{self, plan::FilePlan};
use crate::render::shard_file::{self, ShardInfo};
use crate::render::{Accumulation, Part};
use anyhow::{bail, Context, Result};
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

    // The exact sums, shard after shard (in any order: they are exact): the merged sums and
    // one part's channels in memory at once.
    let first = &infos[0];
    let part_bytes = (first.width as u64 * first.height as u64) * 4 * 84;
    crate::render::check_memory(first.width, first.height, part_bytes)?;
    let mut acc = Accumulation::new(first.width, first.height);
    for (path, info) in args.parts.iter().zip(&infos) {
        shard_file::add_sums(path, info, &mut acc)
            .with_context(|| format!("{}: cannot merge", path.display()))?;
        acc.dropped.add(info.dropped);
    }
    acc.spp_done = first.spp;
    let film = acc.film();
    output::write_image(&args.output, &film, first.display)?;
    if let Some(bad) = acc.dropped.first {
        note!(
            "warning: the render dropped {} non-finite or out-of-range sample(s); first at pixel ({}, {}) sample {}",
            acc.dropped.count,
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
