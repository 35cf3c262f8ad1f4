//! A material at a sample's wavelengths: every colour it holds made the spectrum it stands
//! for there (reflectances and tints bounded, a conductor's complex IOR and a fibre's
//! absorption unbounded; [`crate::spectrum`]), or the spectrum the scene gave by wavelength
//! ([`MaterialSpectra`]). A dielectric whose index of refraction varies with wavelength takes
//! the hero's, and only the hero goes on. In RGB mode materials are used as they are.

use super::Material;
use crate::spectrum::curve::Curve;
use crate::spectrum::rgb_of;
use crate::spectrum::Wavelengths;
use crate::Spectrum;

/// A material's parameters the scene gave by wavelength, by role (as
/// [`super::MaterialTextures`]'s): in spectral mode they are these spectra; in RGB mode the
/// colours they were made into.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialSpectra {
    /// The diffuse reflectance (Lambert's albedo, a plastic's base, a principled base colour).
    pub diffuse: Option<Curve>,
    /// The specular reflectance (a conductor's or dielectric's tint, Phong's `ks`).
    pub specular: Option<Curve>,
    /// The dielectrics' specular transmittance, diffuse transmission's transmittance.
    pub transmittance: Option<Curve>,
    /// A conductor's complex index of refraction, `eta + i k`.
    pub eta: Option<Curve>,
    pub k: Option<Curve>,
    /// A dielectric's index of refraction inside by wavelength, over the one outside
    /// (`ext`): dispersion.
    pub ior: Option<(Curve, f32)>,
}

impl MaterialSpectra {
    /// True when nothing is given by wavelength.
    pub fn is_empty(&self) -> bool {
        *self == MaterialSpectra::default()
    }
}

impl Material {
    /// Makes this material's colours its spectra at `lambda` (spectral mode only), those in
    /// `given` as given; a dispersive dielectric leaves only the hero wavelength going on.
    pub fn at_wavelengths(&mut self, lambda: &mut Wavelengths, given: Option<&MaterialSpectra>) {
        self.colours_at(lambda);
        if let Some(given) = given {
            self.given_at(lambda, given);
        }
    }

    /// The parameters `given` by wavelength, at `lambda`.
    fn given_at(&mut self, lambda: &mut Wavelengths, given: &MaterialSpectra) {
        let at = |field: &mut Spectrum, curve: &Option<Curve>| {
            if let Some(c) = curve {
                *field = lambda.map(rgb_of(*field), |nm| c.at(nm));
            }
        };
        let (d, s, t) = (&given.diffuse, &given.specular, &given.transmittance);
        let mut ior = None;
        match self {
            Material::Lambert(m) => at(&mut m.albedo, d),
            Material::OrenNayar(m) => at(&mut m.albedo, d),
            Material::DiffuseTransmission(m) => {
                at(&mut m.reflectance, d);
                at(&mut m.transmittance, t);
            }
            Material::Phong(m) => {
                at(&mut m.kd, d);
                at(&mut m.ks, s);
            }
            Material::Dielectric(m) => {
                at(&mut m.reflectance, s);
                at(&mut m.transmittance, t);
                ior = Some(&mut m.ior);
            }
            Material::ThinDielectric(m) => {
                at(&mut m.reflectance, s);
                at(&mut m.transmittance, t);
                ior = Some(&mut m.ior);
            }
            Material::RoughDielectric(m) => {
                at(&mut m.reflectance, s);
                at(&mut m.transmittance, t);
                ior = Some(&mut m.ior);
            }
            Material::Conductor(m) => {
                at(&mut m.reflectance, s);
                if let Some(c) = &mut m.ior {
                    at(&mut c.eta, &given.eta);
                    at(&mut c.k, &given.k);
                }
            }
            Material::RoughConductor(m) => {
                at(&mut m.reflectance, s);
                if let Some(c) = &mut m.ior {
                    at(&mut c.eta, &given.eta);
                    at(&mut c.k, &given.k);
                }
            }
            Material::Plastic(m) => {
                at(&mut m.diffuse, d);
                at(&mut m.specular, s);
            }
            Material::RoughPlastic(m) => {
                at(&mut m.diffuse, d);
                at(&mut m.specular, s);
            }
            Material::Principled(m) => at(&mut m.burley.base_color, d),
            Material::PrincipledThin(m) => at(&mut m.burley.base_color, d),
            Material::Hair(_) => {}
        }
        if let (Some(ior), Some((curve, ext)), Some(hero)) = (ior, &given.ior, lambda.hero()) {
            let eta = curve.at(hero) / ext;
            if eta.is_finite() && eta > 0.0 {
                *ior = eta;
            }
            lambda.terminate_secondary();
        }
    }

    /// Every colour of the material as the spectrum it stands for at `lambda`.
    fn colours_at(&mut self, lambda: &Wavelengths) {
        let reflectance = |c: &mut Spectrum| *c = lambda.reflectance(rgb_of(*c));
        let unbounded = |c: &mut Spectrum| *c = lambda.unbounded(rgb_of(*c));
        match self {
            Material::Lambert(m) => reflectance(&mut m.albedo),
            Material::OrenNayar(m) => reflectance(&mut m.albedo),
            Material::DiffuseTransmission(m) => {
                reflectance(&mut m.reflectance);
                reflectance(&mut m.transmittance);
            }
            Material::Phong(m) => {
                reflectance(&mut m.kd);
                reflectance(&mut m.ks);
            }
            Material::Dielectric(m) => {
                reflectance(&mut m.reflectance);
                reflectance(&mut m.transmittance);
            }
            Material::ThinDielectric(m) => {
                reflectance(&mut m.reflectance);
                reflectance(&mut m.transmittance);
            }
            Material::RoughDielectric(m) => {
                reflectance(&mut m.reflectance);
                reflectance(&mut m.transmittance);
            }
            Material::Conductor(m) => {
                reflectance(&mut m.reflectance);
                if let Some(ior) = &mut m.ior {
                    unbounded(&mut ior.eta);
                    unbounded(&mut ior.k);
                }
            }
            Material::RoughConductor(m) => {
                reflectance(&mut m.reflectance);
                if let Some(ior) = &mut m.ior {
                    unbounded(&mut ior.eta);
                    unbounded(&mut ior.k);
                }
            }
            Material::Plastic(m) => {
                reflectance(&mut m.diffuse);
                reflectance(&mut m.specular);
            }
            Material::RoughPlastic(m) => {
                reflectance(&mut m.diffuse);
                reflectance(&mut m.specular);
            }
            Material::Principled(m) => reflectance(&mut m.burley.base_color),
            Material::PrincipledThin(m) => reflectance(&mut m.burley.base_color),
            Material::Hair(m) => m.map_sigma_a(|c| lambda.unbounded(rgb_of(c))),
        }
    }
}
