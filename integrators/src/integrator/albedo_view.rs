//! `albedo`: debug view of the material's base colour at the first hit (emitters show their
//! radiance). Not radiance: for checking materials and the build step.

use crate::integrator::{emitted_at, RayIntegrator, Tracer};
use crate::registry::{IntegratorEntry, MediaSupport, Params, SpectralSupport};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Ray, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "albedo",
    summary: "debug view: material base colour at the first hit, emitters in their radiance",
    params: &[],
    build: |_: &Params| Box::new(AlbedoView),
    analytic: None,
    media: MediaSupport::None,
    spectral: SpectralSupport::Spectrum,
};

struct AlbedoView;

impl RayIntegrator for AlbedoView {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        _sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // A view of the scene, not light: RGB in either mode.
        *lambda = Wavelengths::Rgb;
        let Some(mut hit) = tracer.camera(ray) else {
            return Spectrum::ZERO;
        };
        if hit.light.is_some() {
            return emitted_at(tracer.scene, &hit, ray, lambda);
        }
        crate::bsdf::material_at(tracer.scene, &mut hit, -ray.dir, lambda).albedo()
    }
}
