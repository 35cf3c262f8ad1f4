//! A projector (Mitsuba 3's `projector`, RON `Projector`): a point light that throws an
//! image through a pinhole, as a slide projector does. Its frame is the entity's (`z` the axis
//! of projection); a point `q` of that frame ahead of it (`q.z > 0`) is lit through the
//! image's texture coordinates
//!
//! `u = 1/2 - q.x / (2 q.z tan(fov/2))`, `v = 1/2 - aspect q.y / (2 q.z tan(fov/2))`
//!
//! (`fov` the horizontal field of view, `aspect` the image's width over its height; the
//! image's left edge towards the frame's `+x`, as Mitsuba's perspective projection has it), and
//! nothing outside `[0, 1]^2`. The image gives the irradiance on the plane `z = 1` facing the
//! projector: the intensity towards a direction at angle `theta` from the axis is
//! `pi scale E(u, v) / cos^3 theta`, Mitsuba's (its `pi` makes an image of 1 give the
//! irradiance `pi`, as its code has it). A delta in position.
//!
//! Emitted rays take a uniform point of the image (Mitsuba samples the image's values; the
//! weights differ, the estimate is the same).

use super::{lum, LeSample, LightSample};
use crate::texture::Texture;
use crate::{Frame, Rgb};
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub struct ProjectorLight {
    pub position: Vec3A,
    /// The projector's frame (`n` its axis), orthonormal.
    pub frame: Frame,
    pub irradiance: Texture,
    pub scale: f32,
    /// `tan(fov / 2)` of the horizontal field of view.
    tan_half: f32,
    /// The image's width over its height.
    aspect: f32,
}

impl ProjectorLight {
    /// A projector at `position` with frame `frame`, throwing `irradiance` (an image of
    /// `aspect` = width / height) over a horizontal field of view of `fov_x` degrees, in
    /// `(0, 180)`, times `scale`.
    pub fn new(
        position: Vec3A,
        frame: Frame,
        irradiance: Texture,
        scale: f32,
        fov_x: f32,
        aspect: f32,
    ) -> Result<ProjectorLight, String> {
        if !(fov_x > 0.0 && fov_x < 180.0) {
            return Err(format!(
                "a projector's field of view must lie in (0, 180) degrees, got {fov_x}"
            ));
        }
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(format!(
                "a projector's scale must be finite and not negative, got {scale}"
            ));
        }
        if !(aspect.is_finite() && aspect > 0.0) {
            return Err(format!(
                "a projector's image has no shape (aspect {aspect})"
            ));
        }
        Ok(ProjectorLight {
            position,
            frame,
            irradiance,
            scale,
            tan_half: (0.5 * fov_x).to_radians().tan(),
            aspect,
        })
    }

    /// The texture coordinates of the local direction (or point) `q`, if it lies ahead and
    /// inside the image.
    #[inline]
    fn uv(&self, q: Vec3A) -> Option<Vec2> {
        if q.z <= 0.0 {
            return None;
        }
        let k = 0.5 / (q.z * self.tan_half);
        let uv = Vec2::new(0.5 - q.x * k, 0.5 - self.aspect * q.y * k);
        (uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()).then_some(uv)
    }

    /// Intensity (W sr^-1) towards the unit local direction `d`.
    #[inline]
    fn intensity(&self, d: Vec3A) -> Rgb {
        match self.uv(d) {
            Some(uv) => self.irradiance.eval(uv) * (PI * self.scale / (d.z * d.z * d.z)),
            None => Rgb::ZERO,
        }
    }

    /// The image's area on the plane `z = 1`.
    #[inline]
    fn image_area(&self) -> f32 {
        let w = 2.0 * self.tan_half;
        w * w / self.aspect
    }

    pub fn sample_li(&self, p: Vec3A, _u: Vec2) -> Option<LightSample> {
        LightSample::from_position(p, self.position, |w, dist2| {
            let local = self.frame.to_local(w);
            self.uv(local)?;
            Some(self.intensity(local) / dist2)
        })
    }

    pub fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _q: Vec3A) -> f32 {
        0.0
    }

    pub fn emitted(&self, _n: Vec3A, _w: Vec3A) -> Rgb {
        Rgb::ZERO
    }

    /// Density of [`ProjectorLight::sample_le`]'s direction `d` (local, unit) per solid
    /// angle: uniform over the image on `z = 1`, `1 / (area cos^3 theta)`.
    #[inline]
    fn dir_pdf(&self, d: Vec3A) -> f32 {
        match self.uv(d) {
            Some(_) => 1.0 / (self.image_area() * d.z * d.z * d.z),
            None => 0.0,
        }
    }

    /// A ray through a uniform point of the image.
    pub fn sample_le(&self, u_dir: Vec2) -> LeSample {
        let w = 2.0 * self.tan_half;
        let q = Vec3A::new((0.5 - u_dir.x) * w, (0.5 - u_dir.y) * w / self.aspect, 1.0);
        let d = q.normalize();
        let pdf_dir = self.dir_pdf(d);
        let intensity = self.intensity(d);
        LeSample {
            ray: crate::Ray::new(self.position, self.frame.to_world(d)),
            radiance: crate::spectrum::of_rgb(intensity),
            normal: Vec3A::ZERO,
            pdf_pos: 1.0,
            pdf_dir,
            weight: crate::spectrum::of_rgb(if pdf_dir > 0.0 {
                intensity / pdf_dir
            } else {
                Rgb::ZERO
            }),
        }
    }

    pub fn pdf_le(&self, w: Vec3A) -> (f32, f32) {
        (0.0, self.dir_pdf(self.frame.to_local(w)))
    }

    /// `integral I dw = pi scale integral E dA` over the image on `z = 1`.
    pub fn power(&self) -> f64 {
        PI as f64 * self.scale as f64 * lum(self.irradiance.mean()) * self.image_area() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn projector(fov: f32) -> ProjectorLight {
        // Two columns, 1 and 3, one row, as an image twice as wide as high (aspect 2).
        let texture = crate::texture::two_columns();
        let frame = Frame::from_normal_and_tangent(Vec3A::Z, Vec3A::X);
        ProjectorLight::new(Vec3A::ZERO, frame, texture, 0.5, fov, 2.0).unwrap()
    }

    /// The irradiance on the plane z = 1 facing the projector is pi scale times the image:
    /// the left column of the image lands on +x, and the image ends at the field of view.
    #[test]
    fn the_image_lands_on_the_plane_at_one() {
        let p = projector(90.0);
        for (x, want) in [(0.5f32, 1.0f32), (-0.5, 3.0)] {
            let q = Vec3A::new(x, 0.1, 1.0);
            let ls = p.sample_li(q, Vec2::ZERO).unwrap();
            // Irradiance on the plane: the arriving radiance times the cosine of incidence.
            let e = ls.radiance.x * ls.wi.z.abs();
            assert!((e - PI * 0.5 * want).abs() < 1e-4, "{x}: {e}");
        }
        // Outside the field (tan 45 = 1 sideways, 1/2 vertically) and behind: nothing.
        assert!(p.sample_li(Vec3A::new(1.1, 0.0, 1.0), Vec2::ZERO).is_none());
        assert!(p.sample_li(Vec3A::new(0.0, 0.6, 1.0), Vec2::ZERO).is_none());
        assert!(p
            .sample_li(Vec3A::new(0.0, 0.0, -1.0), Vec2::ZERO)
            .is_none());
    }

    /// Emitted rays: their mean weight is the power, and the densities they report are those
    /// `pdf_le` gives their directions.
    #[test]
    fn emitted_rays_carry_the_power() {
        let p = projector(60.0);
        let mut s = crate::Sampler::new(9, 0, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let le = p.sample_le(s.next_2d());
            let (_, pdf) = p.pdf_le(le.ray.dir);
            assert!(
                (pdf - le.pdf_dir).abs() <= 1e-4 * pdf,
                "{pdf} vs {}",
                le.pdf_dir
            );
            sum += crate::luminance(crate::spectrum::rgb_of(le.weight)) as f64;
        }
        let mean = sum / n as f64;
        assert!(
            (mean - p.power()).abs() < 1e-2 * p.power(),
            "{mean} vs {}",
            p.power()
        );
    }
}
