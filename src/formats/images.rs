//! Reading images that scenes name (environment maps, textures): any format the `image` crate decodes
//! here (OpenEXR, Radiance HDR, PNG, JPEG, TGA) and PFM ([`super::pfm`]), capped in size before
//! anything is allocated, as linear
//! RGB. 8- and 16-bit images are decoded from sRGB, as Mitsuba 3 does, unless they hold data
//! (`raw`); float images are taken as they are. Texels that are not finite are refused.

use raylab_integrators::texture::Texels;
use raylab_integrators::Rgb;
use std::io::Cursor;
use std::path::Path;
use std::sync::Arc;

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

/// `file`'s error message for `e`.
fn cannot(file: &Path, e: &dyn std::fmt::Display) -> String {
    format!("cannot load image `{}`: {e}", file.display())
}

/// Reads and decodes `file` as a texture's texels: an 8-bit image as its bytes and the
/// linear value of each byte (the values [`read_linear_rgb`] gives it, bit for bit: the
/// table goes through the same conversions), any other as [`read_linear_rgb`] reads it. Returns
/// (width, height, texels).
pub fn read_texels(file: &Path, raw: bool) -> Result<(usize, usize, Texels), String> {
    let decoded = decode(file, |colour| match colour {
        image::ColorType::L8
        | image::ColorType::La8
        | image::ColorType::Rgb8
        | image::ColorType::Rgba8 => BYTE_BYTES_PER_PIXEL,
        _ => FLOAT_BYTES_PER_PIXEL,
    })?;
    // Every byte value, as a grey image of the same layout: the decoder's conversion to
    // floats differs from layout to layout in its rounding.
    use image::DynamicImage as D;
    let byte = |x: u32| x as u8;
    let ramp = match decoded {
        D::ImageLuma8(_) => D::ImageLuma8(image::GrayImage::from_fn(256, 1, |x, _| {
            image::Luma([byte(x)])
        })),
        D::ImageLumaA8(_) => D::ImageLumaA8(image::GrayAlphaImage::from_fn(256, 1, |x, _| {
            image::LumaA([byte(x), 255])
        })),
        D::ImageRgb8(_) => D::ImageRgb8(image::RgbImage::from_fn(256, 1, |x, _| {
            image::Rgb([byte(x); 3])
        })),
        D::ImageRgba8(_) => D::ImageRgba8(image::RgbaImage::from_fn(256, 1, |x, _| {
            image::Rgba([byte(x), byte(x), byte(x), 255])
        })),
        _ => {
            let image = to_linear(file, decoded, raw)?;
            return Ok((
                image.width,
                image.height,
                Texels::Float(image.texels.into()),
            ));
        }
    };
    let ramp = to_linear(file, ramp, raw)?;
    let table: [f32; 256] = std::array::from_fn(|i| ramp.texels[i].x);
    let rgba = decoded.into_rgba8();
    let (width, height) = (rgba.width() as usize, rgba.height() as usize);
    let bytes: Arc<[[u8; 4]]> = rgba.pixels().map(|p| p.0).collect();
    Ok((
        width,
        height,
        Texels::Bytes {
            bytes,
            table: Arc::new(table),
        },
    ))
}

/// Reads and decodes `file`; 8- and 16-bit images are decoded from sRGB unless `raw`. The
/// error names the file and what is wrong with it.
pub fn read_linear_rgb(file: &Path, raw: bool) -> Result<LinearImage, String> {
    to_linear(file, decode(file, |_| FLOAT_BYTES_PER_PIXEL)?, raw)
}

/// Bytes per pixel that reading an image as linear floats holds besides the decoded image at
/// its peak: the `f32` RGB copy (12), the texels (16), and either the texture's shared copy of
/// them or an environment map's sampling tables and octahedral remap (16 at most). Measured:
/// 28.4 bytes a pixel in all for a 5000 x 5000 grey PNG as an environment map.
const FLOAT_BYTES_PER_PIXEL: u64 = 44;

/// The same for a texture of 8-bit texels: its RGBA copy, and the shared bytes, collected
/// and then moved into their shared allocation (4 each). Measured: 12.4 bytes a pixel in all
/// for a 5000 x 5000 grey PNG.
const BYTE_BYTES_PER_PIXEL: u64 = 12;

/// Reads and decodes `file`, within the size and memory caps: the image's size, read from its
/// header, is refused when the decoded image and the `extra` bytes per pixel that will be made
/// of it (given its colour type) do not fit in the memory this process may use.
fn decode(
    file: &Path,
    extra: impl Fn(image::ColorType) -> u64,
) -> Result<image::DynamicImage, String> {
    let bytes =
        crate::files::read_capped(file, crate::files::MAX_BINARY).map_err(|e| cannot(file, &e))?;
    decode_bytes(file, &bytes, extra)
}

/// The image `file`'s `bytes` hold as linear RGB, as [`read_linear_rgb`] reads a file (what
/// the fuzzer feeds: any bytes, an error or an image, never a panic).
pub fn parse_linear_rgb(file: &Path, bytes: &[u8], raw: bool) -> Result<LinearImage, String> {
    to_linear(
        file,
        decode_bytes(file, bytes, |_| FLOAT_BYTES_PER_PIXEL)?,
        raw,
    )
}

/// [`decode`] of bytes read already; `file` names them (and its extension says TGA).
fn decode_bytes(
    file: &Path,
    bytes: &[u8],
    extra: impl Fn(image::ColorType) -> u64,
) -> Result<image::DynamicImage, String> {
    use image::ImageDecoder as _;
    let cannot = |e: &dyn std::fmt::Display| cannot(file, e);
    if super::pfm::is_pfm(bytes) {
        let room = crate::system::memory_limit().map(|(room, _)| room);
        let (w, h, values) = super::pfm::decode(bytes, room).map_err(|e| cannot(&e))?;
        let image = image::Rgb32FImage::from_raw(w, h, values)
            .ok_or_else(|| cannot(&"its size does not match its values"))?;
        return Ok(image::DynamicImage::ImageRgb32F(image));
    }
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| cannot(&e))?;
    if reader.format().is_none() {
        // TGA has no signature to guess from: its name says it.
        if let Ok(f @ image::ImageFormat::Tga) = image::ImageFormat::from_path(file) {
            reader.set_format(f);
        }
    }
    if reader.format().is_none() {
        return Err(cannot(
            &"it is not an image raylab reads (OpenEXR, Radiance HDR, PNG, JPEG, TGA, BMP or PFM)",
        ));
    }
    let mut decoder = reader.into_decoder().map_err(|e| cannot(&e))?;
    decoder
        .set_limits(crate::files::image_limits())
        .map_err(|e| cannot(&e))?;
    let (w, h) = decoder.dimensions();
    let colour = decoder.color_type();
    let per_pixel = colour.bytes_per_pixel() as u64 + extra(colour);
    let need = (w as u64 * h as u64).saturating_mul(per_pixel);
    if let Some((room, what)) = crate::system::memory_limit() {
        if need > room {
            return Err(cannot(&format_args!(
                "it is {w} x {h} pixels, which take {need} bytes of memory as raylab holds them, more than the {room} bytes {what}"
            )));
        }
    }
    image::DynamicImage::from_decoder(decoder).map_err(|e| cannot(&e))
}

/// `decoded` (read from `file`) as linear RGB: 8- and 16-bit images decoded from sRGB unless
/// `raw`; texels that are not finite refused.
fn to_linear(file: &Path, decoded: image::DynamicImage, raw: bool) -> Result<LinearImage, String> {
    let cannot = |e: &dyn std::fmt::Display| cannot(file, e);
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

    /// An 8-bit image read as a texture's bytes gives, texel by texel and bit for bit, what
    /// reading it as linear floats gives, in every 8-bit layout, decoded from sRGB or raw; a
    /// 16-bit image stays floats.
    #[test]
    fn texture_bytes_decode_to_the_linear_floats_exactly() {
        use image::DynamicImage as D;
        let dir = tempfile::tempdir().unwrap();
        let bytes = |n: usize| (0..n).map(|i| (i * 37 % 256) as u8).collect::<Vec<u8>>();
        let (w, h) = (64u32, 16u32);
        let n = (w * h) as usize;
        let images = [
            (
                "luma",
                D::ImageLuma8(image::GrayImage::from_raw(w, h, bytes(n)).unwrap()),
            ),
            (
                "luma-alpha",
                D::ImageLumaA8(image::GrayAlphaImage::from_raw(w, h, bytes(2 * n)).unwrap()),
            ),
            (
                "rgb",
                D::ImageRgb8(image::RgbImage::from_raw(w, h, bytes(3 * n)).unwrap()),
            ),
            (
                "rgba",
                D::ImageRgba8(image::RgbaImage::from_raw(w, h, bytes(4 * n)).unwrap()),
            ),
        ];
        for (name, img) in images {
            let path = dir.path().join(format!("{name}.png"));
            img.save(&path).unwrap();
            for raw in [false, true] {
                let floats = read_linear_rgb(&path, raw).unwrap();
                let (tw, th, texels) = read_texels(&path, raw).unwrap();
                assert_eq!((tw, th), (floats.width, floats.height));
                assert!(matches!(texels, Texels::Bytes { .. }), "{name}");
                let bits = |t: Rgb| t.to_array().map(f32::to_bits);
                assert!(
                    texels
                        .iter()
                        .map(bits)
                        .eq(floats.texels.iter().map(|&t| bits(t))),
                    "{name}, raw {raw}: the bytes decode differently"
                );
            }
        }
        let path = dir.path().join("sixteen.png");
        D::ImageRgb16(image::ImageBuffer::from_raw(2, 1, vec![0u16, 300, 65535, 7, 8, 9]).unwrap())
            .save(&path)
            .unwrap();
        let (_, _, texels) = read_texels(&path, false).unwrap();
        assert!(matches!(texels, Texels::Float(_)));
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
        // As a texture: the 8-bit PNG as bytes, giving the same texels.
        let (w, h, texels) = read_texels(&png, false).unwrap();
        assert_eq!((w, h), (2, 1));
        assert!(matches!(texels, Texels::Bytes { .. }));
        assert_eq!(texels.iter().collect::<Vec<_>>(), img.texels);
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
