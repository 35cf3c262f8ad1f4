//! Textures: spatially varying material parameters, looked up by a hit's texture coordinates.
//!
//! The kinds and their conventions are Mitsuba 3's, so that a scene renders the same in both:
//!
//! * [`Texture::Image`] (Mitsuba's `bitmap`): `v = 0` is the image's top row; bilinear
//!   filtering interpolates between texel centres (`uv * size - 0.5`), nearest takes the texel
//!   under `uv * size`; out-of-range texels wrap by `repeat`, `clamp` or `mirror` (the edge
//!   texel repeated, as OpenGL's mirrored repeat).
//! * [`Texture::Checkerboard`]: `color0` where the fractional parts of `u` and `v` are both at
//!   most or both above one half, `color1` elsewhere.
//!
//! Both map the hit's `uv` through an affine transform first (Mitsuba's `to_uv`). A scalar
//! parameter (a roughness) reads a colour texture's luminance, as Mitsuba's `eval_1` does.

use crate::{luminance, Rgb};
use glam::{Affine2, Vec2};
use std::sync::Arc;

/// How lookups between texels are filtered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TextureFilter {
    #[default]
    Bilinear,
    Nearest,
}

/// What lookups outside `[0, 1]^2` read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    #[default]
    Repeat,
    Clamp,
    Mirror,
}

impl Wrap {
    /// `x` moved by whole periods of the wrap (1 for repeat, 2 for mirror) into a small range,
    /// or clamped just outside `[0, 1]`: the same texels and weights, with texel indices that
    /// stay small for any finite coordinate.
    #[inline]
    fn reduce(self, x: f32) -> f32 {
        match self {
            Wrap::Repeat => x - x.floor(),
            Wrap::Mirror => x.rem_euclid(2.0),
            Wrap::Clamp => x.clamp(-1.0, 2.0),
        }
    }

    /// Texel index `i` of a row or column of `n` texels, wrapped into `0..n`.
    #[inline]
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        let wrapped = match self {
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        };
        wrapped as usize
    }
}

/// An image's texels, row by row from the top: linear RGB floats, or the bytes of an 8-bit
/// image with the 256 linear values they decode to.
///
/// An 8-bit image takes a quarter of the memory as bytes (4 per texel against 16), and its
/// lookups miss the cache less: a 256x256 texture is 256 KiB instead of 1 MiB, and a textured
/// scene spent 10% of its time on those misses (`docs/performance.md`). The table holds the
/// same floats the decoder gives, so both forms give the same texels, bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    Float(Arc<[Rgb]>),
    /// Each texel's red, green and blue bytes (the fourth is padding), and what each byte
    /// value means as a linear value.
    Bytes {
        bytes: Arc<[[u8; 4]]>,
        table: Arc<[f32; 256]>,
    },
}

impl Texels {
    pub fn len(&self) -> usize {
        match self {
            Texels::Float(t) => t.len(),
            Texels::Bytes { bytes, .. } => bytes.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Texel `i` as linear RGB.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Rgb {
        match self {
            Texels::Float(t) => t[i],
            Texels::Bytes { bytes, table } => {
                let [r, g, b, _] = bytes[i];
                Rgb::new(table[r as usize], table[g as usize], table[b as usize])
            }
        }
    }

    /// Every texel, in order, as linear RGB.
    pub fn iter(&self) -> impl Iterator<Item = Rgb> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

/// An image's texels (shared by every texture that reads the file), with its filter and wrap
/// mode.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageTexture {
    width: usize,
    height: usize,
    texels: Texels,
    filter: TextureFilter,
    wrap: Wrap,
}

impl ImageTexture {
    /// The texture over `texels` (`width * height`, row by row from the top; at least one).
    /// `None` when the sizes do not match.
    pub fn new(
        width: usize,
        height: usize,
        texels: Texels,
        filter: TextureFilter,
        wrap: Wrap,
    ) -> Option<ImageTexture> {
        (width > 0 && height > 0 && width.checked_mul(height) == Some(texels.len())).then_some(
            ImageTexture {
                width,
                height,
                texels,
                filter,
                wrap,
            },
        )
    }

    /// `uv` reduced by the wrap mode ([`Wrap::reduce`]).
    #[inline]
    fn reduced(&self, uv: Vec2) -> Vec2 {
        Vec2::new(self.wrap.reduce(uv.x), self.wrap.reduce(uv.y))
    }

    #[inline]
    fn texel(&self, x: i64, y: i64) -> Rgb {
        let (x, y) = (
            self.wrap.index(x, self.width),
            self.wrap.index(y, self.height),
        );
        self.texels.get(y * self.width + x)
    }

    /// The four texels around `uv` and the bilinear weights of the far ones.
    #[inline]
    fn corners(&self, uv: Vec2) -> ([Rgb; 4], Vec2) {
        let size = Vec2::new(self.width as f32, self.height as f32);
        let pos = self.reduced(uv) * size - 0.5;
        let base = pos.floor();
        let w = pos - base;
        let (x, y) = (base.x as i64, base.y as i64);
        (
            [
                self.texel(x, y),
                self.texel(x + 1, y),
                self.texel(x, y + 1),
                self.texel(x + 1, y + 1),
            ],
            w,
        )
    }

    /// The filtered colour at `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        if !uv.is_finite() {
            return Rgb::ZERO;
        }
        match self.filter {
            TextureFilter::Nearest => {
                let size = Vec2::new(self.width as f32, self.height as f32);
                let p = (self.reduced(uv) * size).floor();
                self.texel(p.x as i64, p.y as i64)
            }
            TextureFilter::Bilinear => {
                let ([f00, f10, f01, f11], w) = self.corners(uv);
                (f00 * (1.0 - w.x) + f10 * w.x) * (1.0 - w.y)
                    + (f01 * (1.0 - w.x) + f11 * w.x) * w.y
            }
        }
    }

    /// The gradient of the luminance along `u` and `v` at `uv` (zero for nearest filtering,
    /// which is piecewise constant): what a bump map differentiates.
    pub fn luminance_gradient(&self, uv: Vec2) -> Vec2 {
        if self.filter == TextureFilter::Nearest || !uv.is_finite() {
            return Vec2::ZERO;
        }
        let ([f00, f10, f01, f11], w) = self.corners(uv);
        let [f00, f10, f01, f11] = [f00, f10, f01, f11].map(luminance);
        let dx = (1.0 - w.y) * (f10 - f00) + w.y * (f11 - f01);
        let dy = (1.0 - w.x) * (f01 - f00) + w.x * (f11 - f10);
        Vec2::new(dx * self.width as f32, dy * self.height as f32)
    }

    /// The largest and smallest value of any channel of any texel: what a filtered lookup
    /// stays within.
    pub fn range(&self) -> (f32, f32) {
        self.texels
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), t| {
                (lo.min(t.min_element()), hi.max(t.max_element()))
            })
    }

    /// The mean of the texels (what Mitsuba 3's `mean()` is for a bitmap).
    pub fn mean(&self) -> Rgb {
        let sum = self.texels.iter().fold(glam::DVec3::ZERO, |s, t| {
            s + glam::DVec3::new(t.x as f64, t.y as f64, t.z as f64)
        });
        let m = sum / self.texels.len() as f64;
        Rgb::new(m.x as f32, m.y as f32, m.z as f32)
    }

    /// The largest value of each channel over the texels.
    pub fn max(&self) -> Rgb {
        self.texels
            .iter()
            .fold(Rgb::splat(f32::NEG_INFINITY), |m, t| m.max(t))
    }
}

/// A material parameter: a constant, or a texture over the surface's `uv`.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Rgb),
    /// An image's texels times `scale` (pbrt-v4's `scale` on an image, or a scale texture of
    /// one).
    Image {
        image: Arc<ImageTexture>,
        to_uv: Affine2,
        scale: f32,
    },
    Checkerboard {
        color0: Rgb,
        color1: Rgb,
        to_uv: Affine2,
    },
    /// The attribute the hit mesh carries (Mitsuba 3's `mesh_attribute`): a vertex colour
    /// interpolated, or a face's value. Only a material's parameters read it (through
    /// [`Texture::at`]), times `scale`; a lookup by `uv` alone sees black.
    Attribute {
        scale: f32,
    },
    /// `(1 - amount) tex0 + amount tex1`, `amount` read as a number (pbrt-v4's `mix`; a
    /// Mitsuba `blendbsdf` of two diffuse reflectances by a texture).
    Mix(Box<[Texture; 3]>),
}

/// Where a material's textures are looked up: the hit's texture coordinates and the mesh
/// attribute it carries.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TextureLookup {
    pub uv: Vec2,
    pub attribute: Rgb,
}

impl TextureLookup {
    /// The lookup at a hit (parametrised).
    #[inline]
    pub fn at(hit: &crate::Hit) -> TextureLookup {
        TextureLookup {
            uv: hit.uv,
            attribute: hit.attribute,
        }
    }
}

impl Texture {
    /// The colour at a hit: [`Texture::eval`] at its `uv`, the hit's mesh attribute for
    /// [`Texture::Attribute`].
    #[inline]
    pub fn at(&self, l: &TextureLookup) -> Rgb {
        match self {
            Texture::Attribute { scale } => l.attribute * *scale,
            Texture::Mix(t) => {
                let a = t[2].at_scalar(l);
                t[0].at(l) * (1.0 - a) + t[1].at(l) * a
            }
            _ => self.eval(l.uv),
        }
    }

    /// A scalar parameter at a hit: the colour's luminance.
    #[inline]
    pub fn at_scalar(&self, l: &TextureLookup) -> f32 {
        luminance(self.at(l))
    }

    /// Whether the texture reads the hit's mesh attribute.
    pub fn reads_attribute(&self) -> bool {
        match self {
            Texture::Attribute { .. } => true,
            Texture::Mix(t) => t.iter().any(Texture::reads_attribute),
            _ => false,
        }
    }

    /// The colour at texture coordinates `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image {
                image,
                to_uv,
                scale,
            } => image.eval(to_uv.transform_point2(uv)) * *scale,
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.transform_point2(uv);
                let f = p - p.floor();
                if (f.x > 0.5) == (f.y > 0.5) {
                    *color0
                } else {
                    *color1
                }
            }
            Texture::Attribute { .. } => Rgb::ZERO,
            Texture::Mix(t) => {
                let a = t[2].eval_scalar(uv);
                t[0].eval(uv) * (1.0 - a) + t[1].eval(uv) * a
            }
        }
    }

    /// A scalar parameter at `uv`: the colour's luminance (a grey texture's value).
    #[inline]
    pub fn eval_scalar(&self, uv: Vec2) -> f32 {
        luminance(self.eval(uv))
    }

    /// The gradient of [`Texture::eval_scalar`] with respect to the surface's `uv`: an
    /// image's is exact for bilinear filtering (chained through `to_uv`); a constant's and a
    /// checkerboard's (a step) are zero.
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Image {
                image,
                to_uv,
                scale,
            } => {
                let g = image.luminance_gradient(to_uv.transform_point2(uv));
                to_uv.matrix2.transpose() * g * *scale
            }
            Texture::Constant(_) | Texture::Checkerboard { .. } | Texture::Attribute { .. } => {
                Vec2::ZERO
            }
            Texture::Mix(t) => {
                // d/duv of (1 - a) x + a y = (1 - a) dx + a dy + (y - x) da, by luminance.
                let (a, (x, y)) = (
                    t[2].eval_scalar(uv),
                    (t[0].eval_scalar(uv), t[1].eval_scalar(uv)),
                );
                t[0].gradient(uv) * (1.0 - a) + t[1].gradient(uv) * a + t[2].gradient(uv) * (y - x)
            }
        }
    }

    /// The smallest and largest channel value the texture takes anywhere.
    pub fn range(&self) -> (f32, f32) {
        match self {
            Texture::Constant(c) => (c.min_element(), c.max_element()),
            Texture::Image { image, scale, .. } => {
                let (lo, hi) = image.range();
                let (a, b) = (lo * scale, hi * scale);
                (a.min(b), a.max(b))
            }
            Texture::Checkerboard { color0, color1, .. } => (
                color0.min_element().min(color1.min_element()),
                color0.max_element().max(color1.max_element()),
            ),
            // The loader keeps attributes read as colours within [0, 1].
            Texture::Attribute { scale } => (0.0_f32.min(*scale), 0.0_f32.max(*scale)),
            Texture::Mix(t) => {
                let ((a0, a1), (b0, b1)) = (t[0].range(), t[1].range());
                (a0.min(b0), a1.max(b1))
            }
        }
    }

    /// The texture's mean over the unit square of texture space: what a material's constant
    /// form (and its lobe-sampling weights) is made from.
    pub fn mean(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image { image, scale, .. } => image.mean() * *scale,
            Texture::Checkerboard { color0, color1, .. } => (*color0 + *color1) * 0.5,
            // Unknown until a mesh carries it: the middle of its range.
            Texture::Attribute { scale } => Rgb::splat(0.5 * scale),
            Texture::Mix(t) => {
                let a = luminance(t[2].mean()).clamp(0.0, 1.0);
                t[0].mean() * (1.0 - a) + t[1].mean() * a
            }
        }
    }

    /// An image's width over its height (`None` for the others).
    pub fn aspect(&self) -> Option<f32> {
        match self {
            Texture::Image { image, .. } => Some(image.width as f32 / image.height as f32),
            _ => None,
        }
    }

    /// The largest value of each channel the texture takes anywhere.
    pub fn max(&self) -> Rgb {
        match self {
            Texture::Constant(c) => *c,
            // The scale is not negative (the loader checks).
            Texture::Image { image, scale, .. } => image.max() * *scale,
            Texture::Checkerboard { color0, color1, .. } => color0.max(*color1),
            Texture::Attribute { scale } => Rgb::splat(scale.max(0.0)),
            Texture::Mix(t) => t[0].max().max(t[1].max()),
        }
    }
}

/// A test texture of two columns and one row, 1 on the left (u < 1/2) and 3 on the right,
/// looked up by nearest texel: where a lookup lands is plain from its value.
#[cfg(test)]
pub(crate) fn two_columns() -> Texture {
    let texels = Texels::Float(vec![Rgb::splat(1.0), Rgb::splat(3.0)].into());
    let image = ImageTexture::new(2, 1, texels, TextureFilter::Nearest, Wrap::Clamp).unwrap();
    Texture::Image {
        image: Arc::new(image),
        to_uv: Affine2::IDENTITY,
        scale: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(filter: TextureFilter, wrap: Wrap) -> ImageTexture {
        // 4 x 2: red runs 0, 1, 2, 3 along x; green 0 on the top row, 10 on the bottom.
        let texels: Vec<Rgb> = (0..8)
            .map(|i| Rgb::new((i % 4) as f32, 10.0 * (i / 4) as f32, 0.0))
            .collect();
        ImageTexture::new(4, 2, Texels::Float(texels.into()), filter, wrap).unwrap()
    }

    #[test]
    fn texel_centres_return_the_texels_and_v_runs_down_the_image() {
        let t = ramp(TextureFilter::Bilinear, Wrap::Clamp);
        for x in 0..4 {
            for y in 0..2 {
                let uv = Vec2::new((x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 2.0);
                assert_eq!(t.eval(uv), Rgb::new(x as f32, 10.0 * y as f32, 0.0));
            }
        }
        // Halfway between texel centres: the mean.
        let mid = t.eval(Vec2::new(0.25, 0.5));
        assert!((mid - Rgb::new(0.5, 5.0, 0.0)).length() < 1e-5, "{mid}");
    }

    #[test]
    fn wrap_modes_follow_mitsuba() {
        for (wrap, expected) in [
            // index -1, -2, 4, 5 of a row of 4
            (Wrap::Repeat, [3, 2, 0, 1]),
            (Wrap::Clamp, [0, 0, 3, 3]),
            (Wrap::Mirror, [0, 1, 3, 2]),
        ] {
            let got = [-1, -2, 4, 5].map(|i| wrap.index(i, 4));
            assert_eq!(got, expected, "{wrap:?}");
        }
        let t = ramp(TextureFilter::Nearest, Wrap::Repeat);
        assert_eq!(t.eval(Vec2::new(1.1, 0.2)).x, 0.0);
        assert_eq!(t.eval(Vec2::new(-0.1, 0.2)).x, 3.0);
        assert_eq!(t.eval(Vec2::new(f32::NAN, 0.2)), Rgb::ZERO);
        // Far-away coordinates wrap like near ones (no overflow of the texel index).
        for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            for filter in [TextureFilter::Nearest, TextureFilter::Bilinear] {
                let t = ramp(filter, wrap);
                for uv in [
                    Vec2::new(1e30, -1e30),
                    Vec2::splat(f32::MAX),
                    Vec2::new(3e9, 0.3),
                ] {
                    assert!(t.eval(uv).is_finite() && t.luminance_gradient(uv).is_finite());
                }
            }
        }
        let far = ramp(TextureFilter::Bilinear, Wrap::Repeat);
        let (a, b) = (
            far.eval(Vec2::new(0.3, 0.3)),
            far.eval(Vec2::new(1024.3, 0.3)),
        );
        assert!((a - b).length() < 1e-3, "{a} vs {b}");
    }

    #[test]
    fn checkerboard_follows_mitsuba() {
        let c = Texture::Checkerboard {
            color0: Rgb::splat(0.4),
            color1: Rgb::splat(0.2),
            to_uv: Affine2::from_scale(Vec2::splat(2.0)),
        };
        // uv (0.1, 0.1) -> (0.2, 0.2): both halves low, color0; (0.3, 0.1) -> (0.6, 0.2):
        // color1; (0.3, 0.3) -> (0.6, 0.6): both high, color0.
        assert_eq!(c.eval(Vec2::new(0.1, 0.1)).x, 0.4);
        assert_eq!(c.eval(Vec2::new(0.3, 0.1)).x, 0.2);
        assert_eq!(c.eval(Vec2::new(0.3, 0.3)).x, 0.4);
        assert_eq!(c.gradient(Vec2::new(0.3, 0.3)), Vec2::ZERO);
        assert_eq!(c.range(), (0.2, 0.4));
    }

    #[test]
    fn the_gradient_is_the_derivative_of_the_lookup() {
        let image = Arc::new(ramp(TextureFilter::Bilinear, Wrap::Repeat));
        let t = Texture::Image {
            image,
            to_uv: Affine2::from_scale_angle_translation(Vec2::new(1.5, 0.7), 0.3, Vec2::X),
            scale: 1.3,
        };
        let h = 1e-3;
        for uv in [Vec2::new(0.31, 0.42), Vec2::new(0.77, 0.13)] {
            let g = t.gradient(uv);
            let fd = Vec2::new(
                t.eval_scalar(uv + Vec2::X * h) - t.eval_scalar(uv - Vec2::X * h),
                t.eval_scalar(uv + Vec2::Y * h) - t.eval_scalar(uv - Vec2::Y * h),
            ) / (2.0 * h);
            assert!(
                (g - fd).length() < 1e-2 * (1.0 + fd.length()),
                "{g} vs {fd}"
            );
        }
    }
}
