//! A perfect specular mirror: `wi` is `wo` reflected about the normal, weighted by `tint`.

use super::{BsdfSample, Bxdf};
use crate::Rgb;
use glam::{Vec2, Vec3A};

#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    pub tint: Rgb,
}

impl Mirror {
    /// A perfect mirror tinted by `tint` (each channel in `[0, 1]`).
    pub fn new(tint: Rgb) -> Result<Mirror, String> {
        Ok(Mirror {
            tint: super::checks::reflectance("tint", tint)?,
        })
    }
}

impl Bxdf for Mirror {
    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Rgb {
        Rgb::ZERO
    }

    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3A, _u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        let wi = Vec3A::new(-wo.x, -wo.y, wo.z);
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.tint / wi.z,
            pdf: 1.0,
            specular: true,
            eta: 1.0,
        })
    }

    fn albedo(&self) -> Rgb {
        self.tint
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::dir;

    #[test]
    fn reflects_about_the_normal_with_weight_tint() {
        let m = Mirror {
            tint: Rgb::new(0.9, 0.8, 0.7),
        };
        let wo = dir(40.0, 75.0);
        let s = m.sample(wo, 0.3, Vec2::new(0.1, 0.9)).expect("reflects");
        assert!(s.specular && s.pdf == 1.0);
        assert!((s.wi - Vec3A::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
        assert!((s.weight() - m.tint).abs().max_element() < 1e-6);
        assert_eq!(m.eval(wo, s.wi), Rgb::ZERO);
        assert_eq!(m.pdf(wo, s.wi), 0.0);
        assert!(
            m.sample(Vec3A::X, 0.5, Vec2::splat(0.5)).is_none(),
            "grazing wo has no reflection"
        );
    }
}
