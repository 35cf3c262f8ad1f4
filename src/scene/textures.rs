//! Textured material parameters in RON, and their loading.
//!
//! A colour parameter is `(r, g, b)`, a grey number, or a texture: `Image(path: "wood.png")` or
//! `Checkerboard(color0: ..., color1: ...)`; a roughness is a number or a texture (its
//! luminance). Textures take Mitsuba 3's parameters under its names: `filter` (`"bilinear"`,
//! `"nearest"`), `wrap` (`"repeat"`, `"clamp"`, `"mirror"`), `raw`, and the UV transform as
//! `uv_scale` and `uv_offset` (`uv' = uv * uv_scale + uv_offset`).
//!
//! An image is read once however many parameters name it. 8- and 16-bit images are decoded
//! from sRGB unless `raw: true`; `raw` defaults to false for colours and to true for data
//! (roughness, normal and bump maps), which sRGB decoding would distort.

use crate::formats::access::SceneFiles;
use crate::formats::images::read_texels;
use crate::formats::texture_desc::{ColorDesc, FloatDesc, ImageDesc, TextureDesc};
use glam::{Affine2, Vec2, Vec3A};
use raylab_integrators::spectrum::curve::Curve;
use raylab_integrators::texture::{self, ImageTexture, Texture, TextureFilter, Wrap};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

/// What a texture's values mean, which decides how its image is decoded and what range it
/// must stay in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A reflectance or transmittance: in `[0, 1]`, sRGB-decoded by default.
    Reflectance,
    /// A microfacet roughness: in `[0, 2]`, raw by default.
    Roughness,
    /// A normal or bump map: raw by default, any finite values.
    Data,
    /// An emitter's texture (over an area light's radiance, a spot's or projector's image):
    /// sRGB-decoded by default, not negative.
    Emission,
}

/// The texels of a decoded image: width, height, and the texels row by row from the top.
type Texels = (usize, usize, texture::Texels);

/// Reads the scene's textures, each image file once per decoding (sRGB or raw).
pub struct TextureLoader<'a> {
    files: &'a SceneFiles,
    images: HashMap<(PathBuf, bool), Texels>,
    /// The image files asked for since [`TextureLoader::take_read`] was last called.
    read: Vec<PathBuf>,
}

fn uv_transform(scale: [f32; 2], offset: [f32; 2]) -> Result<Affine2, String> {
    if !scale.iter().chain(&offset).all(|x| x.is_finite()) || scale.contains(&0.0) {
        return Err(format!(
            "uv_scale must be finite and non-zero and uv_offset finite, got {scale:?} and {offset:?}"
        ));
    }
    Ok(Affine2::from_scale_angle_translation(
        Vec2::from_array(scale),
        0.0,
        Vec2::from_array(offset),
    ))
}

impl<'a> TextureLoader<'a> {
    pub fn new(files: &'a SceneFiles) -> Self {
        TextureLoader {
            files,
            images: HashMap::new(),
            read: Vec::new(),
        }
    }

    /// The image files the textures made since the last call read (or took from the ones
    /// already read): what a material depends on besides its description.
    pub fn take_read(&mut self) -> Vec<PathBuf> {
        std::mem::take(&mut self.read)
    }

    /// The texture `desc` describes for a parameter of `role`, checked against the role's
    /// range; the message names the file for an image.
    pub fn texture(&mut self, desc: &TextureDesc, role: Role) -> Result<Texture, String> {
        let texture = match desc {
            TextureDesc::Checkerboard(c) => Texture::Checkerboard {
                color0: Vec3A::from_array(c.color0),
                color1: Vec3A::from_array(c.color1),
                to_uv: uv_transform(c.uv_scale, c.uv_offset)?,
            },
            TextureDesc::Image(i) => Texture::Image {
                image: {
                    self.read.push(self.files.dir().join(&i.path));
                    self.image(i, role)?
                },
                to_uv: uv_transform(i.uv_scale, i.uv_offset)?,
                scale: if i.scale.is_finite() && i.scale >= 0.0 {
                    i.scale
                } else {
                    return Err(format!(
                        "texture `{}`: scale must be finite and not negative, got {}",
                        i.path, i.scale
                    ));
                },
            },
            TextureDesc::Attribute(a) => {
                if matches!(role, Role::Data | Role::Emission) {
                    return Err(format!(
                        "the mesh attribute `{}` can be read by a material's colours and numbers only",
                        a.name
                    ));
                }
                if !(a.scale.is_finite() && a.scale >= 0.0) {
                    return Err(format!(
                        "the mesh attribute `{}`: scale must be finite and not negative, got {}",
                        a.name, a.scale
                    ));
                }
                Texture::Attribute { scale: a.scale }
            }
            TextureDesc::Mix(m) => {
                let mut colour = |c: &ColorDesc| match c {
                    ColorDesc::Constant(v) => Ok(Texture::Constant(Vec3A::from_array(*v))),
                    ColorDesc::Spectrum(p) => Ok(Texture::Constant(Vec3A::from_array(
                        ColorDesc::spectrum_colour(p),
                    ))),
                    ColorDesc::Texture(t) => self.texture(t, role),
                };
                let (tex0, tex1) = (colour(&m.tex0)?, colour(&m.tex1)?);
                let amount = match &m.amount {
                    FloatDesc::Constant(x) => Texture::Constant(Vec3A::splat(*x)),
                    FloatDesc::Texture(t) => self.texture(t, Role::Reflectance)?,
                };
                let (lo, hi) = amount.range();
                if !(lo >= 0.0 && hi <= 1.0) {
                    return Err(format!(
                        "a mix's amount must lie in [0, 1], got values from {lo} to {hi}"
                    ));
                }
                Texture::Mix(Box::new([tex0, tex1, amount]))
            }
        };
        let what = match desc {
            TextureDesc::Image(i) => format!("texture `{}`", i.path),
            TextureDesc::Checkerboard(_) => "checkerboard".to_string(),
            TextureDesc::Attribute(a) => format!("mesh attribute `{}`", a.name),
            TextureDesc::Mix(_) => "mix".to_string(),
        };
        let (lo, hi) = texture.range();
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(format!("{what} has values that are not finite"));
        }
        let range = match role {
            Role::Reflectance => Some(("a reflectance", 0.0, 1.0)),
            Role::Roughness => Some(("a roughness (alpha)", 0.0, 2.0)),
            Role::Data => None,
            Role::Emission => Some(("an emission", 0.0, f32::INFINITY)),
        };
        if let Some((kind, min, max)) = range {
            if lo < min || hi > max {
                return Err(format!(
                    "{what} has values from {lo} to {hi}: {kind} must be in [{min}, {max}]"
                ));
            }
        }
        Ok(texture)
    }

    fn image(&mut self, desc: &ImageDesc, role: Role) -> Result<Arc<ImageTexture>, String> {
        let filter = match desc.filter.as_str() {
            "bilinear" => TextureFilter::Bilinear,
            "nearest" => TextureFilter::Nearest,
            other => {
                return Err(format!(
                    "unknown texture filter {other:?}; known: \"bilinear\", \"nearest\""
                ))
            }
        };
        let wrap = match desc.wrap.as_str() {
            "repeat" => Wrap::Repeat,
            "clamp" => Wrap::Clamp,
            "mirror" => Wrap::Mirror,
            other => {
                return Err(format!(
                    "unknown texture wrap mode {other:?}; known: \"repeat\", \"clamp\", \"mirror\""
                ))
            }
        };
        let raw = desc
            .raw
            .unwrap_or(!matches!(role, Role::Reflectance | Role::Emission));
        let file = self.files.named(&desc.path)?;
        let (width, height, texels) = match self.images.get(&(file.clone(), raw)) {
            Some(t) => t.clone(),
            None => {
                let t: Texels = read_texels(&file, raw)?;
                self.images.insert((file.clone(), raw), t.clone());
                t
            }
        };
        ImageTexture::new(width, height, texels, filter, wrap)
            .map(Arc::new)
            .ok_or_else(|| format!("image `{}` has no texels", file.display()))
    }

    /// A colour parameter: the constant, or the texture (and its mean, for the material's
    /// constant form).
    pub fn colour(
        &mut self,
        desc: &ColorDesc,
        role: Role,
    ) -> Result<(Vec3A, Option<Texture>), String> {
        self.colour_or_spectrum(desc, role)
            .map(|(c, texture, _)| (c, texture))
    }

    /// [`TextureLoader::colour`], and the spectrum a parameter given by wavelength is (its
    /// colour stands for it in RGB mode).
    pub fn colour_or_spectrum(
        &mut self,
        desc: &ColorDesc,
        role: Role,
    ) -> Result<(Vec3A, Option<Texture>, Option<Curve>), String> {
        match desc {
            ColorDesc::Constant(c) => Ok((Vec3A::from_array(*c), None, None)),
            ColorDesc::Texture(t) => {
                let texture = self.texture(t, role)?;
                Ok((texture.mean(), Some(texture), None))
            }
            ColorDesc::Spectrum(p)
                if role == Role::Reflectance && p.iter().any(|v| !(0.0..=1.0).contains(&v.1)) =>
            {
                Err("a reflectance's spectrum must lie in [0, 1]".into())
            }
            ColorDesc::Spectrum(p) => Ok((
                Vec3A::from_array(ColorDesc::spectrum_colour(p)),
                None,
                Some(Curve::table(&crate::formats::texture_desc::narrow(p))?),
            )),
        }
    }

    /// A scalar parameter: the constant, or the texture (and its mean luminance).
    pub fn scalar(
        &mut self,
        desc: &FloatDesc,
        role: Role,
    ) -> Result<(f32, Option<Texture>), String> {
        match desc {
            FloatDesc::Constant(x) => Ok((*x, None)),
            FloatDesc::Texture(t) => {
                let texture = self.texture(t, role)?;
                Ok((raylab_integrators::luminance(texture.mean()), Some(texture)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Probe {
        c: ColorDesc,
        #[serde(default)]
        f: Option<FloatDesc>,
    }

    fn parse(s: &str) -> Result<Probe, String> {
        ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str::<Probe>(s)
            .map_err(|e| format!("{}:{}: {}", e.span.start.line, e.span.start.col, e.code))
    }

    #[test]
    fn parameters_read_constants_and_textures() {
        assert_eq!(
            parse("(c: (0.1, 0.2, 0.3))").unwrap().c,
            ColorDesc::Constant([0.1, 0.2, 0.3])
        );
        assert_eq!(parse("(c: 0.5)").unwrap().c, ColorDesc::Constant([0.5; 3]));
        let p = parse(
            "(c: Image(path: \"a.png\", wrap: \"mirror\"), f: Checkerboard(uv_scale: (4, 4)))",
        )
        .unwrap();
        let ColorDesc::Texture(TextureDesc::Image(i)) = p.c else {
            panic!("{:?}", p.c)
        };
        assert_eq!(
            (i.path.as_str(), i.wrap.as_str(), i.filter.as_str(), i.raw),
            ("a.png", "mirror", "bilinear", None)
        );
        let Some(FloatDesc::Texture(TextureDesc::Checkerboard(c))) = p.f else {
            panic!()
        };
        assert_eq!((c.color0, c.uv_scale), ([0.4; 3], [4.0, 4.0]));
    }

    #[test]
    fn mistakes_are_named_with_their_place() {
        for (text, expected) in [
            ("(c: (0.1, 0.2))", "3 components, got 2"),
            ("(c: Foo(path: \"x\"))", "unknown texture `Foo`"),
            ("(c: Image(path: \"x\",\n pth: 1))", "pth"),
            ("(c: \"red\")", "a colour: (r, g, b)"),
            ("(c: 0.5, f: (1, 2))", "a number or a texture"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(expected), "{text}: {e}");
        }
        // The place: the line of the mistake.
        assert!(parse("(c: Image(path: \"x\",\n pth: 1))")
            .unwrap_err()
            .starts_with("2:"));
    }

    #[test]
    fn uv_transforms_scale_then_offset() {
        let t = uv_transform([2.0, 4.0], [0.5, 0.25]).unwrap();
        assert_eq!(
            t.transform_point2(Vec2::new(1.0, 1.0)),
            Vec2::new(2.5, 4.25)
        );
        assert!(uv_transform([0.0, 1.0], [0.0, 0.0]).is_err());
        assert!(uv_transform([1.0, 1.0], [f32::NAN, 0.0]).is_err());
    }
}
