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

use super::access::SceneFiles;
use super::images::read_texels;
use super::schema::V3;
use glam::{Affine2, Vec2, Vec3A};
use raylab_integrators::texture::{self, ImageTexture, Texture, TextureFilter, Wrap};
use serde::de::{self, Deserialize, Deserializer};
use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::Arc;

/// A texture as a scene file gives it.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureDesc {
    Image(ImageDesc),
    Checkerboard(CheckerboardDesc),
}

/// `Image(...)`: Mitsuba's `bitmap`.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageDesc {
    /// Relative to the scene file.
    pub path: String,
    /// `"bilinear"` (default) or `"nearest"`.
    #[serde(default = "bilinear")]
    pub filter: String,
    /// `"repeat"` (default), `"clamp"` or `"mirror"`.
    #[serde(default = "repeat")]
    pub wrap: String,
    /// Take 8- and 16-bit texels as they are instead of decoding sRGB. Default: false for
    /// colours, true for data.
    #[serde(default, deserialize_with = "optional_bool")]
    pub raw: Option<bool>,
    #[serde(default = "unit_scale")]
    pub uv_scale: [f32; 2],
    #[serde(default)]
    pub uv_offset: [f32; 2],
}

/// `Checkerboard(...)`: Mitsuba's `checkerboard`, one square of each colour per unit of `uv`
/// in each direction (`uv_scale: (4, 4)` gives 8 x 8 squares over a rectangle).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerboardDesc {
    /// `(r, g, b)` or a grey number. Default: 0.4 grey.
    #[serde(default = "grey40", deserialize_with = "rgb_or_grey")]
    pub color0: V3,
    /// Default: 0.2 grey.
    #[serde(default = "grey20", deserialize_with = "rgb_or_grey")]
    pub color1: V3,
    #[serde(default = "unit_scale")]
    pub uv_scale: [f32; 2],
    #[serde(default)]
    pub uv_offset: [f32; 2],
}

/// A flag written as `true`, or as `Some(true)` (the fields of a texture arrive without
/// RON's implicit `Some`).
fn optional_bool<'de, D: Deserializer<'de>>(d: D) -> Result<Option<bool>, D::Error> {
    #[derive(serde::Deserialize)]
    #[serde(untagged)]
    enum Either {
        Bare(bool),
        Wrapped(Option<bool>),
    }
    match Either::deserialize(d).map_err(|_| de::Error::custom("expected true or false"))? {
        Either::Bare(b) => Ok(Some(b)),
        Either::Wrapped(b) => Ok(b),
    }
}

/// A colour written as `(r, g, b)` or as one grey number.
fn rgb_or_grey<'de, D: Deserializer<'de>>(d: D) -> Result<V3, D::Error> {
    #[derive(serde::Deserialize)]
    #[serde(untagged)]
    enum Either {
        Grey(f32),
        Rgb(V3),
    }
    match Either::deserialize(d).map_err(|_| de::Error::custom("expected (r, g, b) or a number"))? {
        Either::Grey(g) => Ok([g; 3]),
        Either::Rgb(c) => Ok(c),
    }
}

fn bilinear() -> String {
    "bilinear".into()
}
fn repeat() -> String {
    "repeat".into()
}
fn unit_scale() -> [f32; 2] {
    [1.0, 1.0]
}
fn grey40() -> V3 {
    [0.4; 3]
}
fn grey20() -> V3 {
    [0.2; 3]
}

/// A colour parameter: a constant or a texture.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorDesc {
    Constant(V3),
    Texture(TextureDesc),
}

/// A scalar parameter (a roughness): a constant or a texture.
#[derive(Clone, Debug, PartialEq)]
pub enum FloatDesc {
    Constant(f32),
    Texture(TextureDesc),
}

impl From<V3> for ColorDesc {
    fn from(c: V3) -> Self {
        ColorDesc::Constant(c)
    }
}

/// What a parameter's RON value can be, before it is known to be right. RON keeps a
/// struct-like value's name only through serde's untagged path, so the value is read as one
/// of these and then checked, with messages that say what was expected.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum Raw {
    Number(f32),
    Sequence(Vec<f32>),
    /// `Name(fields...)`, as a map from the name to its fields.
    Named(BTreeMap<String, ron::Value>),
}

const EXPECTED_COLOUR: &str =
    "a colour: (r, g, b), a grey number, Image(path: ...) or Checkerboard(...)";
const EXPECTED_FLOAT: &str = "a number or a texture: Image(path: ...) or Checkerboard(...)";

fn texture_from_named<E: de::Error>(named: BTreeMap<String, ron::Value>) -> Result<TextureDesc, E> {
    let mut entries = named.into_iter();
    let (Some((name, fields)), None) = (entries.next(), entries.next()) else {
        return Err(E::custom(EXPECTED_COLOUR));
    };
    let inner = |e: ron::Error| E::custom(format!("in {name}(...): {e}"));
    match name.as_str() {
        "Image" => fields.into_rust().map(TextureDesc::Image).map_err(inner),
        "Checkerboard" => fields
            .into_rust()
            .map(TextureDesc::Checkerboard)
            .map_err(inner),
        _ => Err(E::custom(format!(
            "unknown texture `{name}`; known: Image, Checkerboard"
        ))),
    }
}

impl<'de> Deserialize<'de> for ColorDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match Raw::deserialize(d).map_err(|_| de::Error::custom(EXPECTED_COLOUR))? {
            Raw::Number(g) => Ok(ColorDesc::Constant([g; 3])),
            Raw::Sequence(v) => <V3>::try_from(v.as_slice())
                .map(ColorDesc::Constant)
                .map_err(|_| {
                    de::Error::custom(format!("a colour has 3 components, got {}", v.len()))
                }),
            Raw::Named(named) => texture_from_named(named).map(ColorDesc::Texture),
        }
    }
}

impl<'de> Deserialize<'de> for FloatDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match Raw::deserialize(d).map_err(|_| de::Error::custom(EXPECTED_FLOAT))? {
            Raw::Number(x) => Ok(FloatDesc::Constant(x)),
            Raw::Sequence(_) => Err(de::Error::custom(EXPECTED_FLOAT)),
            Raw::Named(named) => texture_from_named(named).map(FloatDesc::Texture),
        }
    }
}

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
            },
        };
        let what = match desc {
            TextureDesc::Image(i) => format!("texture `{}`", i.path),
            TextureDesc::Checkerboard(_) => "checkerboard".to_string(),
        };
        let (lo, hi) = texture.range();
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(format!("{what} has values that are not finite"));
        }
        let range = match role {
            Role::Reflectance => Some(("a reflectance", 0.0, 1.0)),
            Role::Roughness => Some(("a roughness (alpha)", 0.0, 2.0)),
            Role::Data => None,
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
        let raw = desc.raw.unwrap_or(role != Role::Reflectance);
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
        match desc {
            ColorDesc::Constant(c) => Ok((Vec3A::from_array(*c), None)),
            ColorDesc::Texture(t) => {
                let texture = self.texture(t, role)?;
                Ok((texture.mean(), Some(texture)))
            }
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
