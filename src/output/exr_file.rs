//! EXR files with their noise: the radiance as `R`, `G`, `B` and, when the render measured it,
//! the variance of each pixel's mean as a layer `variance` (`variance.R`, `variance.G`,
//! `variance.B`), as tev and other viewers show layers. A reference written this way carries
//! its own noise, which `compare` subtracts from its error and `diff --ztest` tests against
//! (Mitsuba's render tests keep the same in a second file).

use super::Film;
use anyhow::{anyhow, Result};
use exr::prelude::*;
use std::io::{Read, Seek};

/// The names of the variance channels, in R, G, B order.
const VARIANCE: [&str; 3] = ["variance.R", "variance.G", "variance.B"];

/// Encodes the film: three f32 radiance channels, and the variance layer if the film has one.
pub fn encode(film: &Film, out: &mut std::io::Cursor<Vec<u8>>) -> Result<()> {
    let size = (film.width as usize, film.height as usize);
    let channel = |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
    let plane = |of: &[glam::Vec3], c: usize| of.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
        channels.push(channel(name, plane(&film.pixels, c)));
    }
    if film.has_variance {
        for (c, name) in VARIANCE.into_iter().enumerate() {
            channels.push(channel(name, plane(&film.variance, c)));
        }
    }
    // ZIP over blocks of 16 lines, written in increasing order: the same render gives the
    // same bytes (with an unspecified order, blocks land as the compressing threads finish).
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        size,
        LayerAttributes::default(),
        encoding,
        AnyChannels::sort(channels),
    );
    Image::from_layer(layer)
        .write()
        .to_buffered(out)
        .map_err(|e| anyhow!("{e}"))
}

/// The variance layer of an EXR file, if it has one of `width x height` pixels; `None` when
/// it has none (a file from another renderer, or a 1-spp render).
pub fn read_variance(
    file: impl Read + Seek,
    width: u32,
    height: u32,
) -> Result<Option<Vec<glam::Vec3>>> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::BufReader::new(file))
        .map_err(|e| anyhow!("{e}"))?;
    let layer = &image.layer_data;
    if (layer.size.x(), layer.size.y()) != (width as usize, height as usize) {
        return Ok(None);
    }
    let find = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .map(|c| c.sample_data.values_as_f32().collect::<Vec<f32>>())
    };
    let (Some(r), Some(g), Some(b)) = (find(VARIANCE[0]), find(VARIANCE[1]), find(VARIANCE[2]))
    else {
        return Ok(None);
    };
    Ok(Some(
        r.into_iter()
            .zip(g)
            .zip(b)
            .map(|((r, g), b)| glam::Vec3::new(r, g, b))
            .collect(),
    ))
}
