//! EXR files with their noise: the radiance as `R`, `G`, `B` and, when the render measured it,
//! the variance of each pixel's mean as a layer `variance` (`variance.R`, `variance.G`,
//! `variance.B`), as tev and other viewers show layers. A reference written this way carries
//! its own noise, which `compare` subtracts from its error and `diff --ztest` tests against
//! (Mitsuba's render tests keep the same in a second file).

use super::Film;
use anyhow::{anyhow, bail, Result};
use exr::prelude::*;
use std::io::{Read, Seek};

/// The names of the variance channels, in R, G, B order.
const VARIANCE: [&str; 3] = ["variance.R", "variance.G", "variance.B"];

/// The header attribute that holds how many passes the variance was estimated from.
const SAMPLES: &str = "raylabVarianceSamples";

/// Encodes the film: three f32 radiance channels, and the variance layer if the film has one.
pub fn encode(film: &Film, out: &mut std::io::Cursor<Vec<u8>>) -> Result<()> {
    encode_with(film, Vec::new(), None, out)
}

/// Encodes the film with more channels and, instead of the variance's pass count, one other
/// header attribute (shard files). One raylab attribute at most: the exr crate writes a
/// header's attributes in hash-map order, so two would make the bytes differ between runs.
pub fn encode_with(
    film: &Film,
    extra: Vec<AnyChannel<FlatSamples>>,
    attribute: Option<(&str, AttributeValue)>,
    out: &mut std::io::Cursor<Vec<u8>>,
) -> Result<()> {
    encode_channels(film, ["R", "G", "B"], extra, attribute, out)
}

/// Encodes the film whose pixels are CIE XYZ (see [`super::to_xyz`]) as channels X, Y, Z.
pub fn encode_xyz(film: &Film, out: &mut std::io::Cursor<Vec<u8>>) -> Result<()> {
    encode_channels(film, ["X", "Y", "Z"], Vec::new(), None, out)
}

/// [`encode_with`], the pixels' three channels named `names`.
fn encode_channels(
    film: &Film,
    names: [&str; 3],
    extra: Vec<AnyChannel<FlatSamples>>,
    attribute: Option<(&str, AttributeValue)>,
    out: &mut std::io::Cursor<Vec<u8>>,
) -> Result<()> {
    let size = (film.width as usize, film.height as usize);
    let channel = |name: &str, values: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(values));
    let plane = |of: &[glam::Vec3], c: usize| of.iter().map(|p| p[c]).collect::<Vec<f32>>();
    let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in names.into_iter().enumerate() {
        channels.push(channel(name, plane(&film.pixels, c)));
    }
    if film.has_variance {
        for (c, name) in VARIANCE.into_iter().enumerate() {
            channels.push(channel(name, plane(&film.variance, c)));
        }
    }
    channels.extend(extra);
    // ZIP over blocks of 16 lines, written in increasing order: the same render gives the
    // same bytes (with an unspecified order, blocks land as the compressing threads finish).
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let mut attributes = LayerAttributes::default();
    if let Some((name, value)) = attribute {
        attributes.other.insert(Text::from(name), value);
    } else if film.has_variance {
        let n = i32::try_from(film.variance_samples).unwrap_or(i32::MAX);
        attributes
            .other
            .insert(Text::from(SAMPLES), AttributeValue::I32(n));
    }
    let layer = Layer::new(size, attributes, encoding, AnyChannels::sort(channels));
    Image::from_layer(layer)
        .write()
        .to_buffered(out)
        .map_err(|e| anyhow!("{e}"))
}

/// The variance layer of an EXR file, if it has one of `width x height` pixels, with the
/// number of passes it was estimated from (0 when the file does not say); `None` when it has
/// none (a file from another renderer, or a 1-spp render). The header is read first: a file
/// declaring absurdly many channels is refused before any pixel is.
pub fn read_variance(
    mut file: impl Read + Seek,
    width: u32,
    height: u32,
) -> Result<Option<(Vec<glam::Vec3>, u32)>> {
    let meta = exr::meta::MetaData::read_from_buffered(std::io::BufReader::new(&mut file), false)
        .map_err(|e| anyhow!("{e}"))?;
    let names = |h: &exr::meta::header::Header| -> Vec<String> {
        h.channels.list.iter().map(|c| c.name.to_string()).collect()
    };
    let Some(header) = meta
        .headers
        .iter()
        .find(|h| VARIANCE.iter().all(|v| names(h).iter().any(|n| n == v)))
    else {
        return Ok(None);
    };
    if header.channels.list.len() > 96 {
        bail!(
            "its layer of variance has {} channels (at most 96 are read)",
            header.channels.list.len()
        );
    }
    let samples = match header.own_attributes.other.get(&Text::from(SAMPLES)) {
        Some(AttributeValue::I32(n)) if *n >= 0 => *n as u32,
        _ => 0,
    };
    let size = header.layer_size;
    if (size.width(), size.height()) != (width as usize, height as usize) {
        bail!(
            "its variance layer is {}x{}, its image {width}x{height}",
            size.width(),
            size.height()
        );
    }
    file.rewind()?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required(VARIANCE[0])
        .required(VARIANCE[1])
        .required(VARIANCE[2])
        .collect_pixels(
            |size, _| (size.width(), vec![glam::Vec3::ZERO; size.area()]),
            |(w, values): &mut (usize, Vec<glam::Vec3>), at, (r, g, b): (f32, f32, f32)| {
                values[at.y() * *w + at.x()] = glam::Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::BufReader::new(file))
        .map_err(|e| anyhow!("{e}"))?;
    let (_, values) = image.layer_data.channel_data.pixels;
    if values.len() != width as usize * height as usize {
        bail!("its variance layer is not the image's size");
    }
    Ok(Some((values, samples)))
}
