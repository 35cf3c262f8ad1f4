//! Reading images that scenes name (environment maps, textures): any format the `image` crate decodes
//! here (OpenEXR, Radiance HDR, PNG, JPEG), capped in size before anything is allocated, as linear
//! RGB. 8- and 16-bit images are decoded from sRGB, as Mitsuba 3 does, unless they hold data
//! (`raw`); float images are taken as they are. Texels that are not finite are refused.

use raylab_integrators::Rgb;
use std::io::Cursor;
use std::path::Path;

/// The largest image side a scene may name (a 32k x 16k environment map is the largest in
/// common use).
pub const MAX_IMAGE_SIDE: u32 = 65_536;

/// An image as linear RGB texels, row by row from the top.
#[derive(Debug)]
pub struct LinearImage {
    pub width: usize,
    pub height: usize,
    pub texels: Vec<Rgb>,
}

/// The sRGB transfer function, inverted.
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Reads and decodes `file`; 8- and 16-bit images are decoded from sRGB unless `raw`. The
/// error names the file and what is wrong with it.
pub fn read_linear_rgb(file: &Path, raw: bool) -> Result<LinearImage, String> {
    let cannot = |e: &dyn std::fmt::Display| format!("cannot load image `{}`: {e}", file.display());
    let bytes =
        crate::files::read_capped(file, crate::files::MAX_BINARY).map_err(|e| cannot(&e))?;
    let mut reader = image::ImageReader::new(Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| cannot(&e))?;
    if reader.format().is_none() {
        return Err(cannot(
            &"it is not an image raylab reads (OpenEXR, Radiance HDR, PNG or JPEG)",
        ));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    // The decoded image, and its float copy, must fit in the memory this process may use.
    let room = crate::system::memory_limit().map_or(u64::MAX, |(room, _)| room / 2);
    limits.max_alloc = Some(room.min(crate::files::MAX_BINARY));
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| cannot(&e))?;
    let is_float = matches!(
        decoded,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    );
    let rgb = decoded.into_rgb32f();
    let (width, height) = (rgb.width() as usize, rgb.height() as usize);
    let texels: Vec<Rgb> = rgb
        .pixels()
        .map(|p| {
            let [r, g, b] = p.0;
            if is_float || raw {
                Rgb::new(r, g, b)
            } else {
                Rgb::new(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b))
            }
        })
        .collect();
    if let Some(i) = texels.iter().position(|t| !t.is_finite()) {
        return Err(cannot(&format_args!(
            "texel ({}, {}) is not finite",
            i % width,
            i / width
        )));
    }
    Ok(LinearImage {
        width,
        height,
        texels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }

    #[test]
    fn images_load_as_linear_rgb_and_bad_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        // A 2 x 1 PNG: mid grey and white.
        let png = dir.path().join("a.png");
        image::RgbImage::from_raw(2, 1, vec![128, 128, 128, 255, 255, 255])
            .unwrap()
            .save(&png)
            .unwrap();
        let img = read_linear_rgb(&png, false).unwrap();
        assert_eq!((img.width, img.height), (2, 1));
        assert!((img.texels[0].x - 0.215_861).abs() < 1e-4 && img.texels[1] == Rgb::ONE);
        // Raw: the stored values, for data such as normal maps.
        let raw = read_linear_rgb(&png, true).unwrap();
        assert!((raw.texels[0].x - 128.0 / 255.0).abs() < 1e-6);
        // An EXR keeps its values.
        let exr = dir.path().join("a.exr");
        image::Rgb32FImage::from_raw(1, 1, vec![5.0, 0.25, 0.0])
            .unwrap()
            .save(&exr)
            .unwrap();
        assert_eq!(
            read_linear_rgb(&exr, false).unwrap().texels[0],
            Rgb::new(5.0, 0.25, 0.0)
        );
        // Not an image; missing.
        let txt = dir.path().join("a.hdr");
        std::fs::write(&txt, "hello").unwrap();
        assert!(read_linear_rgb(&txt, false)
            .unwrap_err()
            .contains("not an image"));
        assert!(read_linear_rgb(&dir.path().join("none.exr"), false)
            .unwrap_err()
            .contains("none.exr"));
    }
}
