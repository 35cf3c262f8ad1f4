//! Triangle, parallelogram and disk emitters: uniform area sampling, one-sided by default.

use super::{leave, lum, LeSample, LightSample, MIN_COS};
use crate::sampling::{concentric_disk, uniform_triangle};
use crate::texture::Texture;
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Which planar shape `p0, e1, e2` spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanarShape {
    /// `p0, p0 + e1, p0 + e2`.
    Triangle,
    /// `p0 + s e1 + t e2`, `s, t` in `[0, 1]`.
    Parallelogram,
    /// `p0 + s e1 + t e2`, `s^2 + t^2 <= 1`: a disk (an ellipse when `e1` and `e2` differ in
    /// length), Mitsuba 3's `disk` with `p0` its centre and `e1`, `e2` its placed `x` and `y`
    /// axes.
    Disk,
}

/// A planar emitter. `n = normalize(e1 x e2)` is the emitting side unless `two_sided`. Build it
/// with [`Planar::new`] (or [`super::Light::triangle`], [`super::Light::parallelogram`]) so that
/// `n` and `area` are consistent.
#[derive(Clone, Debug, PartialEq)]
pub struct Planar {
    pub shape: PlanarShape,
    /// First vertex (corner).
    pub p0: Vec3A,
    /// First edge from `p0`.
    pub e1: Vec3A,
    /// Second edge from `p0`.
    pub e2: Vec3A,
    /// Unit normal `normalize(e1 x e2)`: the emitting side of a one-sided light.
    pub n: Vec3A,
    /// Area: `|e1 x e2| / 2` for a triangle, `|e1 x e2|` for a parallelogram, `pi |e1 x e2|`
    /// for a disk.
    pub area: f32,
    /// Emitted radiance, W·sr⁻¹·m⁻² per channel.
    pub radiance: Rgb,
    /// Emits on both sides.
    pub two_sided: bool,
    /// A texture over the radiance (Mitsuba's textured `radiance`), boxed: few lights have
    /// one, and every light of a scene takes the largest kind's room.
    pub emission: Option<Box<EmissionTexture>>,
}

/// A texture over a planar light's radiance: looked up at the texture coordinates the points
/// `p0`, `p0 + e1`, `p0 + e2` have (`uvs`), interpolated.
#[derive(Clone, Debug, PartialEq)]
pub struct EmissionTexture {
    pub texture: Texture,
    pub uvs: [Vec2; 3],
}

/// Solid-angle density of uniform area sampling of a planar emitter, seen from a point at
/// squared distance `dist2` under `cos_l = dot(n, -wi)`. Zero when the sample would be
/// rejected (back of a one-sided emitter, grazing, degenerate).
#[inline]
fn planar_pdf(dist2: f32, cos_l: f32, area: f32, two_sided: bool) -> f32 {
    if !two_sided && cos_l <= 0.0 {
        return 0.0;
    }
    let cos = cos_l.abs();
    if !(cos >= MIN_COS && dist2 > 0.0 && area > 0.0) {
        return 0.0;
    }
    let pdf = dist2 / (cos * area);
    if pdf.is_finite() {
        pdf
    } else {
        0.0
    }
}

impl Planar {
    pub fn new(
        shape: PlanarShape,
        p0: Vec3A,
        e1: Vec3A,
        e2: Vec3A,
        radiance: Rgb,
        two_sided: bool,
    ) -> Planar {
        let c = e1.cross(e2);
        let area = match shape {
            PlanarShape::Triangle => 0.5 * c.length(),
            PlanarShape::Parallelogram => c.length(),
            PlanarShape::Disk => PI * c.length(),
        };
        Planar {
            shape,
            p0,
            e1,
            e2,
            n: c.normalize(),
            area,
            radiance,
            two_sided,
            emission: None,
        }
    }

    /// The same light with its radiance times `texture`, looked up at texture coordinates
    /// `uvs` at `p0`, `p0 + e1`, `p0 + e2` (interpolated in between).
    pub fn with_texture(self, texture: Texture, uvs: [Vec2; 3]) -> Planar {
        Planar {
            emission: Some(Box::new(EmissionTexture { texture, uvs })),
            ..self
        }
    }

    /// The radiance leaving the point `q` of the light.
    #[inline]
    pub fn radiance_at(&self, q: Vec3A) -> Rgb {
        let Some(EmissionTexture { texture, uvs }) = self.emission.as_deref() else {
            return self.radiance;
        };
        // q - p0 = s e1 + t e2, solved on the plane.
        let d = q - self.p0;
        let (a, b, c) = (
            self.e1.dot(self.e1),
            self.e1.dot(self.e2),
            self.e2.dot(self.e2),
        );
        let (x, y) = (d.dot(self.e1), d.dot(self.e2));
        let det = a * c - b * b;
        if det == 0.0 || !det.is_finite() {
            return self.radiance * texture.eval(uvs[0]);
        }
        let s = (x * c - y * b) / det;
        let t = (y * a - x * b) / det;
        let uv = uvs[0] + (uvs[1] - uvs[0]) * s + (uvs[2] - uvs[0]) * t;
        self.radiance * texture.eval(uv)
    }

    /// [`Planar::emitted`] from the point `q` of the light.
    #[inline]
    pub fn emitted_at(&self, q: Vec3A, n: Vec3A, w: Vec3A) -> Rgb {
        if self.two_sided || n.dot(w) > 0.0 {
            self.radiance_at(q)
        } else {
            Rgb::ZERO
        }
    }

    /// The point of the shape that `u` picks, uniformly in area.
    #[inline]
    fn point(&self, u: Vec2) -> Vec3A {
        match self.shape {
            PlanarShape::Triangle => {
                let b = uniform_triangle(u);
                self.p0 + self.e1 * b.x + self.e2 * b.y
            }
            PlanarShape::Parallelogram => self.p0 + self.e1 * u.x + self.e2 * u.y,
            // Uniform on the unit disk (Shirley-Chiu), and an affine map keeps uniformity.
            PlanarShape::Disk => {
                let d = concentric_disk(u);
                self.p0 + self.e1 * d.x + self.e2 * d.y
            }
        }
    }

    /// Emitting sides: 2 when two-sided.
    fn sides(&self) -> f32 {
        if self.two_sided {
            2.0
        } else {
            1.0
        }
    }

    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        let q = self.point(u);
        LightSample::on_surface(p, q, self.radiance_at(q), |wi, dist2| {
            planar_pdf(dist2, self.n.dot(-wi), self.area, self.two_sided)
        })
    }

    pub fn pdf_li(&self, p: Vec3A, wi: Vec3A, q: Vec3A) -> f32 {
        planar_pdf(
            (q - p).length_squared(),
            self.n.dot(-wi),
            self.area,
            self.two_sided,
        )
    }

    pub fn emitted(&self, n: Vec3A, w: Vec3A) -> Rgb {
        if self.two_sided || n.dot(w) > 0.0 {
            self.radiance
        } else {
            Rgb::ZERO
        }
    }

    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, u_side: f32) -> LeSample {
        let p = self.point(u_pos);
        let normal = if self.two_sided && u_side < 0.5 {
            -self.n
        } else {
            self.n
        };
        let (ray, cos) = leave(p, normal, u_dir);
        let radiance = self.radiance_at(p);
        LeSample {
            ray,
            radiance: crate::spectrum::of_rgb(radiance),
            normal,
            pdf_pos: 1.0 / self.area,
            pdf_dir: cos / (PI * self.sides()),
            weight: crate::spectrum::of_rgb(radiance * (self.area * PI * self.sides())),
        }
    }

    pub fn pdf_le(&self, w: Vec3A) -> (f32, f32) {
        let cos = self.n.dot(w);
        let cos = if self.two_sided { cos.abs() } else { cos };
        (1.0 / self.area, cos.max(0.0) / (PI * self.sides()))
    }

    pub fn power(&self) -> f64 {
        use std::f64::consts::PI;
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        // A texture: its mean (what the light's own part of it holds, roughly).
        let radiance = match self.emission.as_deref() {
            Some(e) => self.radiance * e.texture.mean(),
            None => self.radiance,
        };
        lum(radiance) * self.area as f64 * PI * sides
    }
}
