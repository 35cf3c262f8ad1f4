//! The shading point: what every integrator builds once per surface hit (the hit, its shading
//! frame, the direction back along the path, the material), and the two things done there:
//! scattering (one BSDF sample, in either transport mode) and connecting to a light sample
//! (the one direct-lighting routine every light-sampling integrator shares).

use super::{stays_on_viewer_side, Tracer};
use crate::bsdf::{BsdfSample, MappedBsdf, TransportMode};
use crate::light::LightSample;
use crate::spectrum::Wavelengths;
use crate::{Frame, Hit, Scene, Spectrum};
use glam::{Vec2, Vec3A};

/// A surface hit, ready to shade.
#[derive(Clone, Debug)]
pub struct ShadingPoint<'a> {
    /// The hit, with its shading normal as the material's normal or bump map makes it.
    pub hit: Hit,
    /// The shading frame (`z` = the shading normal).
    pub frame: Frame,
    /// Unit direction back along the arriving ray, in the shading frame.
    pub wo: Vec3A,
    /// The same direction in world space (exactly the negated ray direction).
    pub wo_world: Vec3A,
    /// The BSDF at the hit (its textures looked up there), with a normal or bump map's terms.
    pub material: MappedBsdf<'a>,
    /// The wavelengths the path carries here (what lights connected to it emit at).
    pub lambda: Wavelengths,
}

/// One BSDF sample at a shading point, in world space, with the factors a path's throughput
/// takes from it.
#[derive(Clone, Copy, Debug)]
pub struct Scatter {
    /// The sampled direction, world space.
    pub wi: Vec3A,
    pub bsdf: BsdfSample,
    /// `f |cos| / pdf` for the transport mode (`eta^2` times more on refraction for
    /// importance).
    pub weight: Spectrum,
    /// Veach's adjoint correction for shading normals (thesis, eq. 5.19) in importance mode:
    /// `|wo.ns| |wi.ng| / (|wo.ng| |wi.ns|)`; 1 for radiance.
    pub correction: f32,
}

impl Scatter {
    /// The throughput after this scattering event.
    #[inline]
    pub fn throughput(&self, beta: Spectrum) -> Spectrum {
        beta * self.weight * self.correction
    }
}

impl<'a> ShadingPoint<'a> {
    /// The shading point of `hit`, reached by a ray of direction `dir`, for a path carrying
    /// the wavelengths `lambda` (which a dispersive material leaves with only the hero).
    #[inline]
    pub fn new(
        hit: &Hit,
        dir: Vec3A,
        scene: &'a dyn Scene,
        lambda: &mut Wavelengths,
    ) -> ShadingPoint<'a> {
        let mut hit = *hit;
        let material = crate::bsdf::material_at(scene, &mut hit, -dir, lambda);
        let frame = hit.frame();
        ShadingPoint {
            hit,
            frame,
            wo: frame.to_local(-dir),
            wo_world: -dir,
            material,
            lambda: *lambda,
        }
    }

    /// Samples the BSDF (`u_lobe` picks a lobe, `u` places the direction) for a path carrying
    /// `mode`. `None` when the material returns no sample, the direction would cross an opaque
    /// surface (shading normals can put it on the viewer's side of the shading frame yet
    /// behind the geometry), or, for importance, the correction is undefined (grazing).
    #[inline]
    pub fn sample(&self, u_lobe: f32, u: Vec2, mode: TransportMode) -> Option<Scatter> {
        let bs = self.material.sample(self.wo, u_lobe, u)?;
        let wi = self.frame.to_world(bs.wi);
        if !stays_on_viewer_side(&self.material, self.hit.ng, self.wo_world, wi) {
            return None;
        }
        let correction = match mode {
            TransportMode::Radiance => 1.0,
            TransportMode::Importance => {
                let (wo, hit) = (self.wo_world, &self.hit);
                let denom = wo.dot(hit.ng).abs() * wi.dot(hit.ns).abs();
                if denom <= 0.0 {
                    return None;
                }
                wo.dot(hit.ns).abs() * wi.dot(hit.ng).abs() / denom
            }
        };
        Some(Scatter {
            wi,
            bsdf: bs,
            weight: self.material.sample_weight(self.wo, &bs, mode),
            correction,
        })
    }

    /// The BSDF factor of a connection leaving this point along `w` (unit, world), times
    /// `|cos|` against the shading normal: for `Radiance`, light arriving along `w` and leaving
    /// towards `wo`; for `Importance` (a light subpath's vertex), light arriving along `wo`
    /// and leaving along `w`, with Veach's shading-normal correction
    /// `|wo.ns| |w.ng| / (|wo.ng| |w.ns|)`. Zero across an opaque surface.
    #[inline]
    pub fn connection_factor(&self, w: Vec3A, mode: TransportMode) -> Spectrum {
        if !stays_on_viewer_side(&self.material, self.hit.ng, self.wo_world, w) {
            return Spectrum::ZERO;
        }
        let local = self.frame.to_local(w);
        let cos = local.z.abs();
        match mode {
            TransportMode::Radiance => self.material.eval(self.wo, local) * cos,
            TransportMode::Importance => {
                let (hit, wo) = (&self.hit, self.wo_world);
                let denom = wo.dot(hit.ng).abs() * w.dot(hit.ns).abs();
                if denom <= 0.0 {
                    return Spectrum::ZERO;
                }
                let correction = wo.dot(hit.ns).abs() * w.dot(hit.ng).abs() / denom;
                self.material.eval(local, self.wo) * (cos * correction)
            }
        }
    }

    /// Where a light is chosen for: the point and its geometric normal.
    #[inline]
    pub fn light_context(&self) -> crate::light::LightContext {
        crate::light::LightContext {
            p: self.hit.p,
            n: self.hit.ng,
        }
    }

    /// False when light `index` cannot light this point: it is the emitter the point lies on,
    /// and flat or convex (only a concave emitter, a sphere emitting inwards, lights itself).
    /// Skipped exactly rather than left to rounding, which would produce grazing samples of
    /// the emitter's own plane.
    #[inline]
    pub fn can_receive(&self, index: u32, lights: &crate::LightTable) -> bool {
        self.hit.light != Some(index) || lights.get(index).lights_itself()
    }

    /// Connects the shading point to one sample of light `index` (`u` places it): the sample,
    /// the BSDF value towards it and `|cos|` at the shading point. `None` when the connection
    /// carries nothing (the emitter the point lies on, no sample, black, across an opaque
    /// surface, a zero BSDF) or is blocked; the shadow ray is cast last, and counted.
    #[inline]
    pub fn connect_light(
        &self,
        index: u32,
        u: Vec2,
        tracer: &mut Tracer,
    ) -> Option<(LightSample, Spectrum, f32)> {
        self.connect_light_with(index, u, tracer, false)
            .map(|(ls, f, cos, _)| (ls, f, cos))
    }

    /// [`ShadingPoint::connect_light`], and with `bsdf_pdf` also the BSDF's density towards
    /// the sample, computed with its value ([`Material::eval_pdf`]: the half vector and
    /// microfacet density of a rough model once for both); 0 without.
    #[inline]
    pub fn connect_light_with(
        &self,
        index: u32,
        u: Vec2,
        tracer: &mut Tracer,
        bsdf_pdf: bool,
    ) -> Option<(LightSample, Spectrum, f32, f32)> {
        if !self.can_receive(index, tracer.scene.lights()) {
            return None;
        }
        let ls = tracer
            .scene
            .lights()
            .get(index)
            .sample_li(self.hit.p, u, &self.lambda)?;
        if ls.pdf <= 0.0 {
            return None;
        }
        let (f, cos, pdf) = self.reflect(&ls, bsdf_pdf)?;
        if !tracer.unoccluded(&self.hit, &ls) {
            return None;
        }
        Some((ls, f, cos, pdf))
    }

    /// What the point reflects towards the viewer of light arriving as `ls` says (before
    /// any shadow ray): the BSDF value, `|cos|` and, with `bsdf_pdf`, the BSDF's density
    /// towards it (0 without). `None` when nothing arrives or is reflected: black light, a
    /// direction across an opaque surface, a zero BSDF. The caller checks that the light can
    /// reach the point ([`ShadingPoint::can_receive`]).
    #[inline]
    pub fn reflect(&self, ls: &LightSample, bsdf_pdf: bool) -> Option<(Spectrum, f32, f32)> {
        if ls.radiance == Spectrum::ZERO
            || !stays_on_viewer_side(
                &self.material,
                self.hit.ng,
                self.frame.to_world(self.wo),
                ls.wi,
            )
        {
            return None;
        }
        let wi = self.frame.to_local(ls.wi);
        let (f, pdf) = if bsdf_pdf {
            self.material.eval_pdf(self.wo, wi)
        } else {
            (self.material.eval(self.wo, wi), 0.0)
        };
        (f != Spectrum::ZERO).then_some((f, wi.z.abs(), pdf))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Dielectric, Lambert};
    use crate::testing::furnace_sphere;
    use crate::Material;
    use std::borrow::Cow;

    fn hit(ns: Vec3A) -> Hit {
        Hit {
            ns,
            ..Hit::new(1.0, Vec3A::ZERO, Vec3A::Z, 0, None)
        }
    }

    #[test]
    fn refraction_reports_its_eta_and_importance_keeps_the_power_radiance_loses() {
        let scene = furnace_sphere(0.5, 1.0);
        let glass = Material::Dielectric(Dielectric::unchecked(1.5, Spectrum::ONE));
        let dir = Vec3A::new(0.3, 0.0, -1.0).normalize();
        let mut sp = ShadingPoint::new(&hit(Vec3A::Z), dir, &scene, &mut Wavelengths::Rgb);
        sp.material = MappedBsdf::plain(Cow::Borrowed(&glass));
        // u_lobe near 1 picks refraction (Fresnel reflectance is a few percent here).
        let r = sp
            .sample(0.999, Vec2::ZERO, TransportMode::Radiance)
            .unwrap();
        let i = sp
            .sample(0.999, Vec2::ZERO, TransportMode::Importance)
            .unwrap();
        assert!(r.wi.z < 0.0 && r.bsdf.eta == 1.5 && r.correction == 1.0);
        assert!((i.weight.x / r.weight.x - 2.25).abs() < 1e-5, "{i:?} {r:?}");
        // Reflection: eta 1, the same weight in both modes.
        let r = sp.sample(0.0, Vec2::ZERO, TransportMode::Radiance).unwrap();
        let i = sp
            .sample(0.0, Vec2::ZERO, TransportMode::Importance)
            .unwrap();
        assert!(r.bsdf.eta == 1.0 && r.weight == i.weight);
        // From inside, the relative IOR is the inverse.
        let mut inside = ShadingPoint::new(&hit(Vec3A::Z), -dir, &scene, &mut Wavelengths::Rgb);
        inside.material = MappedBsdf::plain(Cow::Borrowed(&glass));
        let t = inside
            .sample(0.999, Vec2::ZERO, TransportMode::Radiance)
            .unwrap();
        assert!((t.bsdf.eta - 1.0 / 1.5).abs() < 1e-6);
    }

    #[test]
    fn importance_carries_veachs_shading_normal_correction() {
        let scene = furnace_sphere(0.5, 1.0);
        let lambert = Material::Lambert(Lambert {
            albedo: Spectrum::splat(0.5),
        });
        let ns = Vec3A::new(0.3, 0.0, 1.0).normalize();
        let dir = Vec3A::new(-0.5, 0.2, -1.0).normalize();
        let mut sp = ShadingPoint::new(&hit(ns), dir, &scene, &mut Wavelengths::Rgb);
        sp.material = MappedBsdf::plain(Cow::Borrowed(&lambert));
        let u = Vec2::new(0.3, 0.7);
        let r = sp.sample(0.5, u, TransportMode::Radiance).unwrap();
        let i = sp.sample(0.5, u, TransportMode::Importance).unwrap();
        let (wo, wi, ng) = (-dir, i.wi, Vec3A::Z);
        let expected = wo.dot(ns).abs() * wi.dot(ng).abs() / (wo.dot(ng).abs() * wi.dot(ns).abs());
        assert_eq!(r.wi, i.wi);
        assert!((i.correction - expected).abs() < 1e-6 && (expected - 1.0).abs() > 0.01);
        assert_eq!(r.weight, i.weight);
        // Paths from the camera are unaffected: the throughput is beta times the weight.
        assert_eq!(r.throughput(Spectrum::ONE), r.weight);
    }
}
