//! Hair: light scattered by a dielectric fibre with an absorbing interior and tilted cuticle
//! scales (Chiang, Bitterli, Tappan and Burley 2016, "A Practical and Controllable Hair and
//! Fur Model for Production Path Tracing"; the form of pbrt-v4's `HairBxDF`, which builds on
//! d'Eon et al. 2011 and Marschner et al. 2003).
//!
//! The fibre is a cylinder, so the model works in its own frame: the shading frame's `x` axis
//! must be the fibre's direction (a curve's `dp/du`), `z` the shading normal and `y = z x x`
//! (raylab's [`Frame`](crate::geometry::Frame) built from the normal and `dpdu`). A direction
//! `w` has the longitudinal angle `theta` with `sin(theta) = w.x` (from the normal plane of the
//! fibre) and the azimuth `phi = atan2(w.z, w.y)` around the fibre. `h` in `[-1, 1]` is where
//! across the fibre's width the ray hit it (pbrt-v4's curves: `h = 2 v - 1`), which gives the
//! azimuthal angle of incidence `gamma_o = asin(h)` on the cylinder's cross-section; set it per
//! hit with [`Hair::with_h`].
//!
//! Light leaves after `p` internal paths: reflected at the surface (`p = 0`, R), transmitted
//! twice (`p = 1`, TT), reflected once inside (`p = 2`, TRT), and all longer paths lumped into
//! one last lobe (`p = 3`). Each lobe is a product
//!
//! ```text
//! f(wo, wi) |cos(wi)| = sum_p  M_p(theta_o, theta_i) A_p(theta_o, h) N_p(phi_i - phi_o)
//! ```
//!
//! * `M_p`, the longitudinal lobe: a von Mises–Fisher distribution around the mirrored angle
//!   `-theta_o`, shifted by the cuticle scales' tilt (`-2 alpha` for R, `alpha` for TT,
//!   `4 alpha` for TRT, none for the rest), of variance `v_p` from `beta_m` (Chiang's fit:
//!   `v_0 = (0.726 b + 0.812 b^2 + 3.7 b^20)^2`, `v_1 = v_0 / 4`, `v_2 = v_3 = 4 v_0`).
//!   `M_p cos(theta_i) dtheta_i` integrates to one for any `v_p`.
//! * `A_p`, the attenuation: Fresnel reflectance `f` at the cylinder's surface for
//!   `A_0 = f`, and `(1 - f)^2 f^(p-1) T^p` with the transmittance `T` of one chord through the
//!   interior (`exp(-2 sigma_a cos(gamma_t) / cos(theta_t))`); the last lobe sums the
//!   geometric series. With `sigma_a = 0` the `A_p` sum to one.
//! * `N_p`, the azimuthal lobe: a logistic distribution of scale `s` (from `beta_n`:
//!   `s = sqrt(pi / 8) (0.265 b + 1.194 b^2 + 5.372 b^22)`) trimmed to `[-pi, pi]` around the
//!   exit azimuth `2 p gamma_t - 2 gamma_o + p pi` of a smooth cylinder; uniform for the last
//!   lobe.
//!
//! So the directional albedo is exactly `sum_p A_p` ([`Hair::directional_albedo`]).
//!
//! Sampling picks a lobe with probability proportional to the channel mean of its `A_p`, then
//! `theta_i` from the von Mises–Fisher distribution and `phi_i` from the trimmed logistic,
//! both by inversion: the density is `sum_p P(p) M_p N_p`, which `pdf` evaluates, and with
//! `sigma_a = 0` every sample's weight is one.
//!
//! Parameters (pbrt-v4's `hair` material and its defaults): `eta` the fibre's index of
//! refraction (1.55), `sigma_a` the interior's absorption coefficient per unit radius (by
//! default that of eumelanin concentration 1.3: brown hair; see
//! [`Hair::sigma_a_from_concentration`] and [`Hair::sigma_a_from_reflectance`]), `beta_m` and
//! `beta_n` the longitudinal and azimuthal roughness in `[0, 1]` (0.3 each; raised to at least
//! 0.01, as pbrt's material clamps them), `alpha` the scales' tilt in degrees (2).
//!
//! Approximations and departures from pbrt-v4:
//! * RGB, not spectral: `sigma_a` is per channel, where pbrt turns the RGB of the melanin
//!   concentrations into a spectrum and evaluates it per wavelength, so colours differ a
//!   little; the lobe probabilities use the mean of the three channels (pbrt: of its
//!   wavelength samples).
//! * As in pbrt (and the paper), the fits for `v_p` and `s` are approximations of measured
//!   roughness, orders past TRT share TRT's variance and a uniform azimuth, and the model is
//!   not reciprocal (`A_p` and the tilts follow `wo`).
//! * `M_p` is computed as one expression for every variance, with the exponentially scaled
//!   Bessel function `I_0` (Abramowitz and Stegun 9.8.1–2) and the exponent written as a
//!   squared distance, so it neither overflows nor cancels for narrow lobes; pbrt switches to a
//!   logarithmic form below `v = 0.1` with a truncated series. The same function either way.
//! * Where `|cos(wi)|` is below `1e-20`, `f` is divided by `1e-20` instead (it stays finite;
//!   `f |cos(wi)|` is off only on that set of measure zero).

use super::fresnel::fresnel_dielectric;
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// Scattering orders modelled one by one (R, TT, TRT); the rest are lobe `P_MAX`.
const P_MAX: usize = 3;

/// Offsets across the fibre at which [`Bxdf::albedo`] averages the attenuation.
const ALBEDO_NODES: usize = 32;

/// A hair fibre (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Hair {
    /// Offset across the fibre, `[-1, 1]`.
    h: f32,
    eta: f32,
    sigma_a: Spectrum,
    beta_m: f32,
    beta_n: f32,
    /// Scale tilt, degrees.
    alpha: f32,
    /// Longitudinal variance of each lobe.
    v: [f32; P_MAX + 1],
    /// Scale of the azimuthal logistic lobes.
    s: f32,
    /// `(sin, cos)` of the tilt that shifts `theta_o` for lobes R, TT and TRT: `-2 alpha`,
    /// `alpha`, `4 alpha` (the last lobe is not shifted).
    tilt: [(f32, f32); P_MAX],
    /// `sigma_a` holds a spectral sample's four wavelengths (not RGB's three channels).
    spectral: bool,
}

/// What depends on `wo` (and `h`) alone, shared by `eval`, `pdf` and `sample`.
struct Outgoing {
    phi_o: f32,
    gamma_o: f32,
    gamma_t: f32,
    /// `(sin, cos)` of `theta_o` as each lobe sees it (tilted; the cosine made non-negative;
    /// the last lobe's is `theta_o` itself).
    tilted: [(f32, f32); P_MAX + 1],
    /// Attenuation of each lobe.
    ap: [Spectrum; P_MAX + 1],
    /// Probability of sampling each lobe (all zero if no light leaves).
    p_lobe: [f32; P_MAX + 1],
}

#[inline]
fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// `e^-x I_0(x)` for `x >= 0`, to a relative 2e-7 (Abramowitz and Stegun 9.8.1 and 9.8.2).
fn bessel_i0_scaled(x: f32) -> f32 {
    if x < 3.75 {
        let t = (x / 3.75) * (x / 3.75);
        let poly = 1.0
            + t * (3.515_623
                + t * (3.089_942_4
                    + t * (1.206_749_2 + t * (0.265_973_2 + t * (0.036_076_8 + t * 0.004_581_3)))));
        (-x).exp() * poly
    } else {
        let t = 3.75 / x;
        let poly = 0.398_942_3
            + t * (0.013_285_92
                + t * (0.002_253_19
                    + t * (-0.001_575_65
                        + t * (0.009_162_81
                            + t * (-0.020_577_06
                                + t * (0.026_355_37 + t * (-0.016_476_33 + t * 0.003_923_77)))))));
        poly / x.sqrt()
    }
}

/// The longitudinal lobe `M_p`: the density in `theta_i` (per `cos(theta_i) dtheta_i`) of a
/// von Mises–Fisher distribution of concentration `1 / v` around the direction
/// `(cos, sin) = (cos_o, -sin_o)`:
/// `e^(-sin_i sin_o / v) I_0(cos_i cos_o / v) / (2 v sinh(1 / v))`. Written as
/// `e^-a I_0(a) e^(-d^2 / 2v) / (v (1 - e^(-2/v)))` with `d` the distance between the unit
/// vectors `(cos_i, sin_i)` and `(cos_o, -sin_o)`, which is stable for every `v`.
#[inline]
fn longitudinal(cos_i: f32, sin_i: f32, cos_o: f32, sin_o: f32, v: f32) -> f32 {
    let a = cos_i * cos_o / v;
    let (dc, ds) = (cos_i - cos_o, sin_i + sin_o);
    let d2 = dc * dc + ds * ds;
    bessel_i0_scaled(a) * (-d2 / (2.0 * v)).exp() / (v * -(-2.0 / v).exp_m1())
}

/// The exit azimuth of a smooth cylinder's lobe `p` (relative to `phi_o`).
#[inline]
fn exit_azimuth(p: usize, gamma_o: f32, gamma_t: f32) -> f32 {
    let p = p as f32;
    2.0 * p * gamma_t - 2.0 * gamma_o + p * PI
}

/// `x` wrapped into `[-pi, pi)`.
#[inline]
fn wrap_angle(x: f32) -> f32 {
    (x + PI).rem_euclid(TAU) - PI
}

/// The logistic density of scale `s` trimmed (and renormalised) to `[-pi, pi]`: the mass of
/// the logistic on `[-pi, pi]` is `tanh(pi / 2s)`.
#[inline]
fn trimmed_logistic(x: f32, s: f32) -> f32 {
    let e = (-x.abs() / s).exp();
    e / (s * (1.0 + e) * (1.0 + e) * (PI / (2.0 * s)).tanh())
}

/// Inverts the CDF of [`trimmed_logistic`] at `u`.
#[inline]
fn sample_trimmed_logistic(u: f32, s: f32) -> f32 {
    let cdf = |x: f32| 1.0 / (1.0 + (-x / s).exp());
    let (lo, hi) = (cdf(-PI), cdf(PI));
    let u = lo + u * (hi - lo);
    (-s * (1.0 / u - 1.0).ln()).clamp(-PI, PI)
}

impl Default for Hair {
    /// pbrt-v4's default hair: brown (eumelanin 1.3), `eta` 1.55, `beta_m = beta_n = 0.3`,
    /// scales tilted by 2 degrees, hit at the fibre's centre (`h = 0`).
    fn default() -> Self {
        Hair::build(
            0.0,
            1.55,
            Hair::sigma_a_from_concentration(1.3, 0.0),
            0.3,
            0.3,
            2.0,
        )
    }
}

impl Hair {
    /// A fibre hit at offset `h` in `[-1, 1]`, of index of refraction `eta` (at least 1),
    /// absorption `sigma_a` (finite, non-negative, per unit radius), longitudinal and
    /// azimuthal roughness `beta_m` and `beta_n` in `[0, 1]` (raised to at least 0.01), and
    /// scales tilted by `alpha_deg` degrees (in `[-90, 90]`).
    pub fn new(
        h: f32,
        eta: f32,
        sigma_a: Spectrum,
        beta_m: f32,
        beta_n: f32,
        alpha_deg: f32,
    ) -> Result<Hair, String> {
        super::checks::finite("hair parameters", &[h, eta, beta_m, beta_n, alpha_deg])?;
        let sigma_a = super::checks::colour("sigma_a", sigma_a)?;
        if !(-1.0..=1.0).contains(&h) {
            return Err(format!("hair offset h must be in [-1, 1], got {h}"));
        }
        if eta < 1.0 {
            return Err(format!("hair eta must be at least 1, got {eta}"));
        }
        for (what, b) in [("beta_m", beta_m), ("beta_n", beta_n)] {
            if !(0.0..=1.0).contains(&b) {
                return Err(format!("hair {what} must be in [0, 1], got {b}"));
            }
        }
        if alpha_deg.abs() > 90.0 {
            return Err(format!(
                "hair scale tilt alpha must be in [-90, 90] degrees, got {alpha_deg}"
            ));
        }
        Ok(Hair::build(h, eta, sigma_a, beta_m, beta_n, alpha_deg))
    }

    /// The fibre with its derived terms, from valid parameters.
    fn build(h: f32, eta: f32, sigma_a: Spectrum, beta_m: f32, beta_n: f32, alpha: f32) -> Hair {
        let (beta_m, beta_n) = (beta_m.max(0.01), beta_n.max(0.01));
        // Chiang et al.'s fits of the lobes' widths to the roughness parameters.
        let root_v = 0.726 * beta_m + 0.812 * beta_m * beta_m + 3.7 * beta_m.powi(20);
        let v0 = root_v * root_v;
        let v = [v0, 0.25 * v0, 4.0 * v0, 4.0 * v0];
        let sqrt_pi_over_8 = (PI / 8.0).sqrt();
        let s =
            sqrt_pi_over_8 * (0.265 * beta_n + 1.194 * beta_n * beta_n + 5.372 * beta_n.powi(22));
        // sin and cos of alpha, 2 alpha and 4 alpha by the double-angle formulas.
        let mut twice = [(0.0f32, 1.0f32); 3];
        twice[0] = alpha.to_radians().sin_cos();
        for k in 1..3 {
            let (sin, cos) = twice[k - 1];
            twice[k] = (2.0 * sin * cos, cos * cos - sin * sin);
        }
        // R is shifted by -2 alpha, TT by alpha, TRT by 4 alpha.
        let tilt = [(-twice[1].0, twice[1].1), twice[0], twice[2]];
        Hair {
            h,
            eta,
            sigma_a,
            beta_m,
            beta_n,
            alpha,
            v,
            s,
            tilt,
            spectral: false,
        }
    }

    /// The same fibre hit at offset `h` across its width (clamped to `[-1, 1]`; not a number
    /// is the centre, 0). For a curve hit at `v` across the width, `h = 2 v - 1`.
    #[inline]
    pub fn with_h(mut self, h: f32) -> Hair {
        self.h = if h.is_nan() { 0.0 } else { h.clamp(-1.0, 1.0) };
        self
    }

    /// The fibre with its absorption coefficient mapped by `f` (to a spectral sample's).
    pub(crate) fn map_sigma_a(&mut self, f: impl FnOnce(Spectrum) -> Spectrum) {
        self.sigma_a = f(self.sigma_a);
        self.spectral = true;
    }

    /// Offset across the fibre, in `[-1, 1]`.
    #[inline]
    pub fn h(&self) -> f32 {
        self.h
    }

    /// Index of refraction of the fibre.
    #[inline]
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// Absorption coefficient of the interior, per unit radius.
    #[inline]
    pub fn sigma_a(&self) -> Spectrum {
        self.sigma_a
    }

    /// Longitudinal roughness (at least 0.01).
    #[inline]
    pub fn beta_m(&self) -> f32 {
        self.beta_m
    }

    /// Azimuthal roughness (at least 0.01).
    #[inline]
    pub fn beta_n(&self) -> f32 {
        self.beta_n
    }

    /// Tilt of the cuticle scales, degrees.
    #[inline]
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// Absorption of a fibre with the given concentrations of eumelanin (brown–black pigment)
    /// and pheomelanin (red–yellow), each clamped to be non-negative: Chiang et al.'s (and
    /// pbrt-v4's) absorption coefficients per unit concentration, as RGB. Concentrations
    /// around 0.3 make blond hair, 1.3 brown, 8 black.
    pub fn sigma_a_from_concentration(eumelanin: f32, pheomelanin: f32) -> Spectrum {
        const EUMELANIN: Spectrum = crate::spectrum::rgb(0.419, 0.697, 1.37);
        const PHEOMELANIN: Spectrum = crate::spectrum::rgb(0.187, 0.4, 1.05);
        let finite = |c: f32| if c.is_finite() { c.max(0.0) } else { 0.0 };
        EUMELANIN * finite(eumelanin) + PHEOMELANIN * finite(pheomelanin)
    }

    /// The absorption that gives hair of azimuthal roughness `beta_n` roughly the colour
    /// `reflectance` after multiple scattering in a head of hair (Chiang et al.'s fit, as
    /// pbrt-v4): `(ln c / P(beta_n))^2` per channel with a quintic `P`. Each channel is
    /// clamped into `[0, 1]`, and kept above the smallest normal float so that black stays
    /// finite.
    pub fn sigma_a_from_reflectance(reflectance: Spectrum, beta_n: f32) -> Spectrum {
        let b = beta_n;
        let b2 = b * b;
        let denominator =
            5.969 - 0.215 * b + 2.532 * b2 - 10.73 * b2 * b + 5.574 * b2 * b2 + 0.245 * b2 * b2 * b;
        reflectance.map(|c| {
            let c = if c.is_nan() {
                0.0
            } else {
                c.clamp(f32::MIN_POSITIVE, 1.0)
            };
            let x = c.ln() / denominator;
            x * x
        })
    }

    /// The fraction of the light arriving from `wo` that the fibre scatters (into any
    /// direction): exactly `sum_p A_p`, since each lobe's `M_p N_p` integrates to one.
    pub fn directional_albedo(&self, wo: Vec3A) -> Spectrum {
        self.outgoing(wo).ap.iter().copied().sum()
    }

    /// The terms that depend on `wo` only.
    fn outgoing(&self, wo: Vec3A) -> Outgoing {
        let sin_o = wo.x.clamp(-1.0, 1.0);
        let cos_o = safe_sqrt(1.0 - sin_o * sin_o);
        let phi_o = wo.z.atan2(wo.y);
        let h = self.h;
        let gamma_o = h.asin();
        // The refracted ray: its longitudinal angle, and its azimuth in the cross-section,
        // where the modified index sqrt(eta^2 - sin^2) / cos of Bravais' law applies.
        let sin_t = sin_o / self.eta;
        let cos_t = safe_sqrt(1.0 - sin_t * sin_t);
        let modified = safe_sqrt(self.eta * self.eta - sin_o * sin_o);
        let sin_gamma_t = if modified > 0.0 {
            (h * cos_o / modified).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let cos_gamma_t = safe_sqrt(1.0 - sin_gamma_t * sin_gamma_t);
        let gamma_t = sin_gamma_t.asin();
        // One chord through the interior, and its transmittance.
        let chord = if cos_t > 0.0 {
            2.0 * cos_gamma_t / cos_t
        } else {
            f32::MAX
        };
        let t = (-self.sigma_a * chord).exp();
        // Attenuation of each lobe.
        let f = fresnel_dielectric(cos_o * safe_sqrt(1.0 - h * h), self.eta);
        let ap0 = Spectrum::splat(f);
        let ap1 = t * ((1.0 - f) * (1.0 - f));
        let ap2 = ap1 * t * f;
        let tf = t * f;
        let rest = Spectrum::ONE - tf;
        let ap3 = Spectrum::select(rest.cmpgt(Spectrum::ZERO), ap2 * tf / rest, Spectrum::ZERO);
        let ap = [ap0, ap1, ap2, ap3];
        // Lobe probabilities from the means over the lanes.
        let mean = ap.map(|a| match self.spectral {
            false => crate::spectrum::rgb_of(a).element_sum() / 3.0,
            true => a.element_sum() / crate::spectrum::N as f32,
        });
        let total: f32 = mean.iter().sum();
        let p_lobe = if total > 0.0 && total.is_finite() {
            mean.map(|m| m / total)
        } else {
            [0.0; P_MAX + 1]
        };
        // theta_o as each lobe sees it, tilted by the scales.
        let mut tilted = [(sin_o, cos_o); P_MAX + 1];
        for (p, &(sin_a, cos_a)) in self.tilt.iter().enumerate() {
            tilted[p] = (
                sin_o * cos_a + cos_o * sin_a,
                (cos_o * cos_a - sin_o * sin_a).abs(),
            );
        }
        Outgoing {
            phi_o,
            gamma_o,
            gamma_t,
            tilted,
            ap,
            p_lobe,
        }
    }

    /// `(f, pdf)` of `wi` for the outgoing terms `o`.
    fn eval_pdf_with(&self, o: &Outgoing, wi: Vec3A) -> (Spectrum, f32) {
        let sin_i = wi.x.clamp(-1.0, 1.0);
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        let phi = wi.z.atan2(wi.y) - o.phi_o;
        let (mut f, mut pdf) = (Spectrum::ZERO, 0.0);
        for p in 0..P_MAX {
            let (sin_o, cos_o) = o.tilted[p];
            let m = longitudinal(cos_i, sin_i, cos_o, sin_o, self.v[p]);
            let dphi = wrap_angle(phi - exit_azimuth(p, o.gamma_o, o.gamma_t));
            let mn = m * trimmed_logistic(dphi, self.s);
            f += o.ap[p] * mn;
            pdf += o.p_lobe[p] * mn;
        }
        let (sin_o, cos_o) = o.tilted[P_MAX];
        let mn = longitudinal(cos_i, sin_i, cos_o, sin_o, self.v[P_MAX]) * (0.5 * FRAC_1_PI);
        f += o.ap[P_MAX] * mn;
        pdf += o.p_lobe[P_MAX] * mn;
        (f / wi.z.abs().max(1e-20), pdf)
    }
}

impl Bxdf for Hair {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::GLOSSY_REFLECTION.with(Lobes::GLOSSY_TRANSMISSION)
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        self.eval_pdf_with(&self.outgoing(wo), wi).0
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        self.eval_pdf_with(&self.outgoing(wo), wi).1
    }

    fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Spectrum, f32) {
        self.eval_pdf_with(&self.outgoing(wo), wi)
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if !wo.is_finite() {
            return None;
        }
        let o = self.outgoing(wo);
        // The lobe, and u_lobe rescaled to place the azimuth within it.
        let last = o.p_lobe.iter().rposition(|&q| q > 0.0)?;
        let mut rest = u_lobe;
        let mut p = 0;
        while p < last && rest >= o.p_lobe[p] {
            rest -= o.p_lobe[p];
            p += 1;
        }
        let uc = (rest / o.p_lobe[p]).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
        // theta_i: the cosine of the angle from the lobe's axis by inversion of the von
        // Mises–Fisher distribution, a uniform angle around the axis, projected.
        let (sin_o, cos_o) = o.tilted[p];
        let v = self.v[p];
        let w = u.x + (1.0 - u.x) * (-2.0 / v).exp();
        let cos_axis = if w > 0.0 {
            (1.0 + v * w.ln()).clamp(-1.0, 1.0)
        } else {
            -1.0
        };
        let sin_axis = safe_sqrt(1.0 - cos_axis * cos_axis);
        let around = (TAU * u.y).cos();
        let sin_i = (-cos_axis * sin_o + sin_axis * around * cos_o).clamp(-1.0, 1.0);
        let cos_i = safe_sqrt(1.0 - sin_i * sin_i);
        // phi_i: the lobe's azimuthal distribution.
        let dphi = if p < P_MAX {
            exit_azimuth(p, o.gamma_o, o.gamma_t) + sample_trimmed_logistic(uc, self.s)
        } else {
            TAU * uc
        };
        let (sin_phi, cos_phi) = (o.phi_o + dphi).sin_cos();
        let wi = Vec3A::new(sin_i, cos_i * cos_phi, cos_i * sin_phi);
        let (f, pdf) = self.eval_pdf_with(&o, wi);
        (pdf > 0.0 && pdf.is_finite() && f.is_finite()).then(|| BsdfSample::reflection(wi, f, pdf))
    }

    /// A proxy: the fraction of light a fibre lit perpendicularly (`theta_o = 0`) scatters,
    /// averaged across its width (midpoint rule over `h`), whatever this fibre's own `h`.
    fn albedo(&self) -> Spectrum {
        let mut sum = Spectrum::ZERO;
        for i in 0..ALBEDO_NODES {
            let h = -1.0 + (2 * i + 1) as f32 / ALBEDO_NODES as f32;
            sum += self.clone().with_h(h).directional_albedo(Vec3A::Z);
        }
        sum / ALBEDO_NODES as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::Material;
    use crate::sampling::{uniform_sphere, UNIFORM_SPHERE_PDF};
    use crate::testing::chi2::{assert_chi2, check_sample_matches_eval, dir, Grid, SAMPLES};
    use crate::Sampler;
    use glam::DVec3;

    fn fibre(h: f32, sigma_a: Spectrum, beta_m: f32, beta_n: f32, alpha: f32) -> Hair {
        Hair::new(h, 1.55, sigma_a, beta_m, beta_n, alpha).expect("valid hair")
    }

    fn to_d(c: Spectrum) -> DVec3 {
        DVec3::new(c.x as f64, c.y as f64, c.z as f64)
    }

    /// Midpoint rule over the sphere in the fibre's angles (`theta` in `[-pi/2, pi/2]`,
    /// `phi` in `[-pi, pi]`, `dw = cos(theta) dtheta dphi`), with nodes a fraction of the
    /// narrowest lobe's width apart: the integrals of `f |cos(wi)| g(wi)` (per channel) and of
    /// the density.
    fn sphere_integrals(hair: &Hair, wo: Vec3A, g: impl Fn(Vec3A) -> f64) -> (DVec3, f64) {
        let narrowest = hair.v[1].sqrt() as f64;
        let n_theta = ((std::f64::consts::PI / (0.25 * narrowest)).ceil() as usize).max(128);
        let n_phi = ((std::f64::consts::TAU / (0.5 * hair.s as f64)).ceil() as usize).max(128);
        let n_phi = n_phi + n_phi % 2;
        let (d_theta, d_phi) = (
            std::f64::consts::PI / n_theta as f64,
            std::f64::consts::TAU / n_phi as f64,
        );
        let o = hair.outgoing(wo);
        let (mut f_sum, mut pdf_sum) = (DVec3::ZERO, 0.0f64);
        for i in 0..n_theta {
            let theta = -std::f64::consts::FRAC_PI_2 + (i as f64 + 0.5) * d_theta;
            let (sin_t, cos_t) = theta.sin_cos();
            let (mut f_row, mut pdf_row) = (DVec3::ZERO, 0.0f64);
            for j in 0..n_phi {
                let phi = -std::f64::consts::PI + (j as f64 + 0.5) * d_phi;
                let (sin_p, cos_p) = phi.sin_cos();
                let wi = Vec3A::new(sin_t as f32, (cos_t * cos_p) as f32, (cos_t * sin_p) as f32);
                let (f, pdf) = hair.eval_pdf_with(&o, wi);
                f_row += to_d(f) * (wi.z.abs() as f64 * g(wi));
                pdf_row += pdf as f64;
            }
            f_sum += f_row * cos_t;
            pdf_sum += pdf_row * cos_t;
        }
        (f_sum * d_theta * d_phi, pdf_sum * d_theta * d_phi)
    }

    /// Directions of incidence that the tests share: generic, near the fibre's axis, below
    /// the normal plane, near normal incidence.
    const DIRECTIONS: [(f32, f32); 4] = [(40.0, 30.0), (15.0, 80.0), (120.0, 250.0), (85.0, 5.0)];

    /// pbrt-v4's `Hair.WhiteFurnace`, by quadrature: without absorption the fibre scatters
    /// all the light it receives, from every direction, at every offset and roughness.
    #[test]
    fn white_furnace_integrates_to_one() {
        let betas = [0.1f32, 0.4, 0.7, 1.0];
        let offsets = [-0.99f32, -0.4, 0.3, 0.9];
        let mut worst = 0.0f64;
        let mut k = 0;
        for &beta_m in &betas {
            for &beta_n in &betas {
                for &h in &offsets {
                    let hair = fibre(h, Spectrum::ZERO, beta_m, beta_n, 2.0);
                    k += 1;
                    let (theta, phi) = DIRECTIONS[k % DIRECTIONS.len()];
                    let wo = dir(theta, phi);
                    let (f, pdf) = sphere_integrals(&hair, wo, |_| 1.0);
                    for c in 0..3 {
                        worst = worst.max((f[c] - 1.0).abs());
                    }
                    assert!(
                        (f - DVec3::ONE).abs().max_element() < 2e-3 && (pdf - 1.0).abs() < 2e-3,
                        "beta_m {beta_m} beta_n {beta_n} h {h} wo {wo}: {f} (pdf {pdf})"
                    );
                }
            }
        }
        println!("white furnace by quadrature: 64 fibres, worst |integral - 1| = {worst:.2e}");
    }

    /// The radical inverse of `i` in base `b` (a Halton coordinate), as pbrt's tests use.
    fn radical_inverse(b: u64, mut i: u64) -> f64 {
        let (mut x, mut scale) = (0.0f64, 1.0 / b as f64);
        while i > 0 {
            x += (i % b) as f64 * scale;
            i /= b;
            scale /= b as f64;
        }
        x
    }

    /// pbrt-v4's `Hair.WhiteFurnace` as pbrt runs it: uniform directions and an offset for
    /// each from a Halton sequence, averaged; within pbrt's 5% of one.
    #[test]
    fn white_furnace_uniform_sampling() {
        let mut s = Sampler::new(4101, 0, 0);
        let wo = uniform_sphere(s.next_2d());
        let mut worst = 0.0f64;
        for beta_m in [0.1f32, 0.3, 0.5, 0.7, 0.9] {
            for beta_n in [0.1f32, 0.3, 0.5, 0.7, 0.9] {
                let n = if beta_m < 0.5 || beta_n < 0.5 {
                    100_000
                } else {
                    20_000
                };
                let base = fibre(0.0, Spectrum::ZERO, beta_m, beta_n, 0.0);
                let mut sum = 0.0f64;
                for i in 0..n {
                    let h = (-1.0 + 2.0 * radical_inverse(3, i)).clamp(-0.999_999, 0.999_999);
                    let hair = base.clone().with_h(h as f32);
                    let u = Vec2::new(radical_inverse(5, i) as f32, radical_inverse(7, i) as f32);
                    let wi = uniform_sphere(u);
                    sum += (hair.eval(wo, wi) * wi.z.abs() / UNIFORM_SPHERE_PDF).x as f64;
                }
                let mean = sum / n as f64;
                worst = worst.max((mean - 1.0).abs());
                assert!(
                    (mean - 1.0).abs() < 0.05,
                    "beta_m {beta_m} beta_n {beta_n}: {mean}"
                );
            }
        }
        println!("white furnace, uniform sampling: worst |mean - 1| = {worst:.2e}");
    }

    /// pbrt-v4's `Hair.WhiteFurnaceSampled` and `Hair.SamplingWeights`: without absorption
    /// the lobe probabilities are the attenuations themselves, so every sample's weight is one.
    #[test]
    fn white_furnace_sampled_weights_are_one() {
        let mut s = Sampler::new(4102, 0, 0);
        let mut worst = 0.0f32;
        for beta_m in [0.1f32, 0.3, 0.5, 0.7, 0.9] {
            for beta_n in [0.1f32, 0.3, 0.5, 0.7, 0.9] {
                let base = fibre(0.0, Spectrum::ZERO, beta_m, beta_n, 2.0);
                let n = 10_000;
                let mut sum = Spectrum::ZERO;
                for _ in 0..n {
                    let h = -1.0 + 2.0 * s.next_1d();
                    let hair = base.clone().with_h(h);
                    let wo = uniform_sphere(s.next_2d());
                    let Some(b) = hair.sample(wo, s.next_1d(), s.next_2d()) else {
                        panic!("no sample at wo {wo} h {h}");
                    };
                    let w = b.weight();
                    worst = worst.max((w - Spectrum::ONE).abs().max_element());
                    assert!(
                        (w - Spectrum::ONE).abs().max_element() < 1e-3,
                        "weight {w} at wo {wo} wi {} h {h}",
                        b.wi
                    );
                    sum += w;
                }
                let mean = sum / n as f32;
                assert!(
                    (mean - Spectrum::ONE).abs().max_element() < 1e-3,
                    "beta_m {beta_m} beta_n {beta_n}: mean weight {mean}"
                );
            }
        }
        println!("sampled white furnace: worst |weight - 1| = {worst:.2e}");
    }

    /// The density integrates to one and `f |cos|` to the directional albedo `sum_p A_p`,
    /// with absorption (where the lobe probabilities are the channel means, not the `A_p`).
    #[test]
    fn pdf_and_albedo_integrate_exactly() {
        let absorptions = [
            Hair::sigma_a_from_concentration(1.3, 0.0),
            Hair::sigma_a_from_concentration(0.3, 0.2),
            Hair::sigma_a_from_reflectance(crate::spectrum::rgb(0.8, 0.3, 0.1), 0.5),
            crate::spectrum::rgb(0.25, 0.25, 0.25),
        ];
        let mut worst = (0.0f64, 0.0f64);
        for (k, &sigma_a) in absorptions.iter().enumerate() {
            for (i, &(beta_m, beta_n, h, alpha)) in [
                (0.3f32, 0.3f32, 0.0f32, 2.0f32),
                (0.1, 0.8, -0.7, 3.0),
                (0.7, 0.15, 0.95, -2.0),
                (1.0, 1.0, 0.5, 10.0),
            ]
            .iter()
            .enumerate()
            {
                let hair = fibre(h, sigma_a, beta_m, beta_n, alpha);
                let (theta, phi) = DIRECTIONS[(k + i) % DIRECTIONS.len()];
                let wo = dir(theta, phi);
                let (f, pdf) = sphere_integrals(&hair, wo, |_| 1.0);
                let albedo = to_d(hair.directional_albedo(wo));
                worst.0 = worst.0.max((pdf - 1.0).abs());
                worst.1 = worst.1.max((f - albedo).abs().max_element());
                assert!(
                    (pdf - 1.0).abs() < 2e-3,
                    "{hair:?} at {wo}: pdf integrates to {pdf}"
                );
                assert!(
                    (f - albedo).abs().max_element() < 2e-3,
                    "{hair:?} at {wo}: f |cos| integrates to {f}, albedo {albedo}"
                );
                assert!(albedo.max_element() < 1.0 && albedo.min_element() > 0.0);
            }
        }
        println!(
            "with absorption: worst |pdf integral - 1| = {:.2e}, |f integral - albedo| = {:.2e}",
            worst.0, worst.1
        );
    }

    /// pbrt-v4's `Hair.SamplingConsistency`: importance sampling and quadrature agree on the
    /// light scattered from a non-uniform environment (`L = z^2`) by an absorbing fibre.
    #[test]
    fn sampling_agrees_with_quadrature() {
        let light = |w: Vec3A| (w.z * w.z) as f64;
        let mut s = Sampler::new(4103, 0, 0);
        for (k, beta_m) in [0.2f32, 0.4, 0.6, 0.8].into_iter().enumerate() {
            for (i, beta_n) in [0.4f32, 0.6, 0.8].into_iter().enumerate() {
                let hair = fibre(
                    -0.3 + 0.4 * i as f32,
                    Spectrum::splat(0.25),
                    beta_m,
                    beta_n,
                    2.0,
                );
                let (theta, phi) = DIRECTIONS[(k + i) % DIRECTIONS.len()];
                let wo = dir(theta, phi);
                let (reference, _) = sphere_integrals(&hair, wo, light);
                let n = 40_000;
                let (mut sum, mut sum2) = (0.0f64, 0.0f64);
                for _ in 0..n {
                    if let Some(b) = hair.sample(wo, s.next_1d(), s.next_2d()) {
                        let y = b.weight().x as f64 * light(b.wi);
                        sum += y;
                        sum2 += y * y;
                    }
                }
                let mean = sum / n as f64;
                let err = ((sum2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
                assert!(
                    (mean - reference.x).abs() < 4.5 * err + 1e-4,
                    "beta_m {beta_m} beta_n {beta_n}: sampled {mean} +- {err}, quadrature {}",
                    reference.x
                );
            }
        }
    }

    /// The sampled `f` and `pdf` are `eval` and `pdf` at the sampled direction, from both
    /// sides of the normal plane, near the fibre's axis and at the fibre's edges.
    #[test]
    fn samples_match_eval_and_pdf() {
        let brown = Hair::default();
        let cases = [
            (brown.clone(), dir(40.0, 30.0)),
            (brown.clone().with_h(-1.0), dir(120.0, 250.0)),
            (brown.with_h(1.0), Vec3A::new(0.999, 0.03, 0.0).normalize()),
            (
                fibre(0.6, crate::spectrum::rgb(0.1, 0.9, 3.0), 0.1, 0.1, 4.0),
                dir(95.0, 170.0),
            ),
            (fibre(-0.2, Spectrum::ZERO, 1.0, 1.0, -3.0), -Vec3A::Z),
            (
                fibre(
                    0.0,
                    Hair::sigma_a_from_concentration(8.0, 0.0),
                    0.05,
                    0.3,
                    2.0,
                ),
                Vec3A::X,
            ),
        ];
        for (i, (hair, wo)) in cases.iter().enumerate() {
            check_sample_matches_eval(hair, *wo, 20_000, 4104 + i as u64);
        }
    }

    fn chi2_hair(name: &str, hair: &Hair, wo: Vec3A, grid: &Grid, seed: u64) {
        assert_chi2(
            name,
            grid,
            SAMPLES,
            seed,
            |s| hair.sample(wo, s.next_1d(), s.next_2d()).map(|b| b.wi),
            |w| hair.pdf(wo, w),
        );
    }

    #[test]
    fn chi2_hair_default() {
        let hair = Hair::default().with_h(0.3);
        chi2_hair(
            "hair, pbrt's default",
            &hair,
            dir(50.0, 20.0),
            &Grid::sphere(30, 60),
            4111,
        );
    }

    #[test]
    fn chi2_hair_narrow_tilted() {
        // Narrow lobes: the grid's pole along the fibre, so that rows follow M_p.
        let hair = fibre(-0.8, crate::spectrum::rgb(0.3, 0.5, 0.9), 0.1, 0.15, 4.0);
        let grid = Grid::new(Vec3A::X, 2.0, 60, 120);
        chi2_hair(
            "hair, narrow and tilted",
            &hair,
            dir(70.0, 200.0),
            &grid,
            4112,
        );
    }

    #[test]
    fn chi2_hair_grazing_black() {
        // Black hair seen almost along the fibre from below the normal plane: mostly R.
        let hair = fibre(
            0.97,
            Hair::sigma_a_from_concentration(8.0, 0.0),
            0.5,
            0.6,
            2.0,
        );
        let wo = Vec3A::new(0.95, 0.2, -0.3).normalize();
        chi2_hair(
            "hair, grazing and black",
            &hair,
            wo,
            &Grid::sphere(30, 60),
            4113,
        );
    }

    /// Values of a double-precision transcription of pbrt-v4's `HairBxDF::f` and `PDF` (with
    /// an exact `I_0`; RGB absorption, lobes chosen by the channel mean).
    #[test]
    fn matches_pbrts_formulas() {
        let unit = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z).normalize();
        let cases = [
            (
                Hair::new(
                    0.3,
                    1.55,
                    Hair::sigma_a_from_concentration(1.3, 0.0),
                    0.3,
                    0.3,
                    2.0,
                ),
                unit(0.3, 0.2, 0.9),
                unit(-0.25, 0.5, 0.6),
                [1.428_837_2e-1, 1.427_101_7e-1, 1.426_604_8e-1],
                5.009_06e-1,
            ),
            (
                Hair::new(
                    -0.7,
                    1.55,
                    crate::spectrum::rgb(0.2, 0.5, 1.0),
                    0.2,
                    0.5,
                    3.0,
                ),
                unit(-0.5, 0.7, 0.3),
                unit(0.45, -0.3, -0.8),
                [2.883_615_4, 1.603_197_2, 6.027_511e-1],
                3.282_055_8,
            ),
            (
                Hair::new(0.95, 1.4, Spectrum::ZERO, 0.6, 0.15, -2.0),
                unit(0.1, -0.9, 0.2),
                unit(-0.1, -0.2, 0.95),
                [2.144_552_7e-3; 3],
                2.087_506_5e-3,
            ),
            (
                Hair::new(
                    0.0,
                    1.55,
                    crate::spectrum::rgb(1.0, 2.0, 3.0),
                    0.12,
                    0.8,
                    5.0,
                ),
                unit(0.8, 0.1, 0.5),
                unit(-0.7, 0.3, 0.6),
                [3.067_743e-1, 3.067_225_2e-1, 3.067_221e-1],
                1.655_827_9,
            ),
            (
                Hair::new(-0.2, 1.55, Spectrum::splat(0.1), 0.05, 0.3, 2.0),
                unit(0.2, 0.3, 0.9),
                unit(-0.21, 0.5, 0.8),
                [7.710_32e-2; 3],
                7.781_16e-2,
            ),
        ];
        for (hair, wo, wi, f_ref, pdf_ref) in cases {
            let hair = hair.expect("valid hair");
            let (f, pdf) = hair.eval_pdf(wo, wi);
            for c in 0..3 {
                assert!(
                    (f[c] - f_ref[c]).abs() <= 2e-4 * f_ref[c],
                    "{hair:?}: f {f} vs {f_ref:?}"
                );
            }
            assert!(
                (pdf - pdf_ref).abs() <= 2e-4 * pdf_ref,
                "{hair:?}: pdf {pdf} vs {pdf_ref}"
            );
        }
    }

    #[test]
    fn bessel_i0_scaled_is_accurate() {
        let reference = |x: f64| {
            // The power series, in f64 (converges everywhere; exact enough below 40).
            let (mut sum, mut term, mut k) = (0.0f64, 1.0f64, 0.0f64);
            while term > 1e-17 * sum || k < 2.0 {
                sum += term;
                k += 1.0;
                term *= x * x / (4.0 * k * k);
            }
            sum * (-x).exp()
        };
        for i in 0..4000 {
            let x = i as f32 * 0.01;
            let r = reference(x as f64);
            let got = bessel_i0_scaled(x) as f64;
            assert!((got / r - 1.0).abs() < 5e-7, "{x}: {got} vs {r}");
        }
        // The asymptote 1 / sqrt(2 pi x) far out.
        let x = 1e6f32;
        let asymptote = 1.0 / (TAU * x).sqrt();
        assert!((bessel_i0_scaled(x) / asymptote - 1.0).abs() < 1e-6);
    }

    /// pbrt-v4's `Hair.HOnTheEdge`, and the other edges: a fibre hit at its very edge, light
    /// along the fibre, directions in the normal plane, the narrowest lobes.
    #[test]
    fn edges_are_finite() {
        let wo = Vec3A::new(0.549_869_66, 0.033_590_17, 0.834_574_76);
        let wi = Vec3A::new(-0.373_833_57, -0.919_200_84, 0.123_766_96);
        for hair in [
            fibre(-1.0, Spectrum::ZERO, 0.1, 0.1, 0.0),
            fibre(1.0, Spectrum::splat(5.0), 0.0, 0.0, 2.0),
            Hair::new(0.5, 1.0, Spectrum::splat(1e3), 1.0, 1.0, 90.0).expect("valid"),
        ] {
            for (a, b) in [
                (wo, wi),
                (Vec3A::X, wi),
                (wo, -Vec3A::X),
                (Vec3A::X, -Vec3A::X),
                (wo, Vec3A::Y),
                (Vec3A::Y, Vec3A::new(0.0, -1.0, 0.0)),
            ] {
                let (f, pdf) = hair.eval_pdf(a, b);
                assert!(
                    f.is_finite() && f.min_element() >= 0.0,
                    "{hair:?} {a} {b}: {f}"
                );
                assert!(pdf.is_finite() && pdf >= 0.0, "{hair:?} {a} {b}: {pdf}");
            }
            let mut s = Sampler::new(4105, 0, 0);
            for wo in [wo, Vec3A::X, -Vec3A::X, Vec3A::Y] {
                for _ in 0..1000 {
                    if let Some(b) = hair.sample(wo, s.next_1d(), s.next_2d()) {
                        assert!(b.weight().is_finite() && b.f.is_finite(), "{hair:?} {wo}");
                    }
                }
                // The extremes of the random numbers.
                for (ul, u) in [(0.0, Vec2::ZERO), (0.999_999_9, Vec2::splat(0.999_999_9))] {
                    if let Some(b) = hair.sample(wo, ul, u) {
                        assert!(b.weight().is_finite() && (b.wi.length() - 1.0).abs() < 1e-4);
                    }
                }
            }
        }
        assert!(Hair::default()
            .sample(Vec3A::NAN, 0.5, Vec2::splat(0.5))
            .is_none());
    }

    #[test]
    fn absorption_from_reflectance_and_concentration() {
        // Chiang et al.'s fit at c = 0.5, 0.2 and 0.9 (the quintic by hand, in f64).
        let a = Hair::sigma_a_from_reflectance(crate::spectrum::rgb(0.5, 0.2, 0.9), 0.3);
        let b = Hair::sigma_a_from_reflectance(Spectrum::splat(0.9), 0.7);
        for (got, want) in [
            (a.x, 0.013_856_519),
            (a.y, 0.074_705_34),
            (b.x, 4.902_922e-4),
        ] {
            assert!((got - want).abs() < 1e-5 * want, "{got} vs {want}");
        }
        // White hair does not absorb; darker asks for more absorption, finite even for black.
        for beta_n in [0.1f32, 0.3, 0.6, 1.0] {
            assert_eq!(
                Hair::sigma_a_from_reflectance(Spectrum::ONE, beta_n),
                Spectrum::ZERO
            );
            let mut last = 0.0f32;
            for i in (0..=20).rev() {
                let c = i as f32 / 20.0;
                let sigma = Hair::sigma_a_from_reflectance(Spectrum::splat(c), beta_n);
                assert!(sigma.is_finite() && sigma.min_element() >= 0.0);
                assert!(sigma.x >= last, "beta_n {beta_n}, c {c}");
                if i < 20 {
                    assert!(sigma.x > last);
                }
                last = sigma.x;
            }
        }
        // Concentrations: linear in each pigment, eumelanin bluer-absorbing than pheomelanin.
        let e = Hair::sigma_a_from_concentration(1.0, 0.0);
        let p = Hair::sigma_a_from_concentration(0.0, 1.0);
        assert_eq!(e, crate::spectrum::rgb(0.419, 0.697, 1.37));
        assert_eq!(p, crate::spectrum::rgb(0.187, 0.4, 1.05));
        let mix = Hair::sigma_a_from_concentration(2.0, 0.5);
        assert!((mix - (e * 2.0 + p * 0.5)).abs().max_element() < 1e-6);
        assert_eq!(
            Hair::sigma_a_from_concentration(-1.0, f32::NAN),
            Spectrum::ZERO
        );
        // The colours they make: brown hair is red > green > blue, more pigment is darker,
        // and a fibre given the absorption for a reflectance is lighter where it is lighter.
        let brown = Hair::default().albedo();
        assert!(
            brown.x > brown.y && brown.y > brown.z && brown.x < 1.0,
            "{brown}"
        );
        let mut last = Spectrum::ONE;
        for c in [0.0f32, 0.3, 1.3, 3.0, 8.0] {
            let hair = fibre(0.0, Hair::sigma_a_from_concentration(c, 0.0), 0.3, 0.3, 2.0);
            let albedo = hair.albedo();
            assert!(albedo.cmple(last).all() && albedo.min_element() > 0.0);
            last = albedo;
        }
        let wanted = crate::spectrum::rgb(0.7, 0.4, 0.1);
        let tinted = fibre(
            0.0,
            Hair::sigma_a_from_reflectance(wanted, 0.3),
            0.3,
            0.3,
            2.0,
        );
        let albedo = tinted.albedo();
        assert!(albedo.x > albedo.y && albedo.y > albedo.z, "{albedo}");
        assert!(
            (fibre(0.0, Spectrum::ZERO, 0.3, 0.3, 2.0).albedo() - Spectrum::ONE)
                .abs()
                .max_element()
                < 1e-5
        );
    }

    #[test]
    fn constructor_checks_and_offsets() {
        let ok =
            |h, eta, beta_m, beta_n, alpha| Hair::new(h, eta, Spectrum::ONE, beta_m, beta_n, alpha);
        assert!(ok(0.0, 1.55, 0.3, 0.3, 2.0).is_ok());
        assert!(ok(1.5, 1.55, 0.3, 0.3, 2.0)
            .unwrap_err()
            .contains("[-1, 1]"));
        assert!(ok(0.0, 0.9, 0.3, 0.3, 2.0).unwrap_err().contains("eta"));
        assert!(ok(0.0, 1.55, 1.2, 0.3, 2.0).unwrap_err().contains("beta_m"));
        assert!(ok(0.0, 1.55, 0.3, -0.1, 2.0)
            .unwrap_err()
            .contains("beta_n"));
        assert!(ok(0.0, 1.55, 0.3, 0.3, 100.0)
            .unwrap_err()
            .contains("alpha"));
        assert!(ok(f32::NAN, 1.55, 0.3, 0.3, 2.0)
            .unwrap_err()
            .contains("finite"));
        assert!(Hair::new(0.0, 1.55, Spectrum::splat(-1.0), 0.3, 0.3, 2.0).is_err());
        // Roughness is raised to 0.01, as pbrt's material does.
        let smooth = ok(0.0, 1.55, 0.0, 0.001, 2.0).expect("valid");
        assert_eq!((smooth.beta_m(), smooth.beta_n()), (0.01, 0.01));
        // Offsets: clamped, and not a number is the centre.
        let d = Hair::default();
        assert_eq!(d.clone().with_h(3.0).h(), 1.0);
        assert_eq!(d.clone().with_h(-3.0).h(), -1.0);
        assert_eq!(d.clone().with_h(f32::NAN).h(), 0.0);
        // pbrt-v4's defaults.
        assert_eq!(
            (d.h(), d.eta(), d.beta_m(), d.beta_n(), d.alpha()),
            (0.0, 1.55, 0.3, 0.3, 2.0)
        );
        assert_eq!(d.sigma_a(), Hair::sigma_a_from_concentration(1.3, 0.0));
        // The offset moves the azimuthal lobes: f depends on it.
        let (wo, wi) = (dir(60.0, 80.0), dir(100.0, 300.0));
        assert_ne!(
            d.clone().with_h(-0.5).eval(wo, wi),
            d.clone().with_h(0.5).eval(wo, wi)
        );
    }

    /// As a material: transmissive (directions are not mirrored; paths cross the normal
    /// plane), oriented by the tangent, never a delta.
    #[test]
    fn as_a_material() {
        let hair = Hair::default().with_h(0.4);
        let m = Material::Hair(hair.clone());
        assert!(m.is_transmissive() && m.is_anisotropic());
        assert!(!m.is_specular() && !m.has_delta_lobe());
        assert_eq!(m.lobes(), hair.lobes());
        let mut s = Sampler::new(4106, 0, 0);
        let mut crossed = 0;
        for wo in [dir(30.0, 40.0), -dir(30.0, 40.0), dir(100.0, 10.0)] {
            assert_eq!(m.delta_probability(wo), 0.0);
            for _ in 0..2000 {
                let (ul, u) = (s.next_1d(), s.next_2d());
                let b = m.sample(wo, ul, u).expect("a sample");
                let direct = hair.sample(wo, ul, u).expect("a sample");
                assert_eq!(b.wi, direct.wi);
                assert_eq!(m.eval(wo, b.wi), hair.eval(wo, b.wi));
                assert_eq!(m.pdf(wo, b.wi), hair.pdf(wo, b.wi));
                assert_eq!(b.eta, 1.0);
                crossed += (b.wi.z * wo.z < 0.0) as u32;
                let importance = m.sample_weight(wo, &b, crate::bsdf::TransportMode::Importance);
                assert_eq!(importance, b.weight());
            }
        }
        assert!(crossed > 100, "{crossed}");
    }
}
