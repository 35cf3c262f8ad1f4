//! An environment map: radiance arriving from every direction that leaves the scene, read
//! from a latitude-longitude image (Mitsuba 3's `envmap`, RON `Environment`).
//!
//! **Directions.** In the map's own frame (the entity's rotation takes it to the world) `+y`
//! is up. A direction `d` towards the sky reads the image at `u = atan2(d.x, -d.z) / 2 pi`
//! (wrapped to `[0, 1)`: `-z` at the left edge, `+x` a quarter in, `+z` in the middle) and
//! `v = acos(d.y) / pi` (the top row is straight up), exactly as Mitsuba 3 does. A z-up scene
//! rotates the map by 90 degrees about `x`.
//!
//! **Lookup.** Bilinear, as Mitsuba's: columns are centred at `u = (x + 1/2) / W` and wrap
//! around; rows lie at `v = y / (H - 1)`, the first and last exactly on the poles. Radiance is
//! the texel value times `scale`, W sr^-1 m^-2 per channel.
//!
//! **Sampling.** The bilinear patch between four texels is at most its brightest corner, so
//! each patch's weight is that corner's luminance times the largest `sin(theta)` over the
//! patch; a patch is picked by a piecewise-constant 2D distribution over those weights (rows,
//! then a column within the row) and a point uniformly inside it. The density covers every
//! direction with radiance, so light sampling alone is unbiased; it is proportional to the
//! radiance up to the variation inside one patch. Per unit solid angle it is
//! `pdf(u, v) / (2 pi^2 sin(theta))`.

use super::{lum, LeSample, LightSample};
use crate::sampling::Distribution1D;
use crate::{Rgb, Spectrum};
use glam::{Mat3A, Vec2, Vec3A};
use std::f32::consts::PI;

/// A latitude-longitude environment map with its sampling distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Linear RGB texels, row by row from the top (`+y`).
    texels: Vec<Rgb>,
    scale: f32,
    /// The map's frame to the world's (orthogonal) and back.
    to_world: Mat3A,
    to_local: Mat3A,
    /// Over the `height - 1` rows of patches.
    rows: Distribution1D,
    /// Over the `width` patches of each row.
    columns: Vec<Distribution1D>,
}

impl EnvMap {
    /// A map of `width x height` linear RGB `texels` (row by row, top first), scaled by
    /// `scale` and turned into the world by `to_world` (orthogonal: a rotation, or a rotation
    /// and a mirror, whose transpose maps back). At least 2 x 2 texels, every value
    /// finite and non-negative, `scale` finite and non-negative.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<Rgb>,
        scale: f32,
        to_world: Mat3A,
    ) -> Result<EnvMap, String> {
        if width < 2 || height < 2 || texels.len() != width * height {
            return Err(format!(
                "an environment map needs at least 2 x 2 texels, got {width} x {height}"
            ));
        }
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(format!(
                "scale must be finite and not negative, got {scale}"
            ));
        }
        if let Some(i) = texels
            .iter()
            .position(|t| !(t.is_finite() && t.min_element() >= 0.0))
        {
            return Err(format!(
                "texel ({}, {}) is {:?}: radiance must be finite and not negative",
                i % width,
                i / width,
                texels[i].to_array()
            ));
        }
        let lum_at = |x: usize, y: usize| crate::luminance(texels[y * width + x % width]);
        let mut row_weights = Vec::with_capacity(height - 1);
        let mut columns = Vec::with_capacity(height - 1);
        for y in 0..height - 1 {
            // The largest sin(theta) over the patch's rows.
            let (t0, t1) = (
                PI * y as f32 / (height - 1) as f32,
                PI * (y + 1) as f32 / (height - 1) as f32,
            );
            let sin_max = if t0 <= 0.5 * PI && t1 >= 0.5 * PI {
                1.0
            } else {
                t0.sin().max(t1.sin())
            };
            let weights: Vec<f32> = (0..width)
                .map(|x| {
                    let corners = [
                        lum_at(x, y),
                        lum_at(x + 1, y),
                        lum_at(x, y + 1),
                        lum_at(x + 1, y + 1),
                    ];
                    corners.into_iter().fold(0.0, f32::max) * sin_max
                })
                .collect();
            let d = Distribution1D::new(&weights);
            row_weights.push(d.total as f32);
            columns.push(d);
        }
        Ok(EnvMap {
            width,
            height,
            texels,
            scale,
            to_world,
            to_local: to_world.transpose(),
            rows: Distribution1D::new(&row_weights),
            columns,
        })
    }

    /// `(u, v)` of a direction in the map's frame.
    #[inline]
    fn uv(d: Vec3A) -> (f32, f32) {
        let u = d.x.atan2(-d.z) * (0.5 / PI);
        let u = if u < 0.0 { u + 1.0 } else { u };
        (
            u.min(1.0 - f32::EPSILON / 2.0),
            d.y.clamp(-1.0, 1.0).acos() / PI,
        )
    }

    /// The continuous texel coordinates `(x, y)` of `(u, v)`: `x` in `[0, W)` measured from
    /// the first column's centre (wrapping), `y` in `[0, H - 1]`.
    #[inline]
    fn texel_coords(&self, u: f32, v: f32) -> (f32, f32) {
        let mut x = u * self.width as f32 - 0.5;
        if x < 0.0 {
            x += self.width as f32;
        }
        (
            x.min(self.width as f32 - 1e-3),
            (v * (self.height - 1) as f32).clamp(0.0, (self.height - 1) as f32),
        )
    }

    /// Bilinear radiance at continuous texel coordinates.
    #[inline]
    fn bilinear(&self, x: f32, y: f32) -> Rgb {
        let (x0, y0) = (
            x.floor() as usize % self.width,
            (y.floor() as usize).min(self.height - 2),
        );
        let (fx, fy) = (x - x.floor(), y - y0 as f32);
        let x1 = (x0 + 1) % self.width;
        let at = |x: usize, y: usize| self.texels[y * self.width + x];
        let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
        let bottom = at(x0, y0 + 1) * (1.0 - fx) + at(x1, y0 + 1) * fx;
        (top * (1.0 - fy) + bottom * fy) * self.scale
    }

    /// [`EnvMap::radiance`] at the wavelengths `lambda` (spectral mode), as Mitsuba 3's
    /// spectral `envmap` has it: each of the four texels is a sigmoid spectrum of its colour
    /// over twice its largest channel, and that scale; the sigmoids and the scales are
    /// interpolated apart and multiplied, times D65 (at edges between colours this differs
    /// from the spectrum of the interpolated colour, and Mitsuba's references show it).
    pub fn radiance_at(&self, d: Vec3A, lambda: &crate::spectrum::Wavelengths) -> Spectrum {
        let crate::spectrum::Wavelengths::Sampled { nm, .. } = lambda else {
            return crate::spectrum::of_rgb(self.radiance(d));
        };
        let (u, v) = EnvMap::uv(self.to_local * d);
        let (x, y) = self.texel_coords(u, v);
        let x = x.min(self.width as f32 - 1e-3);
        let (x0, y0) = (
            x.floor() as usize % self.width,
            (y.floor() as usize).min(self.height - 2),
        );
        let (fx, fy) = (x - x.floor(), y - y0 as f32);
        let x1 = (x0 + 1) % self.width;
        let corners = [
            (x0, y0, (1.0 - fx) * (1.0 - fy)),
            (x1, y0, fx * (1.0 - fy)),
            (x0, y0 + 1, (1.0 - fx) * fy),
            (x1, y0 + 1, fx * fy),
        ];
        let (mut sigmoid, mut scale) = (Spectrum::ZERO, 0.0f32);
        for (x, y, w) in corners {
            let (s, k) = crate::spectrum::RgbSpectrum::sigmoid_and_scale(
                self.texels[y * self.width + x],
                *nm,
            );
            sigmoid += s * w;
            scale += k * w;
        }
        let d65 = nm.map(crate::spectrum::upsample::d65);
        sigmoid * d65 * (scale * self.scale)
    }

    /// Radiance arriving from the world direction `d` (towards the sky).
    #[inline]
    pub fn radiance(&self, d: Vec3A) -> Rgb {
        let (u, v) = EnvMap::uv(self.to_local * d);
        let (x, y) = self.texel_coords(u, v);
        self.bilinear(x, y)
    }

    /// A world direction towards the sky, its radiance and its solid-angle density.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3A, Rgb, f32)> {
        let (y, row, p_row) = self.rows.sample(u.y);
        let (x, _, p_col) = self.columns[row].sample(u.x);
        // Texel coordinates to (u, v): columns are centred half a texel in.
        let uu = (x + 0.5) / self.width as f32;
        let uu = if uu >= 1.0 { uu - 1.0 } else { uu };
        let v = y / (self.height - 1) as f32;
        let theta = PI * v;
        let sin = theta.sin();
        if sin <= 0.0 {
            return None;
        }
        let phi = 2.0 * PI * uu;
        let local = Vec3A::new(sin * phi.sin(), theta.cos(), -sin * phi.cos());
        // Density per unit (x, y) area is p_row p_col; (u, v) stretch it by W (H - 1).
        let pdf_uv = p_row * p_col * (self.width * (self.height - 1)) as f32;
        let pdf = pdf_uv / (2.0 * PI * PI * sin);
        let radiance = self.bilinear(x.min(self.width as f32 - 1e-3), y);
        (pdf > 0.0 && pdf.is_finite()).then(|| (self.to_world * local, radiance, pdf))
    }

    /// The solid-angle density of [`EnvMap::sample`] returning world direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3A) -> f32 {
        let local = self.to_local * d;
        let (u, v) = EnvMap::uv(local);
        let (x, y) = self.texel_coords(u, v);
        let row = (y.floor() as usize).min(self.height - 2);
        let col = (x.floor() as usize).min(self.width - 1);
        let sin = (1.0 - local.y * local.y).max(0.0).sqrt();
        if sin <= 0.0 {
            return 0.0;
        }
        let pdf_uv = self.rows.pmf(row)
            * self.columns[row].pmf(col)
            * (self.width * (self.height - 1)) as f32;
        pdf_uv / (2.0 * PI * PI * sin)
    }

    /// `integral L dw` in luminance: Riemann sum over the texels.
    fn integral(&self) -> f64 {
        let mut sum = 0.0f64;
        for y in 0..self.height {
            let sin = (PI * y as f32 / (self.height - 1) as f32).sin() as f64;
            for x in 0..self.width {
                sum += lum(self.texels[y * self.width + x]) * sin;
            }
        }
        let d_omega = (2.0 * std::f64::consts::PI / self.width as f64)
            * (std::f64::consts::PI / (self.height - 1) as f64);
        sum * d_omega * self.scale as f64
    }
}

/// An environment map as a light.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMapLight {
    pub map: std::sync::Arc<EnvMap>,
}

impl EnvMapLight {
    pub fn sample_li(&self, p: Vec3A, u: Vec2) -> Option<LightSample> {
        let (wi, radiance, pdf) = self.map.sample(u)?;
        Some(LightSample {
            wi,
            point: p + wi,
            dist: f32::INFINITY,
            radiance: crate::spectrum::of_rgb(radiance),
            pdf,
            delta: false,
        })
    }

    pub fn pdf_li(&self, _p: Vec3A, wi: Vec3A, _q: Vec3A) -> f32 {
        self.map.pdf(wi)
    }

    /// Radiance arriving from `-w`.
    pub fn emitted(&self, _n: Vec3A, w: Vec3A) -> Rgb {
        self.map.radiance(-w)
    }

    /// A ray arriving from a direction drawn from the map, from a uniform point of the disk
    /// of radius `scene_radius` facing it, outside the scene's bounding sphere.
    pub fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        scene_center: Vec3A,
        scene_radius: f32,
    ) -> LeSample {
        let area = PI * scene_radius * scene_radius;
        let Some((towards_sky, radiance, pdf_dir)) = self.map.sample(u_dir) else {
            return LeSample {
                ray: crate::Ray::new(scene_center, Vec3A::Z),
                radiance: crate::spectrum::of_rgb(Rgb::ZERO),
                normal: Vec3A::Z,
                pdf_pos: 1.0 / area,
                pdf_dir: 0.0,
                weight: crate::spectrum::of_rgb(Rgb::ZERO),
            };
        };
        let dir = -towards_sky;
        let ray = super::ray_from_afar(dir, u_pos, scene_center, scene_radius);
        LeSample {
            ray,
            radiance: crate::spectrum::of_rgb(radiance),
            normal: dir,
            pdf_pos: 1.0 / area,
            pdf_dir,
            weight: crate::spectrum::of_rgb(radiance * (area / pdf_dir)),
        }
    }

    /// Densities of a ray travelling in direction `w`.
    pub fn pdf_le(&self, w: Vec3A, scene_radius: f32) -> (f32, f32) {
        (1.0 / (PI * scene_radius * scene_radius), self.map.pdf(-w))
    }

    /// The power crossing a disk of the scene's radius: `pi r^2 integral L dw`.
    pub fn power(&self, scene_radius: f32) -> f64 {
        let r = scene_radius as f64;
        std::f64::consts::PI * r * r * self.map.integral()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{assert_chi2, Grid, SAMPLES};
    use crate::Sampler;

    /// A 16 x 9 map: a dim gradient, a bright patch, and a black band.
    fn test_map(to_world: Mat3A) -> EnvMap {
        let (w, h) = (16, 9);
        let texels = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (5..7).contains(&x) && (2..4).contains(&y) {
                    Rgb::new(40.0, 30.0, 20.0)
                } else if y == 6 {
                    Rgb::ZERO
                } else {
                    Rgb::new(0.2 + 0.05 * x as f32, 0.3, 0.1 + 0.1 * y as f32)
                }
            })
            .collect();
        EnvMap::new(w, h, texels, 1.5, to_world).unwrap()
    }

    #[test]
    fn directions_follow_mitsubas_convention() {
        // One bright column per axis direction on the equator of an 8 x 5 map.
        let (w, h) = (8, 5);
        let mut texels = vec![Rgb::ZERO; w * h];
        texels[2 * w + 1] = Rgb::new(1.0, 0.0, 0.0); // u = 1.5 / 8 ... column 1
        texels[2 * w + 5] = Rgb::new(0.0, 1.0, 0.0); // column 5
        for t in &mut texels[..w] {
            *t = Rgb::splat(7.0); // the top row is +y
        }
        let map = EnvMap::new(w, h, texels, 1.0, Mat3A::IDENTITY).unwrap();
        // +x reads column 1.5 (between 1 and 2), -x column 5.5 (between 5 and 6).
        assert!((map.radiance(Vec3A::X) - Rgb::new(0.5, 0.0, 0.0)).length() < 1e-5);
        assert!((map.radiance(-Vec3A::X) - Rgb::new(0.0, 0.5, 0.0)).length() < 1e-5);
        // Straight up reads the top row.
        assert_eq!(map.radiance(Vec3A::Y), Rgb::splat(7.0));
        assert_eq!(map.radiance(-Vec3A::Y), Rgb::ZERO);
        // A z-up scene rotates the map 90 degrees about x: world +z is the top row.
        let z_up = Mat3A::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let rotated = EnvMap::new(w, h, map.texels.clone(), 1.0, z_up).unwrap();
        assert!((rotated.radiance(Vec3A::Z) - map.radiance(Vec3A::Y)).length() < 1e-5);
    }

    /// `integral f dw` over the sphere by the midpoint rule, uniform in `y` and the azimuth.
    fn over_sphere(f: impl Fn(Vec3A) -> f64) -> f64 {
        let (nt, np) = (800, 1600);
        let mut sum = 0.0f64;
        for i in 0..nt {
            let z = -1.0 + 2.0 * (i as f64 + 0.5) / nt as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                sum += f(Vec3A::new(
                    (r * phi.cos()) as f32,
                    z as f32,
                    (r * phi.sin()) as f32,
                ));
            }
        }
        sum * 4.0 * std::f64::consts::PI / (nt * np) as f64
    }

    #[test]
    fn sampling_covers_the_radiance_and_integrates_it() {
        let map = test_map(Mat3A::from_rotation_y(0.7) * Mat3A::from_rotation_x(0.3));
        // The estimate of integral L dw from light samples equals a quadrature of it, and
        // the density integrates to 1.
        let quad = over_sphere(|d| map.radiance(d).y as f64);
        let pdf_integral = over_sphere(|d| map.pdf(d) as f64);
        let mut s = Sampler::new(2101, 0, 0);
        let n = 400_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        let mut mismatched = 0;
        for _ in 0..n {
            if let Some((d, l, pdf)) = map.sample(s.next_2d()) {
                // The round trip through the direction may round a sample on a patch's edge
                // into its neighbour; anywhere else the densities and radiances agree.
                let close = (pdf - map.pdf(d)).abs() <= 1e-3 * pdf
                    && (l - map.radiance(d)).abs().max_element() <= 1e-3 * l.max_element() + 1e-5;
                mismatched += usize::from(!close);
                let w = (l.y / pdf) as f64;
                sum += w;
                sum2 += w * w;
            }
        }
        let mean = sum / n as f64;
        let err = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
        println!("env map: integral {quad:.5}, light samples {mean:.5} +- {err:.5}, {mismatched} on edges");
        assert!(mismatched < n / 2000, "{mismatched}");
        assert!((pdf_integral - 1.0).abs() < 1e-3, "{pdf_integral}");
        assert!(
            (mean - quad).abs() < 4.5 * err + 1e-3 * quad,
            "{mean} vs {quad}"
        );
    }

    #[test]
    fn chi2_env_map() {
        let map = test_map(Mat3A::from_rotation_z(0.4));
        assert_chi2(
            "environment map",
            &Grid::sphere(40, 80),
            SAMPLES,
            2102,
            |s| map.sample(s.next_2d()).map(|(d, _, _)| d),
            |d| map.pdf(d),
        );
    }

    #[test]
    fn bad_maps_are_refused() {
        assert!(EnvMap::new(1, 4, vec![Rgb::ONE; 4], 1.0, Mat3A::IDENTITY).is_err());
        assert!(EnvMap::new(2, 2, vec![Rgb::ONE; 3], 1.0, Mat3A::IDENTITY).is_err());
        let mut t = vec![Rgb::ONE; 4];
        t[3] = Rgb::new(f32::NAN, 0.0, 0.0);
        assert!(EnvMap::new(2, 2, t, 1.0, Mat3A::IDENTITY)
            .unwrap_err()
            .contains("texel (1, 1)"));
        assert!(EnvMap::new(2, 2, vec![Rgb::ONE; 4], -1.0, Mat3A::IDENTITY).is_err());
    }
}
