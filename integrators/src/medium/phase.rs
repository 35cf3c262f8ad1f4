//! Phase functions: how a medium scatters light at a point (pbrt-v4's `PhaseFunction`,
//! Mitsuba 3's `phase`). Directions follow the BSDFs' convention, both pointing away from the
//! scattering point: `wo` back towards where the path came from, `wi` the other way. The angle
//! that matters is between the direction of travel `-wo` and `wi`: forward scattering keeps
//! `wi` near `-wo`.
//!
//! Both models are sampled exactly, so a sample's weight `p / pdf` is 1.

use crate::Frame;
use glam::{Vec2, Vec3A};
use std::f32::consts::PI;

/// A phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// The same in every direction: `1 / (4 pi)`.
    Isotropic,
    /// Henyey and Greenstein's lobe of mean cosine `g` in `(-1, 1)`: positive forward,
    /// negative backward, zero isotropic.
    HenyeyGreenstein { g: f32 },
}

/// A direction drawn from a phase function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSample {
    /// The sampled direction (unit, world), away from the scattering point.
    pub wi: Vec3A,
    /// The phase function's value for it.
    pub p: f32,
    /// Its density per unit solid angle.
    pub pdf: f32,
}

/// Largest `|g|` accepted: beyond it the lobe is a delta to float precision.
pub const MAX_G: f32 = 0.999;

impl Phase {
    /// Henyey-Greenstein with mean cosine `g`; an error outside `[-MAX_G, MAX_G]`.
    pub fn henyey_greenstein(g: f32) -> Result<Phase, String> {
        if g.is_nan() || g.abs() > MAX_G {
            return Err(format!(
                "the Henyey-Greenstein `g` must lie in [-{MAX_G}, {MAX_G}], not {g}"
            ));
        }
        Ok(if g == 0.0 {
            Phase::Isotropic
        } else {
            Phase::HenyeyGreenstein { g }
        })
    }

    /// The value for light scattered from `wi` towards `wo` (equal to the density with which
    /// [`Phase::sample`] draws `wi`).
    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        match *self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein { g } => henyey_greenstein(-wo.dot(wi), g),
        }
    }

    /// Draws `wi` for `wo` from two uniform numbers.
    #[inline]
    pub fn sample(&self, wo: Vec3A, u: Vec2) -> PhaseSample {
        let (cos, value) = match *self {
            Phase::Isotropic => (1.0 - 2.0 * u.x, 1.0 / (4.0 * PI)),
            Phase::HenyeyGreenstein { g } => {
                let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
                let cos = ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0);
                (cos, henyey_greenstein(cos, g))
            }
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let local = Vec3A::new(sin * phi.cos(), sin * phi.sin(), cos);
        let wi = Frame::from_normal(-wo).to_world(local).normalize();
        PhaseSample {
            wi,
            p: value,
            pdf: value,
        }
    }

    /// The mean cosine of the scattering angle.
    pub fn mean_cosine(&self) -> f32 {
        match *self {
            Phase::Isotropic => 0.0,
            Phase::HenyeyGreenstein { g } => g,
        }
    }
}

/// Henyey-Greenstein's density for the cosine `cos` between the direction of travel and the
/// scattered direction.
#[inline]
fn henyey_greenstein(cos: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{assert_chi2, Grid, SAMPLES};

    fn phases() -> Vec<(&'static str, Phase)> {
        vec![
            ("isotropic", Phase::Isotropic),
            ("hg_forward", Phase::HenyeyGreenstein { g: 0.7 }),
            ("hg_backward", Phase::HenyeyGreenstein { g: -0.4 }),
            ("hg_weak", Phase::HenyeyGreenstein { g: 0.05 }),
        ]
    }

    fn chi2_of(name: &str, phase: Phase) {
        let wo = Vec3A::new(0.3, -0.5, 0.8).normalize();
        assert_chi2(
            &format!("phase_{name}"),
            &Grid::sphere(20, 40),
            SAMPLES,
            7,
            |s| Some(phase.sample(wo, s.next_2d()).wi),
            |wi| phase.eval(wo, wi),
        );
    }

    #[test]
    fn chi2_phase_isotropic() {
        chi2_of("isotropic", Phase::Isotropic);
    }

    #[test]
    fn chi2_phase_henyey_greenstein_forward() {
        chi2_of("hg_forward", Phase::HenyeyGreenstein { g: 0.7 });
    }

    #[test]
    fn chi2_phase_henyey_greenstein_backward() {
        chi2_of("hg_backward", Phase::HenyeyGreenstein { g: -0.4 });
    }

    #[test]
    fn chi2_phase_henyey_greenstein_weak() {
        chi2_of("hg_weak", Phase::HenyeyGreenstein { g: 0.05 });
    }

    #[test]
    fn densities_integrate_to_one_and_samples_carry_weight_one() {
        let wo = Vec3A::new(-0.2, 0.9, 0.1).normalize();
        for (name, phase) in phases() {
            // Midpoint rule over the cosine of the scattering angle (the density depends on
            // it alone), 2 pi around.
            let n = 200_000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let cos = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
                    let sin = (1.0 - cos * cos).sqrt();
                    let frame = Frame::from_normal(-wo);
                    let wi = frame.to_world(Vec3A::new(sin as f32, 0.0, cos as f32));
                    phase.eval(wo, wi) as f64 * 2.0 / n as f64 * 2.0 * std::f64::consts::PI
                })
                .sum();
            assert!((integral - 1.0).abs() < 1e-3, "{name}: {integral}");
            let s = phase.sample(wo, Vec2::new(0.37, 0.81));
            assert!((s.p / s.pdf - 1.0).abs() < 1e-6 && (s.wi.length() - 1.0).abs() < 1e-5);
            assert!(
                (phase.eval(wo, s.wi) - s.pdf).abs() <= 1e-4 * s.pdf,
                "{name}"
            );
        }
    }

    #[test]
    fn positive_g_scatters_forward() {
        let phase = Phase::HenyeyGreenstein { g: 0.8 };
        let wo = Vec3A::Z;
        // Straight on (wi = -wo) is far likelier than straight back.
        assert!(phase.eval(wo, -Vec3A::Z) > 100.0 * phase.eval(wo, Vec3A::Z));
        let mean: f32 = (0..10_000)
            .map(|i| {
                let u = Vec2::new((i as f32 + 0.5) / 10_000.0, 0.3);
                -wo.dot(phase.sample(wo, u).wi)
            })
            .sum::<f32>()
            / 10_000.0;
        assert!((mean - 0.8).abs() < 0.01, "{mean}");
        assert!(Phase::henyey_greenstein(1.0).is_err());
        assert!(Phase::henyey_greenstein(f32::NAN).is_err());
    }
}
