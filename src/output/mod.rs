//! Writing images: EXR holds raw linear radiance, PNG exposure + tone curve + sRGB. Every
//! file is written to a temporary file in the target folder and renamed into place, so a
//! failure never leaves a partial file and an old file survives intact.

pub mod atomic;
pub mod exr_blocks;
pub mod exr_file;
pub mod film;
pub mod plan;
pub mod tonemap;

use anyhow::{bail, Context, Result};
use atomic::parent_dir;
pub use film::Film;
use image::{ImageFormat, RgbImage};
use std::io::Write;
use std::path::Path;
pub use tonemap::Tonemap;

/// The image formats raylab writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputFormat {
    Png,
    Exr,
}

/// How PNGs are made from radiance.
#[derive(Clone, Copy, Debug, Default)]
pub struct DisplaySettings {
    /// Exposure in stops.
    pub exposure: f32,
    pub tonemap: Tonemap,
}

/// Checks an output path before rendering: a known extension and an existing, writable folder.
pub fn check_output_path(path: &Path) -> Result<OutputFormat> {
    if path.is_dir() {
        bail!(
            "{}: is a folder; give a file name ending in .png or .exr",
            path.display()
        );
    }
    let format = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
    {
        Some(e) if e == "png" => OutputFormat::Png,
        Some(e) if e == "exr" => OutputFormat::Exr,
        _ => bail!(
            "{}: unknown output extension; use .png (tonemapped) or .exr (linear radiance)",
            path.display()
        ),
    };
    check_writable_folder(path)?;
    atomic::check_replaceable(path)?;
    Ok(format)
}

/// Checks that the folder `path` would be written in (its target's, for a symbolic link)
/// exists and takes new files.
pub fn check_writable_folder(path: &Path) -> Result<()> {
    let target = atomic::through_links(path)?;
    let dir = parent_dir(&target);
    if dir.exists() && !dir.is_dir() {
        bail!("{}: `{}` is not a folder", path.display(), dir.display());
    }
    if !dir.is_dir() {
        bail!(
            "{}: the folder `{}` does not exist",
            path.display(),
            dir.display()
        );
    }
    // Probe that we can create files there, without touching the target.
    tempfile::NamedTempFile::new_in(dir).with_context(|| {
        format!(
            "{}: cannot write in the folder `{}`",
            path.display(),
            dir.display()
        )
    })?;
    Ok(())
}

/// Writes `path` atomically: `encode` fills a buffer in memory (its errors are the
/// encoder's), which is then written to the file (its errors are the disk's: a full disk says
/// so, not "decoding" as the EXR encoder would report it).
fn write_buffered(
    path: &Path,
    encode: impl FnOnce(&mut std::io::Cursor<Vec<u8>>) -> Result<()>,
) -> Result<()> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    encode(&mut bytes).with_context(|| format!("{}: cannot encode the image", path.display()))?;
    atomic::write_atomic(path, |file| {
        file.write_all(bytes.get_ref())
            .map_err(|e| anyhow::anyhow!("{}: {}", path.display(), write_error(&e)))
    })
}

/// What a failed write means to the user.
pub fn write_error(e: &std::io::Error) -> String {
    if e.kind() == std::io::ErrorKind::StorageFull || e.raw_os_error() == Some(28) {
        "cannot write: the disk is full".to_string()
    } else {
        format!("cannot write: {e}")
    }
}

/// The film as 8-bit sRGB after exposure and tone curve.
pub fn to_srgb_image(film: &Film, display: DisplaySettings) -> RgbImage {
    let mut data = Vec::with_capacity(film.pixels.len() * 3);
    for p in &film.pixels {
        data.extend_from_slice(&tonemap::to_srgb8(*p, display.exposure, display.tonemap));
    }
    RgbImage::from_raw(film.width, film.height, data).expect("buffer matches the film size")
}

/// Writes the film to `path` in the format its extension names.
pub fn write_image(path: &Path, film: &Film, display: DisplaySettings) -> Result<()> {
    let format = check_output_path(path)?;
    match format {
        OutputFormat::Exr => write_buffered(path, |w| exr_file::encode(film, w)),
        OutputFormat::Png => {
            let img = to_srgb_image(film, display);
            write_buffered(path, |w| {
                img.write_to(w, ImageFormat::Png)?;
                Ok(())
            })
        }
    }
}

/// The film, whose pixels are linear sRGB, as CIE 1931 XYZ (the inverse of the sRGB matrix
/// the film's colours came through, so a spectral render's XYZ up to rounding). The variance
/// layer is left out: XYZ's variance needs the channels' covariances, which the film does not
/// keep.
pub fn to_xyz(film: &Film) -> Film {
    let xyz = |p: &glam::Vec3| {
        glam::Vec3::from(raylab_integrators::spectrum::srgb_to_xyz(
            glam::Vec3A::from(*p),
        ))
    };
    Film {
        width: film.width,
        height: film.height,
        pixels: film.pixels.iter().map(xyz).collect(),
        variance: vec![glam::Vec3::ZERO; film.pixels.len()],
        has_variance: false,
        variance_samples: 0,
    }
}

/// Writes the film as an EXR of CIE XYZ (channels X, Y, Z; see [`to_xyz`]).
pub fn write_exr_xyz(path: &Path, film: &Film) -> Result<()> {
    if check_output_path(path)? != OutputFormat::Exr {
        bail!("{}: XYZ is written as EXR (-o FILE.exr)", path.display());
    }
    let xyz = to_xyz(film);
    write_buffered(path, |w| exr_file::encode_xyz(&xyz, w))
}

/// Writes `film` as EXR with more channels and one more header attribute (shard files).
pub fn write_exr_with(
    path: &Path,
    film: &Film,
    extra: Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>>,
    attribute: (&str, exr::prelude::AttributeValue),
) -> Result<()> {
    write_buffered(path, |w| {
        exr_file::encode_with(film, extra, Some(attribute), w)
    })
}

/// Reads an image as linear radiance: EXR as stored, PNG (8 or 16 bit) decoded from sRGB.
pub fn read_image(path: &Path) -> Result<Film> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let cannot = || format!("{}: cannot read the image", path.display());
    // A regular file of sane size, decoded as its extension says (a pipe would block).
    let (mut file, _) =
        crate::files::open_capped(path, crate::files::MAX_BINARY).with_context(cannot)?;
    let format = match ext.as_deref() {
        Some("exr") => ImageFormat::OpenExr,
        _ => ImageFormat::from_path(path).with_context(cannot)?,
    };
    decode_image(&mut file, format, path)
}

/// Decodes an open image file of `format` (named `path` in messages) as [`read_image`] does,
/// within the memory this process may still use.
pub fn decode_image(file: &mut std::fs::File, format: ImageFormat, path: &Path) -> Result<Film> {
    let cannot = || format!("{}: cannot read the image", path.display());
    let mut reader = image::ImageReader::with_format(std::io::BufReader::new(&mut *file), format);
    reader.limits(crate::files::image_limits());
    let img = reader.decode().with_context(cannot)?;
    let (w, h) = (img.width(), img.height());
    let mut film = Film::new(w, h);
    match format {
        ImageFormat::OpenExr => {
            for (p, q) in film.pixels.iter_mut().zip(img.to_rgb32f().pixels()) {
                *p = glam::Vec3::new(q[0], q[1], q[2]);
            }
            // The variance layer raylab writes beside the radiance, if the file has one.
            use std::io::Seek;
            file.rewind().with_context(cannot)?;
            if let Some((variance, samples)) =
                exr_file::read_variance(file, w, h).with_context(cannot)?
            {
                if let Some(i) = variance
                    .iter()
                    .position(|v| !v.is_finite() || v.min_element() < 0.0)
                {
                    bail!(
                        "{}: the variance layer holds a value that is negative or not finite at ({}, {})",
                        path.display(),
                        i % w as usize,
                        i / w as usize
                    );
                }
                film.variance = variance;
                film.has_variance = true;
                film.variance_samples = samples;
            }
        }
        _ => {
            for (p, q) in film.pixels.iter_mut().zip(img.to_rgb16().pixels()) {
                let lin = |v: u16| tonemap::srgb_decode(v as f32 / 65535.0);
                *p = glam::Vec3::new(lin(q[0]), lin(q[1]), lin(q[2]));
            }
        }
    }
    Ok(film)
}

/// Writes an 8-bit RGB image as PNG, atomically.
pub fn write_png(path: &Path, img: &RgbImage) -> Result<()> {
    check_writable_folder(path)?;
    write_buffered(path, |w| {
        img.write_to(w, ImageFormat::Png)?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_disk_says_so() {
        let full = std::io::Error::from_raw_os_error(28);
        assert_eq!(write_error(&full), "cannot write: the disk is full");
        let other = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        assert!(write_error(&other).starts_with("cannot write: "));
    }
}
