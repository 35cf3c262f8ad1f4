//! How a scene file writes a textured parameter (the schema's part of textures): a colour is
//! `(r, g, b)`, a grey number, or a texture, `Image(path: "wood.png")` or `Checkerboard(color0:
//! ..., color1: ...)`; a roughness is a number or a texture. [`crate::scene::textures`] loads them.

use serde::de::{self, Deserialize, Deserializer};
use std::collections::BTreeMap;

/// An RGB triple as the schema writes it.
type V3 = [f32; 3];

/// A texture as a scene file gives it.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureDesc {
    Image(ImageDesc),
    Checkerboard(CheckerboardDesc),
    /// `Attribute(name: "vertex_color")`: the value the shape's mesh carries per vertex
    /// (interpolated) or per face (Mitsuba 3's `mesh_attribute`); the shape names the same
    /// attribute (`Ply(..., attribute: "vertex_color")`).
    Attribute(AttributeDesc),
    /// `Mix(tex0: ..., tex1: ..., amount: ...)`: `(1 - amount) tex0 + amount tex1`, `amount`
    /// read as a number in [0, 1] (pbrt-v4's `mix`).
    Mix(Box<MixDesc>),
}

/// `Attribute(...)`: a mesh attribute by its name, times `scale` (default 1).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct AttributeDesc {
    pub name: String,
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub scale: f32,
}

/// `Mix(...)`: two colours (or textures) blended by a number (or a texture).
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct MixDesc {
    pub tex0: ColorDesc,
    pub tex1: ColorDesc,
    pub amount: FloatDesc,
}

fn is_one(x: &f32) -> bool {
    *x == 1.0
}

impl TextureDesc {
    /// The same texture with every value times `s` (not negative).
    pub fn scaled(self, s: f32) -> TextureDesc {
        match self {
            TextureDesc::Image(i) => TextureDesc::Image(ImageDesc {
                scale: i.scale * s,
                ..i
            }),
            TextureDesc::Checkerboard(c) => TextureDesc::Checkerboard(CheckerboardDesc {
                color0: c.color0.map(|x| x * s),
                color1: c.color1.map(|x| x * s),
                ..c
            }),
            TextureDesc::Attribute(a) => TextureDesc::Attribute(AttributeDesc {
                scale: a.scale * s,
                ..a
            }),
            TextureDesc::Mix(m) => {
                let scaled = |c: ColorDesc| c.scaled(s);
                TextureDesc::Mix(Box::new(MixDesc {
                    tex0: scaled(m.tex0),
                    tex1: scaled(m.tex1),
                    amount: m.amount,
                }))
            }
        }
    }

    /// The names of the mesh attributes the texture reads.
    pub fn attributes(&self, out: &mut Vec<String>) {
        match self {
            TextureDesc::Attribute(a) => out.push(a.name.clone()),
            TextureDesc::Mix(m) => {
                for c in [&m.tex0, &m.tex1] {
                    if let ColorDesc::Texture(t) = c {
                        t.attributes(out);
                    }
                }
                if let FloatDesc::Texture(t) = &m.amount {
                    t.attributes(out);
                }
            }
            TextureDesc::Image(_) | TextureDesc::Checkerboard(_) => {}
        }
    }
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
    /// Multiplies every texel (pbrt-v4's `scale`); default 1, not negative.
    #[serde(default = "one")]
    pub scale: f32,
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
fn one() -> f32 {
    1.0
}
fn grey40() -> V3 {
    [0.4; 3]
}
fn grey20() -> V3 {
    [0.2; 3]
}

/// A colour parameter: a constant, a texture, or a spectrum given by wavelength:
/// `Spectrum([(400, 0.1), (700, 0.8)])`, (nm, value) pairs linear between them and zero
/// outside them (Mitsuba 3's `<spectrum>`). A spectrum is its colour in RGB mode (under D65,
/// clamped to [0, 1]) and itself in spectral mode.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorDesc {
    Constant(V3),
    Texture(TextureDesc),
    Spectrum(Vec<(f64, f64)>),
}

/// A scalar parameter (a roughness): a constant or a texture.
#[derive(Clone, Debug, PartialEq)]
pub enum FloatDesc {
    Constant(f32),
    Texture(TextureDesc),
}

/// Spectrum pairs as the renderer keeps them.
pub fn narrow(pairs: &[(f64, f64)]) -> Vec<(f32, f32)> {
    pairs.iter().map(|&(n, v)| (n as f32, v as f32)).collect()
}

impl ColorDesc {
    /// A spectrum's colour as a reflectance (under D65, clamped to [0, 1]): what it is in RGB
    /// mode, and wherever a parameter cannot be spectral (a map, a mix).
    pub fn spectrum_colour(pairs: &[(f64, f64)]) -> V3 {
        super::spectra::to_srgb(pairs, super::spectra::Use::Reflectance)
            .map_or([0.0; 3], |c| c.map(|x| x as f32))
    }

    /// The parameter times `s` (not negative).
    pub fn scaled(self, s: f32) -> ColorDesc {
        match self {
            ColorDesc::Constant(v) => ColorDesc::Constant(v.map(|x| x * s)),
            ColorDesc::Texture(t) => ColorDesc::Texture(t.scaled(s)),
            ColorDesc::Spectrum(p) => {
                ColorDesc::Spectrum(p.into_iter().map(|(n, v)| (n, v * s as f64)).collect())
            }
        }
    }

    /// The parameter with a spectrum replaced by its colour.
    pub fn without_spectrum(self) -> ColorDesc {
        match self {
            ColorDesc::Spectrum(p) => ColorDesc::Constant(ColorDesc::spectrum_colour(&p)),
            other => other,
        }
    }
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
    "a colour: (r, g, b), a grey number, Image(path: ...), Checkerboard(...) or Spectrum([(nm, value), ...])";
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
        "Attribute" => fields
            .into_rust()
            .map(TextureDesc::Attribute)
            .map_err(inner),
        "Mix" => fields
            .into_rust()
            .map(|m| TextureDesc::Mix(Box::new(m)))
            .map_err(inner),
        _ => Err(E::custom(format!(
            "unknown texture `{name}`; known: Image, Checkerboard, Attribute, Mix"
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
            Raw::Named(named) => match named.get("Spectrum") {
                Some(pairs) if named.len() == 1 => pairs
                    .clone()
                    .into_rust::<Vec<(f64, f64)>>()
                    .map_err(|e| de::Error::custom(format!("in Spectrum(...): {e}")))
                    .and_then(|p| {
                        raylab_integrators::spectrum::curve::Curve::table(&narrow(&p))
                            .map(|_| ColorDesc::Spectrum(p))
                            .map_err(|e| de::Error::custom(format!("in Spectrum(...): {e}")))
                    }),
                _ => texture_from_named(named).map(ColorDesc::Texture),
            },
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

impl serde::Serialize for TextureDesc {
    /// As a scene file writes it: `Image(path: ..., ...)`, `Checkerboard(...)`.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStructVariant;
        match self {
            TextureDesc::Image(d) => {
                let mut v = s.serialize_struct_variant("Texture", 0, "Image", 7)?;
                v.serialize_field("path", &d.path)?;
                v.serialize_field("filter", &d.filter)?;
                v.serialize_field("wrap", &d.wrap)?;
                match d.raw {
                    Some(raw) => v.serialize_field("raw", &raw)?,
                    None => v.skip_field("raw")?,
                }
                v.serialize_field("uv_scale", &d.uv_scale)?;
                v.serialize_field("uv_offset", &d.uv_offset)?;
                if d.scale == 1.0 {
                    v.skip_field("scale")?;
                } else {
                    v.serialize_field("scale", &d.scale)?;
                }
                v.end()
            }
            TextureDesc::Checkerboard(d) => {
                let mut v = s.serialize_struct_variant("Texture", 1, "Checkerboard", 4)?;
                v.serialize_field("color0", &d.color0)?;
                v.serialize_field("color1", &d.color1)?;
                v.serialize_field("uv_scale", &d.uv_scale)?;
                v.serialize_field("uv_offset", &d.uv_offset)?;
                v.end()
            }
            TextureDesc::Attribute(d) => {
                let mut v = s.serialize_struct_variant("Texture", 2, "Attribute", 2)?;
                v.serialize_field("name", &d.name)?;
                if d.scale == 1.0 {
                    v.skip_field("scale")?;
                } else {
                    v.serialize_field("scale", &d.scale)?;
                }
                v.end()
            }
            TextureDesc::Mix(d) => {
                let mut v = s.serialize_struct_variant("Texture", 3, "Mix", 3)?;
                v.serialize_field("tex0", &d.tex0)?;
                v.serialize_field("tex1", &d.tex1)?;
                v.serialize_field("amount", &d.amount)?;
                v.end()
            }
        }
    }
}

impl serde::Serialize for ColorDesc {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            ColorDesc::Constant(c) => c.serialize(s),
            ColorDesc::Texture(t) => t.serialize(s),
            ColorDesc::Spectrum(p) => s.serialize_newtype_variant("Colour", 2, "Spectrum", p),
        }
    }
}

impl serde::Serialize for FloatDesc {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            FloatDesc::Constant(x) => x.serialize(s),
            FloatDesc::Texture(t) => t.serialize(s),
        }
    }
}
