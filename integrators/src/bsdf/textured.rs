//! Materials as a scene holds them: a BSDF whose parameters may vary over the surface
//! (textures), and an optional normal or bump map that tilts the shading normal.
//!
//! At each hit, [`material_at`] gives the BSDF there: the material itself when nothing
//! is textured (borrowed, no copy), else a copy with the textured parameters looked up at the
//! hit's `uv`. Derived constants stay those of the material made from the textures' means
//! (the coated materials' lobe-sampling weight, as Mitsuba 3 computes it), and a rough
//! plastic's roughness cannot be textured (its tables depend on it; Mitsuba's neither).
//!
//! The normal and bump maps follow Mitsuba 3's `normalmap` and `bumpmap`: a normal map holds
//! tangent-space normals `2 rgb - 1` in the frame of the shading normal and `dpdu`; a bump map
//! displaces the surface along its normal by `scale * h(u, v)`, and the shading normal is the
//! cross product of the displaced tangents `dpdu + n (scale dh/du)` and `dpdv + n (scale dh/dv)`,
//! turned to the geometric normal's side. With [`MapOptions`] as Mitsuba 3.7 sets them by
//! default, a tilted normal that faces away from the viewer has its tangential part negated
//! (`flip_invalid_normals`), and the BSDF carries the terms of [`super::mapped`]
//! (`use_shadowing_function`). The tilted frame's tangent is the unperturbed frame's, made
//! orthogonal to the new normal.

use super::mapped::{MapTerms, MappedBsdf};
use super::spectral::MaterialSpectra;
use super::Material;
use crate::spectrum::Wavelengths;
use crate::texture::{Texture, TextureLookup};
use crate::{Frame, Hit, Scene, Spectrum};
use glam::Vec3A;
use std::borrow::Cow;

/// The textures that replace a material's constant parameters, by the parameter's role.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialTextures {
    /// Diffuse reflectance: Lambert's and Oren-Nayar's `albedo`, Phong's `kd`, the plastics'
    /// `diffuse_reflectance`, diffuse transmission's `reflectance`.
    pub diffuse: Option<Texture>,
    /// Specular reflectance: Phong's `ks`, the conductors' and dielectrics' and plastics'
    /// `specular_reflectance`.
    pub specular: Option<Texture>,
    /// The dielectrics' `specular_transmittance`, diffuse transmission's `transmittance`.
    pub transmittance: Option<Texture>,
    /// The rough conductor's and rough dielectric's roughness.
    pub alpha: Option<RoughnessTextures>,
    /// The principled models' scalar parameters (their base colour is `diffuse`).
    pub principled: Option<Box<PrincipledTextures>>,
}

/// The principled models' textured scalars, by Mitsuba's names; each a texture's scalar
/// (its first channel).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PrincipledTextures {
    pub roughness: Option<Texture>,
    pub anisotropic: Option<Texture>,
    pub spec_trans: Option<Texture>,
    pub spec_tint: Option<Texture>,
    pub sheen: Option<Texture>,
    pub sheen_tint: Option<Texture>,
    pub flatness: Option<Texture>,
    pub metallic: Option<Texture>,
    pub clearcoat: Option<Texture>,
    pub clearcoat_gloss: Option<Texture>,
    pub diff_trans: Option<Texture>,
}

impl PrincipledTextures {
    /// True when some parameter is textured.
    pub fn any(&self) -> bool {
        self.slots().iter().any(|t| t.is_some())
    }

    fn slots(&self) -> [&Option<Texture>; 11] {
        [
            &self.roughness,
            &self.anisotropic,
            &self.spec_trans,
            &self.spec_tint,
            &self.sheen,
            &self.sheen_tint,
            &self.flatness,
            &self.metallic,
            &self.clearcoat,
            &self.clearcoat_gloss,
            &self.diff_trans,
        ]
    }

    /// The base layer's textured scalars looked up at `l`.
    fn apply(&self, b: &mut super::Burley, l: &TextureLookup) {
        let at = |t: &Option<Texture>, x: &mut f32| {
            if let Some(t) = t {
                *x = t.at_scalar(l);
            }
        };
        at(&self.roughness, &mut b.roughness);
        at(&self.anisotropic, &mut b.anisotropic);
        at(&self.spec_trans, &mut b.spec_trans);
        at(&self.spec_tint, &mut b.spec_tint);
        at(&self.sheen, &mut b.sheen);
        at(&self.sheen_tint, &mut b.sheen_tint);
        at(&self.flatness, &mut b.flatness);
    }
}

/// A textured microfacet roughness.
#[derive(Clone, Debug, PartialEq)]
pub enum RoughnessTextures {
    /// One texture for both tangents (`alpha`), looked up once.
    Isotropic(Texture),
    /// Along the tangent and the bitangent (`alpha_u`, `alpha_v`); a `None` keeps the
    /// material's constant.
    Anisotropic {
        u: Option<Texture>,
        v: Option<Texture>,
    },
}

impl RoughnessTextures {
    /// `mf` with its roughness looked up at `l`, kept within the microfacet range.
    #[inline]
    fn apply(&self, mf: &mut super::Microfacet, l: &TextureLookup) {
        let at = |t: &Texture| t.at_scalar(l).clamp(super::microfacet::MIN_ALPHA, 2.0);
        match self {
            RoughnessTextures::Isotropic(t) => {
                let a = at(t);
                (mf.alpha_u, mf.alpha_v) = (a, a);
            }
            RoughnessTextures::Anisotropic { u, v } => {
                mf.alpha_u = u.as_ref().map_or(mf.alpha_u, at);
                mf.alpha_v = v.as_ref().map_or(mf.alpha_v, at);
            }
        }
    }
}

impl MaterialTextures {
    /// True when some parameter is textured.
    pub fn any(&self) -> bool {
        self.diffuse.is_some()
            || self.specular.is_some()
            || self.transmittance.is_some()
            || self.alpha.is_some()
            || self.principled.as_ref().is_some_and(|p| p.any())
    }

    /// `m` with its textured parameters looked up at `l`.
    fn apply(&self, m: &mut Material, l: &TextureLookup) {
        let at = |t: &Option<Texture>, default: Spectrum| {
            t.as_ref()
                .map_or(default, |t| crate::spectrum::of_rgb(t.at(l)))
        };
        let roughness = |mf: &mut super::Microfacet| {
            if let Some(a) = &self.alpha {
                a.apply(mf, l);
            }
        };
        match m {
            Material::Lambert(l) => l.albedo = at(&self.diffuse, l.albedo),
            Material::DiffuseTransmission(d) => {
                d.reflectance = at(&self.diffuse, d.reflectance);
                d.transmittance = at(&self.transmittance, d.transmittance);
            }
            Material::OrenNayar(o) => o.albedo = at(&self.diffuse, o.albedo),
            Material::Phong(p) => {
                p.kd = at(&self.diffuse, p.kd);
                p.ks = at(&self.specular, p.ks);
            }
            Material::Conductor(c) => c.reflectance = at(&self.specular, c.reflectance),
            Material::RoughConductor(c) => {
                c.reflectance = at(&self.specular, c.reflectance);
                roughness(&mut c.microfacet);
            }
            Material::Dielectric(d) => {
                d.reflectance = at(&self.specular, d.reflectance);
                d.transmittance = at(&self.transmittance, d.transmittance);
            }
            Material::ThinDielectric(d) => {
                d.reflectance = at(&self.specular, d.reflectance);
                d.transmittance = at(&self.transmittance, d.transmittance);
            }
            Material::RoughDielectric(d) => {
                d.reflectance = at(&self.specular, d.reflectance);
                d.transmittance = at(&self.transmittance, d.transmittance);
                roughness(&mut d.microfacet);
            }
            Material::Plastic(p) => {
                p.diffuse = at(&self.diffuse, p.diffuse);
                p.specular = at(&self.specular, p.specular);
            }
            Material::RoughPlastic(p) => {
                p.diffuse = at(&self.diffuse, p.diffuse);
                p.specular = at(&self.specular, p.specular);
            }
            Material::Principled(p) => {
                p.burley.base_color = at(&self.diffuse, p.burley.base_color);
                if let Some(t) = &self.principled {
                    t.apply(&mut p.burley, l);
                    let scalar =
                        |t: &Option<Texture>, x: f32| t.as_ref().map_or(x, |t| t.at_scalar(l));
                    p.metallic = scalar(&t.metallic, p.metallic);
                    p.clearcoat = scalar(&t.clearcoat, p.clearcoat);
                    p.clearcoat_gloss = scalar(&t.clearcoat_gloss, p.clearcoat_gloss);
                }
            }
            Material::PrincipledThin(p) => {
                p.burley.base_color = at(&self.diffuse, p.burley.base_color);
                if let Some(t) = &self.principled {
                    t.apply(&mut p.burley, l);
                    p.diff_trans = t
                        .diff_trans
                        .as_ref()
                        .map_or(p.diff_trans, |t| t.at_scalar(l));
                }
            }
            // No texture slot maps onto a fibre's absorption or roughness; its offset across
            // the fibre is the hit's (pbrt-v4's curves: h = 2 v - 1).
            Material::Hair(h) => *h = h.clone().with_h(2.0 * l.uv.y - 1.0),
        }
    }
}

/// A change of the shading normal over the surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Perturbation {
    /// Tangent-space normals, `2 rgb - 1` (Mitsuba's `normalmap`).
    NormalMap(Texture),
    /// A height field `scale * h(u, v)` (its luminance) displacing the surface along its
    /// normal (Mitsuba's `bumpmap`).
    BumpMap { height: Texture, scale: f32 },
}

/// What a normal or bump map does beyond replacing the shading normal (Mitsuba 3.7's two
/// options, both on by default there and here; pbrt's maps have neither).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapOptions {
    /// A tilted normal facing away from the viewer has its tangential part negated.
    pub flip_invalid_normals: bool,
    /// The BSDF carries Estevez et al.'s microfacet shadowing term and refuses directions
    /// across the unperturbed shading normal.
    pub shadowing: bool,
}

impl Default for MapOptions {
    fn default() -> Self {
        MapOptions {
            flip_invalid_normals: true,
            shadowing: true,
        }
    }
}

/// A map's tilted normal at one hit, with what its terms need.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Tilt {
    /// The new shading normal (world).
    normal: Vec3A,
    /// The unperturbed frame's tangent, which orients the tilted frame.
    tangent: Vec3A,
    /// Estevez's `alpha^2 = min(tan^2(tilt) / 8, 1)`.
    alpha2: f32,
}

impl Perturbation {
    /// The tilted normal at `hit` seen from `towards_viewer` (world) under this map with
    /// `options`, or `None` where it is undefined (a zero normal, degenerate tangents) or
    /// would face away from the geometric normal: the hit then keeps its own.
    fn tilt(&self, hit: &Hit, towards_viewer: Vec3A, options: MapOptions) -> Option<Tilt> {
        let frame = hit.frame();
        let mut local = match self {
            Perturbation::NormalMap(t) => (t.eval(hit.uv) * 2.0 - Vec3A::ONE).normalize_or_zero(),
            Perturbation::BumpMap { height, scale } => {
                let g = height.gradient(hit.uv) * *scale;
                let n = hit.ns;
                // Without a parametrisation, the tangents of the normal's own frame, as
                // Mitsuba 3 gives triangles without texture coordinates.
                let (dpdu, dpdv) = if hit.dpdu == Vec3A::ZERO || hit.dpdv == Vec3A::ZERO {
                    let f = Frame::from_normal(n);
                    (f.s, f.t)
                } else {
                    (hit.dpdu, hit.dpdv)
                };
                let du = dpdu + n * (g.x - n.dot(dpdu));
                let dv = dpdv + n * (g.y - n.dot(dpdv));
                let m = du.cross(dv).normalize_or_zero();
                frame.to_local(if m.dot(hit.ng) < 0.0 { -m } else { m })
            }
        };
        if options.flip_invalid_normals {
            let wi = frame.to_local(towards_viewer);
            if wi.z * wi.dot(local) <= 0.0 {
                local = Vec3A::new(-local.x, -local.y, local.z);
            }
        }
        let normal = frame.to_world(local);
        if !(normal.is_finite() && local != Vec3A::ZERO && normal.dot(hit.ng) > 0.0) {
            return None;
        }
        let alpha2 = if options.shadowing {
            let c2 = local.z * local.z;
            (0.125 * (1.0 - c2).max(0.0) / c2).min(1.0)
        } else {
            0.0
        };
        Some(Tilt {
            normal,
            tangent: frame.s,
            alpha2,
        })
    }

    /// The shading normal at `hit` under this map without options (tests).
    #[cfg(test)]
    fn normal(&self, hit: &Hit) -> Option<Vec3A> {
        let off = MapOptions {
            flip_invalid_normals: false,
            shadowing: false,
        };
        self.tilt(hit, hit.ns, off).map(|t| t.normal)
    }
}

/// A material as the scene's material table holds it.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// The BSDF with every parameter constant (textured ones at their textures' means).
    bsdf: Material,
    /// Whether some parameter is textured or a map perturbs the normal: the one test every
    /// hit makes, kept beside the BSDF rather than read from the five textures' slots (which
    /// span several cache lines).
    varies: bool,
    /// Whether the BSDF itself changes per hit (a textured parameter, a hair's offset): a
    /// copy is made there; decided once here.
    own_copy: bool,
    textures: MaterialTextures,
    perturbation: Option<(Perturbation, MapOptions)>,
    /// A cut-out mask's opacity (Mitsuba's `mask`), if any.
    opacity: Option<Texture>,
    /// Seen from its front only (Mitsuba's opaque BSDFs): nothing from behind the shading
    /// normal.
    one_sided: bool,
    /// pbrt-v4's `alpha`, if any: where it is below 1 the surface is absent for a share of
    /// the rays (every ray, shadow rays too), which pass as if it were not there
    /// ([`crate::cutout`]).
    cutout: Option<Texture>,
    /// The parameters the scene gave by wavelength, for spectral mode.
    spectra: Option<Box<MaterialSpectra>>,
}

impl From<Material> for SurfaceMaterial {
    fn from(bsdf: Material) -> Self {
        SurfaceMaterial::new(bsdf, MaterialTextures::default(), None)
    }
}

impl SurfaceMaterial {
    pub fn new(
        bsdf: Material,
        textures: MaterialTextures,
        perturbation: Option<(Perturbation, MapOptions)>,
    ) -> SurfaceMaterial {
        let own_copy = textures.any() || bsdf.varies_per_hit();
        SurfaceMaterial {
            varies: own_copy || perturbation.is_some(),
            own_copy,
            bsdf,
            textures,
            perturbation,
            opacity: None,
            one_sided: false,
            cutout: None,
            spectra: None,
        }
    }

    /// The same material with the parameters `spectra` gives by wavelength (spectral mode
    /// evaluates them; RGB mode keeps the colours they were made into).
    pub fn with_spectra(self, spectra: MaterialSpectra) -> SurfaceMaterial {
        SurfaceMaterial {
            spectra: (!spectra.is_empty()).then(|| Box::new(spectra)),
            ..self
        }
    }

    /// Whether the material's index of refraction varies with wavelength.
    pub fn disperses(&self) -> bool {
        self.spectra.as_ref().is_some_and(|s| s.ior.is_some())
    }

    /// The BSDF with every parameter constant (textured ones at their textures' means): what
    /// does not vary over the surface, such as which lobes it has.
    #[inline]
    pub fn bsdf(&self) -> &Material {
        &self.bsdf
    }

    /// The normal or bump map, if any.
    pub fn perturbation(&self) -> Option<&Perturbation> {
        self.perturbation.as_ref().map(|(p, _)| p)
    }

    /// The same material under the normal or bump map `map`, used with `options`.
    pub fn with_perturbation(self, map: Perturbation, options: MapOptions) -> SurfaceMaterial {
        SurfaceMaterial {
            opacity: self.opacity.clone(),
            spectra: self.spectra.clone(),
            ..SurfaceMaterial::new(self.bsdf, self.textures, Some((map, options)))
        }
    }

    /// No surface: a medium's boundary that does not scatter, crossed by every ray (a mask
    /// of opacity 0 around a black material).
    pub fn null() -> SurfaceMaterial {
        SurfaceMaterial::from(Material::Lambert(crate::bsdf::Lambert {
            albedo: Spectrum::ZERO,
        }))
        .with_opacity(Texture::Constant(Vec3A::ZERO))
    }

    /// Whether any light may pass straight through it (a mask, a thin dielectric): what a
    /// shadow ray in media asks before it shades the surface, which it need not for the rest.
    #[inline]
    pub fn may_pass_straight(&self) -> bool {
        self.opacity.is_some() || matches!(self.bsdf, Material::ThinDielectric(_))
    }

    /// Whether it is no surface at all ([`SurfaceMaterial::null`]).
    pub fn is_null(&self) -> bool {
        matches!(&self.opacity, Some(Texture::Constant(c)) if *c == Vec3A::ZERO)
    }

    /// The same material cut out by a mask of `opacity` (its value, clamped to [0, 1]).
    pub fn with_opacity(self, opacity: Texture) -> SurfaceMaterial {
        SurfaceMaterial {
            varies: true,
            opacity: Some(opacity),
            ..self
        }
    }

    /// The cut-out mask's opacity, if any.
    pub fn opacity(&self) -> Option<&Texture> {
        self.opacity.as_ref()
    }

    /// Whether some texture of the material reads the hit mesh's attribute.
    pub fn reads_attribute(&self) -> bool {
        let t = &self.textures;
        let alpha = match &t.alpha {
            Some(RoughnessTextures::Isotropic(a)) => vec![a],
            Some(RoughnessTextures::Anisotropic { u, v }) => u.iter().chain(v.iter()).collect(),
            None => Vec::new(),
        };
        let principled = t.principled.as_ref().map_or(Vec::new(), |p| {
            p.slots().into_iter().flatten().collect::<Vec<_>>()
        });
        [
            &t.diffuse,
            &t.specular,
            &t.transmittance,
            &self.opacity,
            &self.cutout,
        ]
        .into_iter()
        .flatten()
        .chain(alpha)
        .chain(principled)
        .any(Texture::reads_attribute)
    }

    /// The material seen from its front only (see [`MappedBsdf::one_sided`]).
    pub fn with_one_sided(self) -> SurfaceMaterial {
        SurfaceMaterial {
            one_sided: true,
            ..self
        }
    }

    /// The material on a surface cut out by pbrt-v4's `alpha` (a texture's scalar).
    pub fn with_cutout(self, alpha: Texture) -> SurfaceMaterial {
        SurfaceMaterial {
            cutout: Some(alpha),
            ..self
        }
    }

    /// pbrt-v4's `alpha` of the surface, if it has one.
    #[inline]
    pub fn cutout(&self) -> Option<&Texture> {
        self.cutout.as_ref()
    }

    /// Whether the BSDF at some hit may have a Dirac lobe: the material's own, or a mask's
    /// null event (which [`MappedBsdf`] adds where the opacity is below 1).
    #[inline]
    pub fn may_have_delta_lobe(&self) -> bool {
        self.bsdf.has_delta_lobe() || self.opacity.is_some()
    }

    /// True when the material needs the hit's texture coordinates or tangents: it has
    /// textures, a normal or bump map, or an anisotropic roughness (which the tangents
    /// orient). The shading frame of the others may come from the normal alone.
    #[inline]
    pub fn needs_parametrisation(&self) -> bool {
        self.varies || self.bsdf.is_anisotropic()
    }

    /// The BSDF at `hit` (parametrised, if [`SurfaceMaterial::needs_parametrisation`]) seen
    /// from `towards_viewer` (world), whose shading normal the normal or bump map (if any)
    /// replaces, with the map's terms.
    #[inline(always)]
    pub(crate) fn at(
        &self,
        hit: &mut Hit,
        towards_viewer: Vec3A,
        lambda: &mut Wavelengths,
    ) -> MappedBsdf<'_> {
        if lambda.is_spectral() {
            return self.at_wavelengths(hit, towards_viewer, lambda);
        }
        self.at_rgb(hit, towards_viewer)
    }

    /// [`SurfaceMaterial::at`] in RGB mode.
    #[inline(always)]
    fn at_rgb(&self, hit: &mut Hit, towards_viewer: Vec3A) -> MappedBsdf<'_> {
        if !self.varies {
            return MappedBsdf {
                one_sided: self.one_sided,
                ..MappedBsdf::plain(Cow::Borrowed(&self.bsdf))
            };
        }
        self.at_varying(hit, towards_viewer)
    }

    /// [`SurfaceMaterial::at`] in spectral mode: the material (its textures looked up) with
    /// its colours made spectra at `lambda`.
    #[inline(never)]
    fn at_wavelengths(
        &self,
        hit: &mut Hit,
        towards_viewer: Vec3A,
        lambda: &mut Wavelengths,
    ) -> MappedBsdf<'_> {
        let mut at = self.at_rgb(hit, towards_viewer);
        at.material
            .to_mut()
            .at_wavelengths(lambda, self.spectra.as_deref());
        at
    }

    /// [`SurfaceMaterial::at`] for a material that varies over the surface.
    #[inline(never)]
    fn at_varying(&self, hit: &mut Hit, towards_viewer: Vec3A) -> MappedBsdf<'_> {
        let mut map = None;
        if let Some((p, options)) = &self.perturbation {
            if let Some(tilt) = p.tilt(hit, towards_viewer, *options) {
                let n0 = hit.ns;
                hit.ns = tilt.normal;
                hit.dpdu = tilt.tangent * hit.dpdu.length().max(1.0);
                if options.shadowing {
                    let frame = hit.frame();
                    map = Some(MapTerms::new(
                        frame.to_local(n0),
                        tilt.alpha2,
                        frame.to_local(towards_viewer),
                    ));
                }
            }
        }
        let lookup = TextureLookup::at(hit);
        let material = if self.own_copy {
            let mut m = self.bsdf.clone();
            self.textures.apply(&mut m, &lookup);
            Cow::Owned(m)
        } else {
            Cow::Borrowed(&self.bsdf)
        };
        let opacity = self
            .opacity
            .as_ref()
            .map_or(1.0, |t| t.at_scalar(&lookup).clamp(0.0, 1.0));
        MappedBsdf {
            material,
            map,
            opacity,
            one_sided: self.one_sided,
        }
    }
}

/// The BSDF of the surface at `hit` in `scene` seen from `towards_viewer` (world): its
/// material at the hit, parametrised first where the material needs it, with a normal or bump
/// map's terms; `hit`'s shading normal as the map makes it.
#[inline]
pub fn material_at<'s>(
    scene: &'s dyn Scene,
    hit: &mut Hit,
    towards_viewer: Vec3A,
    lambda: &mut Wavelengths,
) -> MappedBsdf<'s> {
    let surface = scene.material(hit.material);
    if surface.needs_parametrisation() {
        scene.parametrise(hit);
    }
    surface.at(hit, towards_viewer, lambda)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Lambert, Microfacet, RoughConductor};
    use crate::texture::{ImageTexture, TextureFilter, Wrap};
    use crate::Rgb;
    use crate::Spectrum;
    use glam::{Affine2, Vec2};
    use std::sync::Arc;

    fn hit_at(uv: Vec2) -> Hit {
        Hit {
            uv,
            dpdu: Vec3A::X,
            dpdv: Vec3A::Y,
            ..Hit::new(1.0, Vec3A::ZERO, Vec3A::Z, 0, None)
        }
    }

    fn checker() -> Texture {
        Texture::Checkerboard {
            color0: Rgb::splat(0.8),
            color1: Rgb::splat(0.1),
            to_uv: Affine2::IDENTITY,
        }
    }

    #[test]
    fn untextured_materials_are_borrowed_and_textured_ones_looked_up() {
        let plain = SurfaceMaterial::from(Material::Lambert(Lambert::new(Spectrum::ONE).unwrap()));
        assert!(matches!(
            plain
                .at(&mut hit_at(Vec2::ZERO), Vec3A::Z, &mut Wavelengths::Rgb)
                .material,
            Cow::Borrowed(_)
        ));
        let textured = SurfaceMaterial::new(
            plain.bsdf().clone(),
            MaterialTextures {
                diffuse: Some(checker()),
                ..Default::default()
            },
            None,
        );
        for (uv, expected) in [(Vec2::splat(0.25), 0.8), (Vec2::new(0.75, 0.25), 0.1)] {
            assert_eq!(
                textured
                    .at(&mut hit_at(uv), Vec3A::Z, &mut Wavelengths::Rgb)
                    .albedo(),
                Spectrum::splat(expected)
            );
        }
        // Roughness reads the texture's value, kept within the microfacet range.
        let rough = SurfaceMaterial::new(
            Material::RoughConductor(
                RoughConductor::new(
                    None,
                    Spectrum::ONE,
                    Microfacet::new(Default::default(), 0.3, 0.3).unwrap(),
                )
                .unwrap(),
            ),
            MaterialTextures {
                alpha: Some(RoughnessTextures::Anisotropic {
                    u: Some(Texture::Constant(Rgb::ZERO)),
                    v: Some(checker()),
                }),
                ..Default::default()
            },
            None,
        );
        let Material::RoughConductor(c) = &*rough.at(
            &mut hit_at(Vec2::splat(0.25)),
            Vec3A::Z,
            &mut Wavelengths::Rgb,
        ) else {
            panic!("a rough conductor")
        };
        assert_eq!(c.microfacet.alpha_u, crate::bsdf::microfacet::MIN_ALPHA);
        assert!((c.microfacet.alpha_v - 0.8).abs() < 1e-6);
    }

    /// A hair fibre is met at `h = 2 v - 1` across its width (pbrt-v4's curves): the material
    /// at a hit is the fibre with the hit's offset, however it was made.
    #[test]
    fn hair_takes_its_offset_from_each_hit() {
        let hair = SurfaceMaterial::from(Material::Hair(crate::bsdf::Hair::default()));
        assert!(hair.needs_parametrisation());
        for (v, h) in [(0.5, 0.0), (0.9, 0.8), (0.0, -1.0), (1.0, 1.0)] {
            let at = hair.at(
                &mut hit_at(Vec2::new(0.3, v)),
                Vec3A::Z,
                &mut Wavelengths::Rgb,
            );
            let Material::Hair(fibre) = &*at.material else {
                panic!("hair")
            };
            assert!((fibre.h() - h).abs() < 1e-6, "v {v}: h {}", fibre.h());
        }
    }

    #[test]
    fn normal_maps_tilt_the_normal_in_the_tangent_frame() {
        // rgb (1, 0.5, 0.5) -> tangent-space normal (1, 0, 0): along dpdu; halfway with z.
        let map = |c: Rgb| Perturbation::NormalMap(Texture::Constant(c));
        let hit = hit_at(Vec2::ZERO);
        let n = map(Rgb::new(1.0, 0.5, 1.0)).normal(&hit).unwrap();
        assert!(
            (n - Vec3A::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6,
            "{n}"
        );
        // Flat blue is the unperturbed normal; one below the surface is refused.
        let flat = map(Rgb::new(0.5, 0.5, 1.0)).normal(&hit).unwrap();
        assert!((flat - Vec3A::Z).length() < 1e-6);
        assert_eq!(map(Rgb::new(0.5, 0.5, 0.0)).normal(&hit), None);
    }

    #[test]
    fn bump_maps_tilt_the_normal_against_the_slope() {
        // Between the texel centres (u = 1/4 and 3/4) the height rises by 0.5: a slope of 1
        // per unit u, so the normal leans 45 degrees back towards -u.
        let texels = crate::texture::Texels::Float(vec![Rgb::ZERO, Rgb::splat(0.5)].into());
        let image = ImageTexture::new(2, 1, texels, TextureFilter::Bilinear, Wrap::Clamp).unwrap();
        let bump = Perturbation::BumpMap {
            height: Texture::Image {
                image: Arc::new(image),
                to_uv: Affine2::IDENTITY,
                scale: 1.0,
            },
            scale: 1.0,
        };
        let n = bump.normal(&hit_at(Vec2::new(0.5, 0.5))).unwrap();
        assert!(
            (n - Vec3A::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-5,
            "{n}"
        );
    }
}
