//! Microfacet distributions: the statistics of a rough surface's normals, shared by the rough
//! conductor, rough dielectric and rough plastic.
//!
//! Two distributions, isotropic or anisotropic (`alpha_u` along the shading frame's `x`,
//! `alpha_v` along `y`; `alpha` is the RMS slope times `sqrt(2)` for Beckmann, the width of
//! the GGX "Trowbridge-Reitz" lobe):
//!
//! * **GGX** (Walter et al. 2007): `D(m) = 1 / (pi ax ay (x^2/ax^2 + y^2/ay^2 + z^2)^2)`,
//!   Smith's exact `Lambda(w) = (sqrt(1 + a^2 tan^2) - 1) / 2`. Sampled by its visible normals
//!   (Heitz 2018, "Sampling the GGX distribution of visible normals"), as Mitsuba 3 and
//!   pbrt-v4 do: the density of a sampled normal is `G1(wo, m) max(0, wo.m) D(m) / wo.z`.
//! * **Beckmann**: `D(m) = exp(-(x^2/ax^2 + y^2/ay^2) / z^2) / (pi ax ay z^4)`, with the
//!   rational approximation of Smith's `G1` that Walter et al. give and Mitsuba 3 and Nori
//!   use (within 0.35% of the exact `erf` form). Sampled by its visible normals too, with
//!   Jakob's inversion of the visible slopes' distribution ("An improved visible normal
//!   sampling routine for the Beckmann distribution", 2014; Mitsuba's routine).
//!
//! Shadowing-masking is the separable Smith form `G(wo, wi, m) = G1(wo, m) G1(wi, m)`, as in
//! Mitsuba 3 (pbrt-v4 uses the height-correlated form, a few percent brighter at grazing
//! angles), so that raylab and Mitsuba agree per pixel. Every routine here works on the upper
//! side: callers flip directions with `z < 0` up first.

use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// Which distribution of normals. Beckmann is the default, as in Mitsuba 3.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Distribution {
    Ggx,
    #[default]
    Beckmann,
}

/// Smallest roughness used: narrower lobes overflow `D` in single precision (Mitsuba 3 clamps
/// to the same value).
pub const MIN_ALPHA: f32 = 1e-4;

/// A microfacet distribution of normals (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub distribution: Distribution,
    pub alpha_u: f32,
    pub alpha_v: f32,
}

impl Microfacet {
    /// A distribution with roughnesses `alpha_u` (along `x`) and `alpha_v` (along `y`), each in
    /// `(0, 2]`; values below [`MIN_ALPHA`] are raised to it.
    pub fn new(distribution: Distribution, alpha_u: f32, alpha_v: f32) -> Result<Self, String> {
        super::checks::finite("alpha", &[alpha_u, alpha_v])?;
        for a in [alpha_u, alpha_v] {
            if !(a > 0.0 && a <= 2.0) {
                return Err(format!(
                    "alpha (roughness) must be in (0, 2], got {a}; for a smooth surface use the \
                     material without \"Rough\""
                ));
            }
        }
        Ok(Microfacet {
            distribution,
            alpha_u: alpha_u.max(MIN_ALPHA),
            alpha_v: alpha_v.max(MIN_ALPHA),
        })
    }

    /// Density of normals per unit solid angle projected onto the macro-surface: `D(m)`, with
    /// `integral D(m) m.z dm = 1`. Zero below the horizon.
    #[inline]
    pub fn d(&self, m: Vec3A) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_u, self.alpha_v);
        let (x, y) = (m.x / ax, m.y / ay);
        let z2 = m.z * m.z;
        let d = match self.distribution {
            Distribution::Ggx => {
                let s = x * x + y * y + z2;
                1.0 / (PI * ax * ay * s * s)
            }
            Distribution::Beckmann => (-(x * x + y * y) / z2).exp() / (PI * ax * ay * z2 * z2),
        };
        if d.is_finite() {
            d
        } else {
            0.0
        }
    }

    /// `alpha^2 tan^2(theta)` of direction `w` along its azimuth: the squared ratio of the
    /// direction's slope to the roughness it sees.
    #[inline]
    fn alpha2_tan2(&self, w: Vec3A) -> f32 {
        let (x, y) = (w.x * self.alpha_u, w.y * self.alpha_v);
        (x * x + y * y) / (w.z * w.z)
    }

    /// Smith's monodirectional shadowing `G1(w, m)`: the fraction of normals `m` visible from
    /// `w`. Zero when `w` sees the back of the microfacet or lies below the surface.
    #[inline]
    pub fn g1(&self, w: Vec3A, m: Vec3A) -> f32 {
        if w.dot(m) * w.z <= 0.0 || w.z == 0.0 {
            return 0.0;
        }
        let a2t2 = self.alpha2_tan2(w);
        if a2t2 == 0.0 {
            return 1.0;
        }
        match self.distribution {
            Distribution::Ggx => 2.0 / (1.0 + (1.0 + a2t2).sqrt()),
            Distribution::Beckmann => {
                // Walter et al.'s rational fit of 1 / (1 + Lambda), a = 1 / (alpha tan).
                let a = 1.0 / a2t2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    let a2 = a * a;
                    (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2)
                }
            }
        }
    }

    /// Separable shadowing-masking `G1(wo, m) G1(wi, m)`.
    #[inline]
    pub fn g(&self, wo: Vec3A, wi: Vec3A, m: Vec3A) -> f32 {
        self.g1(wo, m) * self.g1(wi, m)
    }

    /// Samples a normal `m` (upper side) visible from a direction `wo` with `wo.z > 0`. Its
    /// density is [`Microfacet::pdf`].
    #[inline]
    pub fn sample(&self, wo: Vec3A, u: Vec2) -> Vec3A {
        match self.distribution {
            Distribution::Ggx => self.sample_ggx_visible(wo, u),
            Distribution::Beckmann => self.sample_beckmann_visible(wo, u),
        }
    }

    /// Beckmann's visible normals: stretch `wo` to unit roughness, sample the slopes visible
    /// from it there, rotate them to `wo`'s azimuth and unstretch.
    #[inline]
    fn sample_beckmann_visible(&self, wo: Vec3A, u: Vec2) -> Vec3A {
        let (ax, ay) = (self.alpha_u, self.alpha_v);
        let w = Vec3A::new(ax * wo.x, ay * wo.y, wo.z).normalize();
        let r = (w.x * w.x + w.y * w.y).sqrt();
        let (cos_phi, sin_phi) = if r > 0.0 {
            (w.x / r, w.y / r)
        } else {
            (1.0, 0.0)
        };
        let (sx, sy) = beckmann_visible_slopes(w.z, u);
        let (x, y) = (cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy);
        Vec3A::new(-ax * x, -ay * y, 1.0).normalize()
    }

    /// Heitz 2018: a normal of the GGX distribution visible from `wo`, by stretching `wo` to
    /// the unit-roughness configuration, sampling the projected hemisphere there and
    /// unstretching the normal.
    #[inline]
    fn sample_ggx_visible(&self, wo: Vec3A, u: Vec2) -> Vec3A {
        let (ax, ay) = (self.alpha_u, self.alpha_v);
        let vh = Vec3A::new(ax * wo.x, ay * wo.y, wo.z).normalize();
        // An orthonormal basis around the stretched view direction.
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3A::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3A::X
        };
        let t2 = vh.cross(t1);
        // A uniform point of the unit disk, squeezed onto the half of it the view sees.
        let r = u.x.sqrt();
        let (sin, cos) = (2.0 * PI * u.y).sin_cos();
        let p1 = r * cos;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin;
        // Lifted onto the hemisphere, then unstretched.
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        Vec3A::new(ax * nh.x, ay * nh.y, nh.z.max(1e-6)).normalize()
    }

    /// Density per unit solid angle with which [`Microfacet::sample`] returns `m` for `wo`
    /// (`wo.z > 0`): the distribution of visible normals `G1(wo, m) max(0, wo.m) D(m) / wo.z`.
    #[inline]
    pub fn pdf(&self, wo: Vec3A, m: Vec3A) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        visible_density(self.d(m), self.g1(wo, m), wo.dot(m), wo.z)
    }

    /// What the value and the density of a reflection from `wo` to `wi` (both upper-side)
    /// share, for models that compute both at once.
    #[inline]
    pub fn half_vector(&self, wo: Vec3A, wi: Vec3A) -> HalfVector {
        let h = (wo + wi).normalize();
        HalfVector {
            h,
            d: self.d(h),
            g1_wo: self.g1(wo, h),
        }
    }
}

/// [`Microfacet::pdf`] from its parts: a normal of density `d` at cosine `cos` to `wo` (of
/// height `wo_z > 0`), shadowed from `wo` by `g1_wo`.
#[inline]
fn visible_density(d: f32, g1_wo: f32, cos: f32, wo_z: f32) -> f32 {
    g1_wo * cos.max(0.0) * d / wo_z
}

/// The half vector `h` of a reflection, its density `d` and its shadowing `g1_wo` from `wo`
/// ([`Microfacet::half_vector`]).
pub struct HalfVector {
    pub h: Vec3A,
    pub d: f32,
    pub g1_wo: f32,
}

impl HalfVector {
    /// The density of the reflected direction when `wo`'s visible normals are sampled and
    /// reflected: [`Microfacet::pdf`] of `h` over the Jacobian `4 wo.h`; 0 where `wo.h <= 0`.
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3A) -> f32 {
        let cos = wo.dot(self.h);
        if cos > 0.0 {
            visible_density(self.d, self.g1_wo, cos, wo.z) / (4.0 * cos)
        } else {
            0.0
        }
    }
}

/// Slopes of the unit-roughness Beckmann surface visible from a direction at `cos_theta` to
/// the normal (azimuth 0): the `x` slope by Newton-bisection on its distribution function
/// (written in the `erf` domain, from Jakob's fitted first guess), the `y` slope a Gaussian.
fn beckmann_visible_slopes(cos_theta: f32, u: Vec2) -> (f32, f32) {
    let y = erfinv(2.0 * u.y - 1.0);
    if cos_theta > 0.9999 {
        // Normal incidence: the visible slopes are the slopes, an isotropic Gaussian.
        let r = (-(1.0 - u.x).max(1e-12).ln()).sqrt();
        let (sin, cos) = (2.0 * PI * u.y).sin_cos();
        return (r * cos, r * sin);
    }
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let tan_theta = sin_theta / cos_theta;
    let cot_theta = 1.0 / tan_theta;
    let ux = u.x.max(1e-6);
    // The distribution function of b = erf(slope x), on [-1, erf(cot)].
    let (mut lo, mut hi) = (-1.0f32, libm::erff(cot_theta));
    let theta = cos_theta.acos();
    let fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
    let mut b = hi - (1.0 + hi) * (1.0 - ux).powf(fit);
    let inv_sqrt_pi = 1.0 / PI.sqrt();
    let normalisation = 1.0 / (1.0 + hi + inv_sqrt_pi * tan_theta * (-cot_theta * cot_theta).exp());
    for _ in 0..10 {
        // Bisect when Newton leaves the bracket (or produced a NaN).
        if !(b >= lo && b <= hi) {
            b = 0.5 * (lo + hi);
        }
        let x = erfinv(b);
        let value = normalisation * (1.0 + b + inv_sqrt_pi * tan_theta * (-x * x).exp()) - ux;
        if value.abs() < 1e-5 {
            break;
        }
        if value > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        b -= value / (normalisation * (1.0 - x * tan_theta));
    }
    (erfinv(b), y)
}

/// The inverse error function on `(-1, 1)` (Giles 2010, "Approximating the erfinv function":
/// single precision, relative error below 4e-7); the ends map to about +-4.
fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-1.0 + 1e-7, 1.0 - 1e-7);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        for c in [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            0.246_640_73,
            1.501_409_4,
        ] {
            p = c + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -2.002_142_6e-4;
        for c in [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461_3e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ] {
            p = c + p * w;
        }
        p
    };
    p * x
}

/// Mirror reflection of `w` about the normal `m`.
#[inline]
pub fn reflect(w: Vec3A, m: Vec3A) -> Vec3A {
    2.0 * w.dot(m) * m - w
}

/// Refraction of `w` through a surface of normal `m` (on either side) with relative IOR
/// `eta` = IOR of the side `w` goes to over the IOR of `w`'s side. `None` on total internal
/// reflection.
#[inline]
pub fn refract(w: Vec3A, m: Vec3A, eta: f32) -> Option<Vec3A> {
    let cos_i = w.dot(m);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-w / eta + (cos_i / eta - cos_t.copysign(cos_i)) * m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{assert_chi2, dir, Grid, SAMPLES};

    fn all() -> Vec<Microfacet> {
        let mut v = Vec::new();
        for d in [Distribution::Ggx, Distribution::Beckmann] {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                v.push(Microfacet::new(d, au, av).unwrap());
            }
        }
        v
    }

    /// Midpoint-rule integral over the upper hemisphere, uniform in `cos` and `phi`.
    fn integrate(f: impl Fn(Vec3A) -> f64) -> f64 {
        let (nt, np) = (2000, 400);
        let mut sum = 0.0;
        for i in 0..nt {
            let z = (i as f64 + 0.5) / nt as f64;
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                sum += f(Vec3A::new(
                    (r * phi.cos()) as f32,
                    (r * phi.sin()) as f32,
                    z as f32,
                ));
            }
        }
        sum * 2.0 * std::f64::consts::PI / (nt * np) as f64
    }

    #[test]
    fn normals_project_to_the_macro_surface_and_visible_normals_are_normalised() {
        for mf in all() {
            if mf.alpha_u < 0.1 {
                continue; // too narrow for the quadrature
            }
            let projected = integrate(|m| (mf.d(m) * m.z) as f64);
            assert!((projected - 1.0).abs() < 2e-3, "{mf:?}: {projected}");
            // The projected area of the visible normals equals the view's: integral of
            // G1 max(0, wo.m) D dm = wo.z (exact for Smith's G1 with the exact Lambda).
            for theta in [0.0f32, 40.0, 75.0] {
                let wo = dir(theta, 30.0);
                let visible = integrate(|m| (mf.g1(wo, m) * wo.dot(m).max(0.0) * mf.d(m)) as f64);
                let tol = match mf.distribution {
                    Distribution::Ggx => 3e-3,
                    Distribution::Beckmann => 1e-2, // Walter's rational G1
                };
                assert!(
                    (visible / wo.z as f64 - 1.0).abs() < tol,
                    "{mf:?} at {theta}: {}",
                    visible / wo.z as f64
                );
            }
        }
    }

    #[test]
    fn refraction_round_trips_and_obeys_snell() {
        let m = Vec3A::new(0.2, -0.1, 1.0).normalize();
        let w = dir(35.0, 70.0);
        let t = refract(w, m, 1.5).unwrap();
        let sin_i = w.cross(m).length();
        let sin_t = t.cross(m).length();
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-5 && t.dot(m) < 0.0);
        let back = refract(t, m, 1.0 / 1.5).unwrap();
        assert!((back - w).length() < 1e-5);
        // Total internal reflection from inside past the critical angle.
        assert!(refract(-dir(60.0, 0.0), Vec3A::Z, 1.0 / 1.5).is_none());
        assert!((reflect(w, m).dot(m) - w.dot(m)).abs() < 1e-6);
    }

    fn chi2_normals(name: &str, mf: Microfacet, wo: Vec3A, seed: u64) {
        assert_chi2(
            name,
            &Grid::hemisphere(20, 40),
            SAMPLES,
            seed,
            |s| Some(mf.sample(wo, s.next_2d())),
            |m| mf.pdf(wo, m),
        );
    }

    #[test]
    fn chi2_ggx_visible_normals() {
        let mf = Microfacet::new(Distribution::Ggx, 0.5, 0.5).unwrap();
        chi2_normals("GGX visible normals a .5 wo 60", mf, dir(60.0, 20.0), 1101);
    }

    #[test]
    fn chi2_ggx_anisotropic_grazing() {
        let mf = Microfacet::new(Distribution::Ggx, 0.2, 0.6).unwrap();
        chi2_normals(
            "GGX visible normals a .2/.6 wo 85",
            mf,
            dir(85.0, 60.0),
            1102,
        );
    }

    #[test]
    fn chi2_beckmann_visible_normals() {
        let mf = Microfacet::new(Distribution::Beckmann, 0.3, 0.7).unwrap();
        chi2_normals(
            "Beckmann visible normals a .3/.7 wo 70",
            mf,
            dir(70.0, 30.0),
            1103,
        );
    }

    #[test]
    fn erfinv_inverts_erf() {
        for x in [-0.999f32, -0.7, -0.1, 0.0, 0.3, 0.9, 0.9999] {
            let y = erfinv(x);
            assert!((libm::erff(y) - x).abs() < 2e-6, "{x}: {y}");
        }
    }
}
