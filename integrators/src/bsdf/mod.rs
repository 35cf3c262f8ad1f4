//! Materials (BSDFs): evaluation, importance sampling and densities.
//!
//! All functions work in the local shading frame (`z` = shading normal); see the crate docs for
//! the direction conventions. Opaque materials are two-sided: [`Material`] mirrors both
//! directions into the upper hemisphere before calling them, so each model only sees
//! `wo.z >= 0`. Transmissive models see the true side: for a dielectric `wo.z > 0` means the
//! ray arrives from outside; [`Hair`] works in the fibre's frame (`x` along the fibre).

pub mod checks;
mod conductor;
mod dielectric;
mod diffuse_transmission;
pub mod fresnel;
mod hair;
pub mod ior;
mod lambert;
pub mod mapped;
pub mod microfacet;
mod oren_nayar;
mod phong;
mod plastic;
pub mod principled;
mod rough_conductor;
mod rough_dielectric;
mod rough_plastic;
pub mod spectral;
mod textured;
mod thin_dielectric;
#[cfg(test)]
mod verification;

pub use conductor::{ComplexIor, Conductor};
pub use dielectric::{relative_ior, Dielectric};
pub use diffuse_transmission::DiffuseTransmission;
pub use fresnel::fresnel_dielectric;
pub use hair::Hair;
pub use lambert::Lambert;
pub use mapped::MappedBsdf;
pub use microfacet::{Distribution, Microfacet};
pub use oren_nayar::OrenNayar;
pub use phong::Phong;
pub use plastic::Plastic;
pub use principled::{Burley, Principled, PrincipledRates, PrincipledThin, ThinRates};
pub use rough_conductor::RoughConductor;
pub use rough_dielectric::RoughDielectric;
pub use rough_plastic::RoughPlastic;
pub use textured::{
    material_at, MapOptions, MaterialTextures, Perturbation, PrincipledTextures, RoughnessTextures,
    SurfaceMaterial,
};
pub use thin_dielectric::ThinDielectric;

use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// The result of sampling a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled incident direction, local frame.
    pub wi: Vec3A,
    /// BSDF value for `(wo, wi)`. For specular lobes this holds the delta's weight, so that
    /// `f * |cos(wi)| / pdf` is always the sample's throughput weight.
    pub f: Spectrum,
    /// Density per unit solid angle; for specular lobes, the discrete probability of the lobe.
    pub pdf: f32,
    /// True when the sampled lobe is a Dirac delta (mirror reflection or refraction).
    pub specular: bool,
    /// Relative index of refraction of the sampled lobe: the IOR of the side `wi` lies on over
    /// that of `wo`'s side for a refraction, 1 for reflection. A camera path's throughput
    /// carries `1 / eta^2` per refraction (radiance is compressed); Russian roulette undoes it.
    pub eta: f32,
}

/// What a path carries, which decides how refraction scales it (pbrt-v4's `TransportMode`):
/// radiance towards the camera is compressed by `1 / eta^2` on refraction; importance (power,
/// carried by photons and light paths) is not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

impl BsdfSample {
    /// A sample of a lobe that is not a delta, in reflection (`eta` 1).
    #[inline]
    pub fn reflection(wi: Vec3A, f: Spectrum, pdf: f32) -> BsdfSample {
        BsdfSample {
            wi,
            f,
            pdf,
            specular: false,
            eta: 1.0,
        }
    }

    /// A cosine-weighted direction of the upper hemisphere with BSDF value `f(wi)`: how
    /// diffuse lobes sample. `None` where the density vanishes (the horizon).
    #[inline]
    pub fn cosine_weighted(u: Vec2, f: impl FnOnce(Vec3A) -> Spectrum) -> Option<BsdfSample> {
        let wi = crate::sampling::cosine_hemisphere(u);
        let pdf = crate::sampling::cosine_hemisphere_pdf(wi.z);
        (pdf > 0.0).then(|| BsdfSample::reflection(wi, f(wi), pdf))
    }

    /// The glossy sample of direction `wi` that `bxdf` drew for `wo`, with the bxdf's own
    /// `eval` and `pdf` (so that sampling and MIS see one density); `None` where the density
    /// vanishes or is not finite.
    #[inline]
    pub fn evaluated<B: Bxdf + ?Sized>(bxdf: &B, wo: Vec3A, wi: Vec3A) -> Option<BsdfSample> {
        let (f, pdf) = bxdf.eval_pdf(wo, wi);
        (pdf > 0.0 && pdf.is_finite()).then(|| BsdfSample::reflection(wi, f, pdf))
    }

    /// Whether the sample goes straight on through the surface, undeviated (a null event: a
    /// mask's, a thin dielectric's transmission), for `wo` it was drawn for.
    #[inline]
    pub fn is_straight_through(&self, wo: Vec3A) -> bool {
        self.specular && self.wi == -wo
    }

    /// Throughput weight `f * |cos(wi)| / pdf`.
    #[inline]
    pub fn weight(&self) -> Spectrum {
        self.f * (self.wi.z.abs() / self.pdf)
    }
}

/// The kinds of lobe a model has, as Mitsuba 3's `BSDFFlags` and pbrt-v4's `BxDFFlags`:
/// delta, glossy or diffuse, each in reflection or transmission. Every model declares its own
/// ([`Bxdf::lobes`]); what an integrator asks of a material (is it specular, does it let
/// light through) is read from them, never guessed from which model it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lobes(u8);

impl Lobes {
    pub const DELTA_REFLECTION: Lobes = Lobes(1);
    pub const DELTA_TRANSMISSION: Lobes = Lobes(2);
    pub const GLOSSY_REFLECTION: Lobes = Lobes(4);
    pub const GLOSSY_TRANSMISSION: Lobes = Lobes(8);
    pub const DIFFUSE_REFLECTION: Lobes = Lobes(16);
    pub const DIFFUSE_TRANSMISSION: Lobes = Lobes(32);
    /// Every Dirac lobe.
    pub const DELTA: Lobes = Lobes(1 | 2);
    /// Every transmission lobe.
    pub const TRANSMISSION: Lobes = Lobes(2 | 8 | 32);

    /// Both sets of lobes.
    pub const fn with(self, other: Lobes) -> Lobes {
        Lobes(self.0 | other.0)
    }

    /// Whether any lobe of `other` is among these.
    pub const fn any(self, other: Lobes) -> bool {
        self.0 & other.0 != 0
    }

    /// Whether every one of these lobes is among `other` (and there is one).
    pub const fn only(self, other: Lobes) -> bool {
        self.0 != 0 && self.0 & !other.0 == 0
    }
}

/// One reflectance model. Implementations may assume `wo.z >= 0` unless they are transmissive.
pub trait Bxdf {
    /// The kinds of lobe the model has (required: a new model says what it is).
    fn lobes(&self) -> Lobes;
    /// `f(wo, wi)`, without the cosine factor. Zero for specular models.
    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum;
    /// Density with which [`Bxdf::sample`] returns `wi`, per unit solid angle. Zero for
    /// specular models.
    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32;
    /// `(eval, pdf)` at once, the same bits as the two calls: models whose value and density
    /// share work (the half vector, the microfacet density) compute it once (Mitsuba's
    /// `eval_pdf`).
    #[inline]
    fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Spectrum, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }
    /// Samples `wi` given `wo`; `u_lobe` picks between lobes, `u` places the direction.
    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample>;
    /// Directional-hemispherical reflectance at normal incidence, or the base colour: what the
    /// `albedo` debug view shows.
    fn albedo(&self) -> Spectrum;
}

/// A surface material. The closed set of models raylab supports.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    Lambert(Lambert),
    DiffuseTransmission(DiffuseTransmission),
    OrenNayar(OrenNayar),
    Phong(Phong),
    Dielectric(Dielectric),
    ThinDielectric(ThinDielectric),
    RoughDielectric(RoughDielectric),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    Plastic(Plastic),
    RoughPlastic(RoughPlastic),
    Principled(Principled),
    PrincipledThin(PrincipledThin),
    Hair(Hair),
}

macro_rules! dispatch {
    ($self:expr, $m:ident => $e:expr) => {
        match $self {
            Material::Lambert($m) => $e,
            Material::DiffuseTransmission($m) => $e,
            Material::OrenNayar($m) => $e,
            Material::Phong($m) => $e,
            Material::Dielectric($m) => $e,
            Material::ThinDielectric($m) => $e,
            Material::RoughDielectric($m) => $e,
            Material::Conductor($m) => $e,
            Material::RoughConductor($m) => $e,
            Material::Plastic($m) => $e,
            Material::RoughPlastic($m) => $e,
            Material::Principled($m) => $e,
            Material::PrincipledThin($m) => $e,
            Material::Hair($m) => $e,
        }
    };
}

/// Flips `v` into the upper hemisphere when `flip` is set.
#[inline]
fn mirror_z(v: Vec3A, flip: bool) -> Vec3A {
    if flip {
        Vec3A::new(v.x, v.y, -v.z)
    } else {
        v
    }
}

impl Material {
    /// True for the opaque models, which are two-sided: they see both sides of the surface
    /// alike.
    #[inline]
    fn two_sided_opaque(&self) -> bool {
        !self.is_transmissive()
    }

    /// What passes straight through from `wo`'s side, undeviated: a thin dielectric's
    /// transmission; nothing for every other model.
    #[inline]
    pub fn null_transmission(&self, wo: Vec3A) -> Spectrum {
        match self {
            Material::ThinDielectric(m) => m.transmittance * (1.0 - m.pane_reflectance(wo.z)),
            _ => Spectrum::ZERO,
        }
    }

    /// The kinds of lobe the material's model declares.
    #[inline]
    pub fn lobes(&self) -> Lobes {
        dispatch!(self, m => m.lobes())
    }

    /// True for materials that let light through (a transmission lobe: the dielectrics,
    /// diffuse transmission, hair): only they may send a path to the other side of the
    /// surface, and they see which side a ray arrives from.
    #[inline]
    pub fn is_transmissive(&self) -> bool {
        self.lobes().any(Lobes::TRANSMISSION)
    }

    /// True when every lobe is a Dirac delta (no direct lighting possible).
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.lobes().only(Lobes::DELTA)
    }

    /// True when some lobe is a Dirac delta: the specular materials, and smooth plastic's
    /// coating over its diffuse base. Whitted-style tracers follow these lobes recursively.
    #[inline]
    pub fn has_delta_lobe(&self) -> bool {
        self.lobes().any(Lobes::DELTA)
    }

    /// Probability that [`Material::sample`] at `wo` picks a Dirac lobe, and does so exactly
    /// when its `u_lobe` is below it: 1 for the specular materials, the coating's share for
    /// smooth plastic, 0 for the rest. Photon gathers use it to split a mixed surface into its
    /// delta lobes (followed) and the rest (gathered).
    #[inline]
    pub fn delta_probability(&self, wo: Vec3A) -> f32 {
        match self {
            Material::Plastic(p) => p.coating_probability(wo.z.abs()),
            m if m.is_specular() => 1.0,
            _ => 0.0,
        }
    }

    /// `f(wo, wi)` in the local frame, without the cosine.
    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        let Some((wo, wi)) = self.oriented(wo, wi) else {
            return Spectrum::ZERO;
        };
        dispatch!(self, m => m.eval(wo, wi))
    }

    /// `(eval, pdf)` at once, the same bits as [`Material::eval`] and [`Material::pdf`].
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Spectrum, f32) {
        let Some((wo, wi)) = self.oriented(wo, wi) else {
            return (Spectrum::ZERO, 0.0);
        };
        dispatch!(self, m => m.eval_pdf(wo, wi))
    }

    /// Density of [`Material::sample`] returning `wi`, per unit solid angle.
    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let Some((wo, wi)) = self.oriented(wo, wi) else {
            return 0.0;
        };
        dispatch!(self, m => m.pdf(wo, wi))
    }

    /// `wo` and `wi` as the model sees them: for a two-sided opaque material both mirrored
    /// into the upper hemisphere when `wo` is below it, and `None` (nothing passes) when they
    /// lie on opposite sides; for the others as they are.
    #[inline]
    fn oriented(&self, wo: Vec3A, wi: Vec3A) -> Option<(Vec3A, Vec3A)> {
        if !self.two_sided_opaque() {
            return Some((wo, wi));
        }
        if wo.z * wi.z <= 0.0 {
            return None;
        }
        let flip = wo.z < 0.0;
        Some((mirror_z(wo, flip), mirror_z(wi, flip)))
    }

    /// Importance-samples an incident direction.
    #[inline]
    pub fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if self.two_sided_opaque() {
            let flip = wo.z < 0.0;
            let mut s = dispatch!(self, m => m.sample(mirror_z(wo, flip), u_lobe, u))?;
            s.wi = mirror_z(s.wi, flip);
            Some(s)
        } else {
            dispatch!(self, m => m.sample(wo, u_lobe, u))
        }
    }

    /// Throughput weight of sample `s` (drawn with [`Material::sample`] at `wo`) in transport
    /// mode `mode`. The BSDFs are symmetric except for refraction, which compresses radiance
    /// by `1/eta^2` but conserves power, so for importance the weight of a refraction is
    /// `eta^2` times the radiance weight.
    #[inline]
    pub fn sample_weight(&self, wo: Vec3A, s: &BsdfSample, mode: TransportMode) -> Spectrum {
        match mode {
            TransportMode::Importance if wo.z * s.wi.z < 0.0 => s.weight() * (s.eta * s.eta),
            _ => s.weight(),
        }
    }

    /// True when the lobes turn with the shading frame's tangent: a roughness that differs
    /// along the two tangents, or hair (whose frame's `x` is the fibre).
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        match self {
            Material::RoughConductor(m) => m.microfacet.alpha_u != m.microfacet.alpha_v,
            Material::RoughDielectric(m) => m.microfacet.alpha_u != m.microfacet.alpha_v,
            Material::Principled(m) => m.burley.anisotropic != 0.0,
            Material::PrincipledThin(m) => m.burley.anisotropic != 0.0,
            Material::Hair(_) => true,
            _ => false,
        }
    }

    /// True when the model depends on where on the surface it is hit beyond its textures:
    /// hair, whose offset across the fibre is the hit's (`h = 2 v - 1`).
    #[inline]
    pub fn varies_per_hit(&self) -> bool {
        matches!(self, Material::Hair(_))
    }

    /// Base colour, for the `albedo` debug view.
    #[inline]
    pub fn albedo(&self) -> Spectrum {
        dispatch!(self, m => m.albedo())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::dir;
    use crate::Sampler;

    #[test]
    fn opaque_materials_are_two_sided_and_consistent_below_the_surface() {
        let materials = [
            Material::Lambert(Lambert {
                albedo: Spectrum::splat(0.5),
            }),
            Material::OrenNayar(OrenNayar::new(Spectrum::splat(0.5), 30.0)),
            Material::Phong(Phong {
                kd: Spectrum::splat(0.3),
                ks: Spectrum::splat(0.6),
                exponent: 20.0,
            }),
        ];
        let mut s = Sampler::new(601, 0, 0);
        for m in &materials {
            for wo in [
                dir(30.0, 40.0),
                -dir(30.0, 40.0),
                Vec3A::new(0.5, 0.1, -0.3).normalize(),
            ] {
                for _ in 0..2000 {
                    let Some(b) = m.sample(wo, s.next_1d(), s.next_2d()) else {
                        continue;
                    };
                    assert!(b.wi.z * wo.z > 0.0, "reflection stays on wo's side");
                    let (f, pdf) = (m.eval(wo, b.wi), m.pdf(wo, b.wi));
                    assert!(
                        (pdf - b.pdf).abs() <= 1e-4 * pdf,
                        "{m:?}: {pdf} vs {}",
                        b.pdf
                    );
                    assert!(
                        (f - b.f).abs().max_element() <= 1e-4 * f.max_element(),
                        "{m:?}"
                    );
                    // Mirroring both directions gives the same values.
                    let flip = |v: Vec3A| Vec3A::new(v.x, v.y, -v.z);
                    assert!((m.eval(flip(wo), flip(b.wi)) - f).abs().max_element() <= 1e-6);
                }
                assert_eq!(
                    m.eval(wo, Vec3A::new(0.0, 0.0, -wo.z.signum())),
                    Spectrum::ZERO
                );
                assert_eq!(m.pdf(wo, Vec3A::new(0.0, 0.0, -wo.z.signum())), 0.0);
            }
        }
    }

    #[test]
    fn glass_sees_the_true_side() {
        let m = Material::Dielectric(Dielectric::unchecked(1.5, Spectrum::ONE));
        assert!(m.is_specular());
        // From inside past the critical angle: total internal reflection, staying inside.
        let b = m
            .sample(Vec3A::new(0.9, 0.0, -0.435_889_9), 0.99, Vec2::ZERO)
            .expect("reflects");
        assert!(b.wi.z < 0.0 && b.pdf == 1.0);
        // From outside, refraction goes below.
        let b = m.sample(Vec3A::Z, 0.99, Vec2::ZERO).expect("refracts");
        assert!(b.wi.z < 0.0 && (b.wi + Vec3A::Z).length() < 1e-6);
    }

    #[test]
    fn photons_through_glass_keep_their_power() {
        // Lossless glass conserves power: the mean importance weight over both lobes is 1 from
        // either side, while radiance weights carry 1/eta^2 on refraction.
        let glass = Material::Dielectric(Dielectric::unchecked(1.5, Spectrum::ONE));
        let mut s = Sampler::new(77, 0, 0);
        for wo in [dir(30.0, 20.0), dir(150.0, 20.0)] {
            let n = 200_000;
            let (mut importance, mut radiance) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let b = glass.sample(wo, s.next_1d(), s.next_2d()).expect("a lobe");
                importance += glass.sample_weight(wo, &b, TransportMode::Importance).x as f64;
                radiance += b.weight().x as f64;
            }
            let (importance, radiance) = (importance / n as f64, radiance / n as f64);
            assert!((importance - 1.0).abs() < 1e-3, "{importance}");
            assert!((radiance - 1.0).abs() > 0.1, "{radiance}");
        }
    }
}
