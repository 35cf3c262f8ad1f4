//! What an integrator needs from a scene, and nothing more.

use crate::{Hit, LightTable, Medium, MediumId, Ray, SurfaceMaterial};
use glam::Vec3A;

/// A renderable scene as light transport sees it. The engine implements this for its
/// flattened, BVH-backed scene; tests implement it for tiny analytic scenes.
pub trait Scene: Sync {
    /// The closest surface hit by `ray` with `t < ray.tmax`.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// True if any surface lies on `ray` with `t < ray.tmax`.
    fn occluded(&self, ray: &Ray) -> bool;
    /// [`Scene::intersect`] of every ray of `rays`, into `hits` (of the same length): a batch
    /// of incoherent rays, such as a bounce's. A scene may trace them together (interleaved,
    /// so that one ray's memory loads overlap another's work); the answers are the same.
    fn intersect_all(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = self.intersect(ray);
        }
    }
    /// [`Scene::occluded`] of every ray of `rays`, into `blocked` (of the same length), as
    /// [`Scene::intersect_all`] traces its batch.
    fn occluded_all(&self, rays: &[Ray], blocked: &mut [bool]) {
        for (ray, b) in rays.iter().zip(blocked) {
            *b = self.occluded(ray);
        }
    }
    /// Material `id` of the scene's material table.
    fn material(&self, id: u32) -> &SurfaceMaterial;
    /// Every emitter, with the distribution used to pick one.
    fn lights(&self) -> &LightTable;
    /// Axis-aligned bounds of the geometry (min, max).
    fn bounds(&self) -> (Vec3A, Vec3A);
    /// The scene's participating media, which [`MediumId`]s index. Hits report the media on
    /// either side of their surface ([`Hit::media`]): for a surface that bounds none, the
    /// medium of the ray that found it on both sides.
    fn media(&self) -> &[Medium] {
        &[]
    }
    /// The medium the camera sits in.
    fn camera_medium(&self) -> MediumId {
        MediumId::VACUUM
    }
    /// Whether any ray may travel through a medium.
    fn has_media(&self) -> bool {
        !self.media().is_empty()
    }
    /// The medium `id` (none for vacuum).
    #[inline]
    fn medium(&self, id: MediumId) -> Option<&Medium> {
        self.media().get(id.0 as usize)
    }
    /// Whether some material's index of refraction varies with wavelength (dispersion): in
    /// spectral mode, the integrators that carry one set of wavelengths through a whole pass
    /// then carry only its hero.
    fn disperses(&self) -> bool {
        false
    }
    /// Computes `hit`'s texture coordinates and tangents if they are pending (see
    /// [`crate::geometry::Pending`]). Scenes of spheres alone need not override it.
    fn parametrise(&self, hit: &mut Hit) {
        hit.parametrise_sphere();
    }
}
