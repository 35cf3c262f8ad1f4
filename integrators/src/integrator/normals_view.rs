//! `normals`: debug view of the shading normal at the first hit, mapped from [-1, 1] to
//! [0, 1] per axis. Not radiance: for checking geometry and the build step.

use crate::integrator::{RayIntegrator, Tracer};
use crate::registry::{IntegratorEntry, MediaSupport, Params, SpectralSupport};
use crate::spectrum::Wavelengths;
use crate::Spectrum;
use crate::{Ray, Sampler};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "normals",
    summary: "debug view: shading normal at the first hit as colour (n * 0.5 + 0.5)",
    params: &[],
    build: |_: &Params| Box::new(NormalsView),
    analytic: None,
    media: MediaSupport::None,
    spectral: SpectralSupport::Spectrum,
};

struct NormalsView;

impl RayIntegrator for NormalsView {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        _sampler: &mut Sampler,
        lambda: &mut Wavelengths,
    ) -> Spectrum {
        // A view of the scene, not light: RGB in either mode.
        *lambda = Wavelengths::Rgb;
        match tracer.camera(ray) {
            Some(hit) => crate::spectrum::of_rgb(hit.ns * 0.5 + 0.5),
            None => Spectrum::ZERO,
        }
    }
}
