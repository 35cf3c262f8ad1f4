//! A spot light (Mitsuba 3's `spot`, RON `Spot`): a point light whose intensity falls off
//! with the angle `theta` from its axis. Full `intensity` (W sr^-1 per channel) inside
//! `beam_width`, none outside `cutoff_angle`, and in between a falloff linear in the angle,
//! `(cutoff - theta) / (cutoff - beam_width)`, exactly as Mitsuba's; or, as pbrt-v4's, a
//! smoothstep in the cosine, `t^2 (3 - 2 t)` with
//! `t = (cos theta - cos cutoff) / (cos beam_width - cos cutoff)`. A delta in position.
//!
//! A textured spot (Mitsuba's `texture`) projects an image: towards a direction `d` of the
//! spot's frame (`z` the axis) the intensity is times the texture at
//! `u = 1/2 + d.x / (2 d.z tan(cutoff))`, `v = 1/2 + d.y / (2 d.z tan(cutoff))`, so that the
//! image spans the square the cutoff cone inscribes.

use super::{lum, LeSample, LightSample};
use crate::texture::Texture;
use crate::{Frame, Rgb};
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// How a spot's intensity falls from its beam width to its cutoff.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Falloff {
    /// Linear in the angle (Mitsuba 3's).
    #[default]
    Linear,
    /// A smoothstep in the cosine of the angle (pbrt-v4's).
    Smoothstep,
}

/// A spot light at `position` pointing along `axis` (unit).
#[derive(Clone, Debug, PartialEq)]
pub struct SpotLight {
    pub position: Vec3A,
    pub axis: Vec3A,
    pub intensity: Rgb,
    /// Angles from the axis in radians, `0 <= beam_width <= cutoff <= pi`.
    pub cutoff: f32,
    pub beam_width: f32,
    pub falloff: Falloff,
    /// A projected texture and the spot's frame (`n` the axis); boxed, as few spots have one
    /// and every light of a scene takes the largest kind's room.
    pub texture: Option<Box<(Texture, Frame)>>,
}

impl SpotLight {
    /// A spot light; angles in degrees, `0 < cutoff_angle <= 180`, `0 <= beam_width <=
    /// cutoff_angle`.
    pub fn new(
        position: Vec3A,
        axis: Vec3A,
        intensity: Rgb,
        cutoff_angle: f32,
        beam_width: f32,
    ) -> Result<SpotLight, String> {
        if !(cutoff_angle > 0.0 && cutoff_angle <= 180.0) {
            return Err(format!(
                "cutoff_angle must be in (0, 180] degrees, got {cutoff_angle}"
            ));
        }
        if !(beam_width >= 0.0 && beam_width <= cutoff_angle) {
            return Err(format!(
                "beam_width must be in [0, cutoff_angle = {cutoff_angle}] degrees, got {beam_width}"
            ));
        }
        let axis = axis.normalize_or_zero();
        if axis == Vec3A::ZERO {
            return Err("the spot's axis has no length".into());
        }
        Ok(SpotLight {
            position,
            axis,
            intensity,
            cutoff: cutoff_angle.to_radians(),
            beam_width: beam_width.to_radians(),
            falloff: Falloff::Linear,
            texture: None,
        })
    }

    /// The same spot projecting `texture`, its frame's `x` axis along `x` (made orthogonal to
    /// the axis). The cutoff must be below 90 degrees (the image lies on a plane ahead).
    pub fn with_texture(self, texture: Texture, x: Vec3A) -> Result<SpotLight, String> {
        if self.cutoff >= 0.5 * PI {
            return Err("a textured spot's cutoff_angle must be below 90 degrees".into());
        }
        let frame = Frame::from_normal_and_tangent(self.axis, x);
        Ok(SpotLight {
            texture: Some(Box::new((texture, frame))),
            ..self
        })
    }

    /// The intensity towards unit direction `w` (from the light), before the falloff: the
    /// texture's value there times `intensity`.
    #[inline]
    fn intensity_towards(&self, w: Vec3A) -> Rgb {
        let Some((texture, frame)) = self.texture.as_deref() else {
            return self.intensity;
        };
        let d = frame.to_local(w);
        if d.z <= 0.0 {
            return Rgb::ZERO;
        }
        let k = 0.5 / (d.z * self.cutoff.tan());
        let uv = Vec2::new(0.5 + d.x * k, 0.5 + d.y * k);
        self.intensity * texture.eval(uv)
    }

    /// The same spot with another falloff.
    pub fn with_falloff(self, falloff: Falloff) -> SpotLight {
        SpotLight { falloff, ..self }
    }

    /// The falloff towards unit direction `w` (from the light): linear in the angle, or a
    /// smoothstep in its cosine (read straight from `w`, no angle needed).
    #[inline]
    pub fn falloff(&self, w: Vec3A) -> f32 {
        let cos = w.dot(self.axis).clamp(-1.0, 1.0);
        match self.falloff {
            Falloff::Linear => {
                let theta = cos.acos();
                if theta <= self.beam_width {
                    1.0
                } else if theta >= self.cutoff {
                    0.0
                } else {
                    (self.cutoff - theta) / (self.cutoff - self.beam_width)
                }
            }
            Falloff::Smoothstep => {
                let (lo, hi) = (self.cutoff.cos(), self.beam_width.cos());
                if cos >= hi {
                    1.0
                } else if cos <= lo {
                    0.0
                } else {
                    let t = (cos - lo) / (hi - lo);
                    t * t * (3.0 - 2.0 * t)
                }
            }
        }
    }

    pub fn sample_li(&self, p: Vec3A, _u: Vec2) -> Option<LightSample> {
        LightSample::from_position(p, self.position, |w, dist2| {
            let falloff = self.falloff(w);
            (falloff > 0.0).then(|| self.intensity_towards(w) * (falloff / dist2))
        })
    }

    pub fn pdf_li(&self, _p: Vec3A, _wi: Vec3A, _q: Vec3A) -> f32 {
        0.0
    }

    pub fn emitted(&self, _n: Vec3A, _w: Vec3A) -> Rgb {
        Rgb::ZERO
    }

    /// Density of [`SpotLight::sample_le`]'s directions: uniform in the cone of the cutoff.
    #[inline]
    fn cone_pdf(&self) -> f32 {
        1.0 / (2.0 * PI * (1.0 - self.cutoff.cos()))
    }

    /// A ray in a uniform direction of the cutoff cone, weighted by the falloff.
    pub fn sample_le(&self, u_dir: Vec2) -> LeSample {
        let cos_max = self.cutoff.cos();
        let cos = 1.0 - u_dir.x * (1.0 - cos_max);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u_dir.y;
        let dir = Frame::from_normal(self.axis).to_world(Vec3A::new(
            sin * phi.cos(),
            sin * phi.sin(),
            cos,
        ));
        let pdf_dir = self.cone_pdf();
        let intensity = self.intensity_towards(dir);
        LeSample {
            ray: crate::Ray::new(self.position, dir),
            radiance: crate::spectrum::of_rgb(intensity * self.falloff(dir)),
            normal: Vec3A::ZERO,
            pdf_pos: 1.0,
            pdf_dir,
            weight: crate::spectrum::of_rgb(intensity * (self.falloff(dir) / pdf_dir)),
        }
    }

    pub fn pdf_le(&self, w: Vec3A) -> (f32, f32) {
        let inside = w.dot(self.axis) >= self.cutoff.cos();
        (0.0, if inside { self.cone_pdf() } else { 0.0 })
    }

    /// `integral I falloff dw`: the full cone inside the beam plus the falloff's ring,
    /// integrated numerically.
    pub fn power(&self) -> f64 {
        let (b, c) = (self.beam_width as f64, self.cutoff as f64);
        let inner = 2.0 * std::f64::consts::PI * (1.0 - b.cos());
        const N: usize = 256;
        let ring: f64 = (0..N)
            .map(|i| {
                let t = b + (c - b) * (i as f64 + 0.5) / N as f64;
                let f = match self.falloff {
                    Falloff::Linear => (c - t) / (c - b),
                    Falloff::Smoothstep => {
                        let x = ((t.cos() - c.cos()) / (b.cos() - c.cos())).clamp(0.0, 1.0);
                        x * x * (3.0 - 2.0 * x)
                    }
                };
                f * t.sin()
            })
            .sum::<f64>()
            * (c - b)
            / N as f64
            * 2.0
            * std::f64::consts::PI;
        // A texture: its mean over the image (what the cone sees, roughly).
        let tint = self
            .texture
            .as_ref()
            .map_or(1.0, |b| lum(b.0.mean()).max(1e-6));
        lum(self.intensity) * tint * (inner + if c > b { ring } else { 0.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{assert_chi2, Grid, SAMPLES};

    fn spot() -> SpotLight {
        SpotLight::new(
            Vec3A::ZERO,
            Vec3A::new(0.3, -0.2, 1.0),
            Rgb::ONE,
            20.0,
            15.0,
        )
        .unwrap()
    }

    #[test]
    fn falloff_is_mitsubas_linear_ramp_in_angle() {
        // Mitsuba 3.9's values at distance 1 for cutoff 20 and beam width 15 degrees.
        let s = spot();
        let frame = Frame::from_normal(s.axis);
        for (deg, expected) in [
            (0.0f32, 1.0),
            (15.0, 1.0),
            (16.0, 0.8),
            (17.5, 0.5),
            (19.0, 0.2),
            (20.0, 0.0),
            (60.0, 0.0),
        ] {
            let (sin, cos) = deg.to_radians().sin_cos();
            let w = frame.to_world(Vec3A::new(sin, 0.0, cos));
            let got = s.sample_li(w, Vec2::ZERO).map_or(0.0, |ls| ls.radiance.x);
            assert!((got - expected).abs() < 1e-4, "{deg}: {got}");
        }
        // Inverse square law on the axis.
        let ls = s.sample_li(s.axis * 2.0, Vec2::ZERO).unwrap();
        assert!((ls.radiance.x - 0.25).abs() < 1e-6 && ls.delta);
        assert!(SpotLight::new(Vec3A::ZERO, Vec3A::Z, Rgb::ONE, 10.0, 12.0).is_err());
        assert!(SpotLight::new(Vec3A::ZERO, Vec3A::ZERO, Rgb::ONE, 10.0, 5.0).is_err());
    }

    /// A textured spot projects its image over the square the cutoff cone inscribes at any
    /// distance: `u` along the frame's `x`, `v` along its `y`, both `1/2` on the axis.
    #[test]
    fn a_textured_spot_projects_its_image() {
        use crate::texture::{ImageTexture, Texels, TextureFilter, Wrap};
        // Four columns of grey 0.1, 0.2, 0.3, 0.4, one row: u alone picks the value.
        let texels = Texels::Float(
            (1..=4)
                .map(|i| Rgb::splat(0.1 * i as f32))
                .collect::<Vec<_>>()
                .into(),
        );
        let image = ImageTexture::new(4, 1, texels, TextureFilter::Nearest, Wrap::Clamp).unwrap();
        let texture = Texture::Image {
            image: std::sync::Arc::new(image),
            to_uv: glam::Affine2::IDENTITY,
            scale: 1.0,
        };
        let s = SpotLight::new(Vec3A::ZERO, Vec3A::Z, Rgb::ONE, 40.0, 40.0)
            .unwrap()
            .with_texture(texture, Vec3A::X)
            .unwrap();
        let half = 40f32.to_radians().tan();
        for z in [1.0f32, 3.0] {
            for (x, want) in [(-0.9f32, 0.1), (-0.3, 0.2), (0.3, 0.3), (0.9, 0.4)] {
                for y in [-0.5f32, 0.0, 0.5] {
                    let p = Vec3A::new(x * half * z, y * half * z * 0.5, z);
                    let ls = s.sample_li(p, Vec2::ZERO).unwrap();
                    let got = ls.radiance.x * p.length_squared();
                    assert!((got - want).abs() < 1e-5, "({x}, {y}, {z}): {got}");
                }
            }
        }
    }

    #[test]
    fn pbrts_falloff_is_a_smoothstep_in_the_cosine() {
        // pbrt-v4's SpotLight::I: SmoothStep(cos theta, cos cutoff, cos(cutoff - delta)).
        let s = spot().with_falloff(Falloff::Smoothstep);
        let frame = Frame::from_normal(s.axis);
        let (lo, hi) = (20f32.to_radians().cos(), 15f32.to_radians().cos());
        for deg in [0.0f32, 15.0, 16.0, 17.5, 19.0, 20.0, 30.0] {
            let c = deg.to_radians().cos();
            let t = ((c - lo) / (hi - lo)).clamp(0.0, 1.0);
            let expected = t * t * (3.0 - 2.0 * t);
            let (sin, cos) = deg.to_radians().sin_cos();
            let w = frame.to_world(Vec3A::new(sin, 0.0, cos));
            let got = s.sample_li(w, Vec2::ZERO).map_or(0.0, |ls| ls.radiance.x);
            assert!((got - expected).abs() < 1e-4, "{deg}: {got} vs {expected}");
        }
    }

    #[test]
    fn power_is_the_integral_of_the_falloff() {
        // Without a ramp: a cone of full intensity.
        let cone = SpotLight::new(Vec3A::ZERO, Vec3A::Z, Rgb::ONE, 30.0, 30.0).unwrap();
        let expected = 2.0 * std::f64::consts::PI * (1.0 - 30f64.to_radians().cos());
        assert!((cone.power() - expected).abs() < 1e-6);
        // With one, of either kind: the mean of emitted-ray weights estimates it.
        for s in [spot(), spot().with_falloff(Falloff::Smoothstep)] {
            let mut sampler = crate::Sampler::new(2201, 0, 0);
            let n = 200_000;
            let mean: f64 = (0..n)
                .map(|_| s.sample_le(sampler.next_2d()).weight.x as f64)
                .sum::<f64>()
                / n as f64;
            assert!(
                (mean - s.power()).abs() < 2e-3 * s.power(),
                "{:?}: {mean} vs {}",
                s.falloff,
                s.power()
            );
        }
    }

    #[test]
    fn chi2_spot_emission() {
        let s = spot();
        assert_chi2(
            "spot emitted directions",
            &Grid::cap_with_edge(s.axis, 1.0 - s.cutoff.cos() as f64, 20, 40),
            SAMPLES,
            2202,
            |u| Some(s.sample_le(u.next_2d()).ray.dir),
            |w| s.pdf_le(w).1,
        );
    }
}
