//! `bpm`: bidirectional photon mapping (Vorba 2011; Georgiev et al. 2012's merging-only
//! estimator, SmallVCM's `bpm`), on the engine of [`vcm`](super::vcm).
//!
//! **Estimates** the measurement equation by vertex merging alone. Each pass traces one
//! light subpath per pixel and keeps its non-specular vertices in a hashed grid; every
//! camera sample's subpath merges, at each of its non-specular vertices, with every light
//! vertex within the pass's radius (a photon density estimate with the light subpath's
//! power). The merges of one path at its different vertices are weighed against each other
//! by the power heuristic (the merging half of `vcm`'s weights), so each path is estimated
//! at the vertex where its density estimate is best: where the camera subpath is unlikely
//! to have reached by itself, merges near the lights; otherwise near the camera. Emission is
//! counted only when seen directly or through specular bounces alone (nothing merges those);
//! there are no light samples and no connections, so direct light comes from merges too.
//!
//! In participating media the subpaths walk media and merge at medium vertices too, with
//! photon points in a kernel of `4/3 pi r^3` (see [`vcm`](super::vcm)), of `volume-radius`,
//! by default five times the surfaces' first radius: at SmallVCM's small radius few light
//! vertices fall within a camera vertex's ball in a thin fog, and merges are fireflies.
//!
//! The radius shrinks as SmallVCM's: `r_i = r_0 / (i + 1)^((1 - alpha) / 2)` in pass `i`.
//!
//! **Parameters**: `max-depth` (scattering events, default unlimited), `rr-depth` (default
//! 3), `radius` (first merging radius in scene units; 0 = 0.3% of the scene's bounding
//! radius), `volume-radius` (in media; 0 = 5 times `radius`), `alpha` (default 0.75).
//! **Bias**: every contribution but directly seen emission is a density estimate, blurred by
//! the radius `r_i` of its pass; the blur vanishes as passes accumulate (consistent, not
//! unbiased). Truncation with a finite `max-depth`.

use super::vcm::{VertexMerging, PARAMS};
use crate::registry::{expect, Analytic, IntegratorEntry, MediaSupport, Params, SpectralSupport};

pub const ENTRY: IntegratorEntry = IntegratorEntry {
    name: "bpm",
    summary: "bidirectional photon mapping: light subpaths merged at every camera vertex, MIS between the merges, shrinking radius (SmallVCM)",
    params: PARAMS,
    build: |p: &Params| Box::new(VertexMerging::new(p, false)),
    // The analytic scenes' radiance is uniform where merges happen: a wide radius costs no
    // bias there.
    analytic: Some(Analytic {
        params: &[("radius", "0.05")],
        furnace: expect(2.0, 40, 900),
        point_in_sphere: expect(1.0, 40, 900),
        sphere_under_sky: expect(1.2, 40, 3600),
    }),
    media: MediaSupport::Scattering,
    spectral: SpectralSupport::PerPass,
};
