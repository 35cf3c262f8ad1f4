//! Participating media as scene files describe them: the `media` table, what an entity's
//! surface bounds (`medium: (inside: ..., outside: ...)`) and where the camera sits
//! (`camera_medium`). Every importer builds these types.

use super::transform_desc::TransformDesc;
use serde::{Deserialize, Serialize};

/// A 3-vector as written in RON: `(x, y, z)` (the schema's `V3`).
type V3 = [f32; 3];

/// A participating medium. Coefficients are per unit length of the scene.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
// A scene has a few media: the fields matched by name read better than a box would.
#[allow(clippy::large_enum_variant)]
pub enum MediumDesc {
    /// The same everywhere: extinction `sigma_t` (times `scale`) and single-scattering
    /// albedo `albedo` in `[0, 1]` (scattering `albedo sigma_t`, absorption the rest).
    Homogeneous {
        sigma_t: V3,
        albedo: V3,
        /// Default: 1.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        scale: f32,
        /// Default: `Isotropic`.
        #[serde(default, skip_serializing_if = "PhaseDesc::is_isotropic")]
        phase: PhaseDesc,
        /// Radiance the medium emits (it adds `sigma_a * emission` per unit length, as
        /// pbrt-v4's `Le`). Default: none.
        #[serde(default, skip_serializing_if = "is_zero")]
        emission: V3,
    },
    /// Coefficients that vary over space (Mitsuba 3's `heterogeneous`, pbrt-v4's
    /// `uniformgrid` and `rgbgrid`): inside the box `bounds` of the medium's own space, placed
    /// by `transform`, and vacuum outside it. A grid volume fills that box. The coefficients
    /// are given as `sigma_t` and `albedo`, or as `sigma_a` and `sigma_s`.
    Heterogeneous {
        /// Extinction (times `scale` and `tint`), with `albedo`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sigma_t: Option<VolumeDesc>,
        /// Single-scattering albedo in `[0, 1]`, with `sigma_t`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        albedo: Option<VolumeDesc>,
        /// Absorption (times `scale` and `tint`), with `sigma_s`, in place of `sigma_t` and
        /// `albedo` (pbrt-v4's `rgbgrid`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sigma_a: Option<VolumeDesc>,
        /// Scattering (times `scale` and `tint`), with `sigma_a`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sigma_s: Option<VolumeDesc>,
        /// Default: 1.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        scale: f32,
        /// A colour the coefficients are multiplied by, channel by channel: pbrt-v4's
        /// `uniformgrid`, a grid of densities times an RGB `sigma_a + sigma_s`. Default:
        /// (1, 1, 1).
        #[serde(default = "white", skip_serializing_if = "is_white")]
        tint: V3,
        /// Default: `Isotropic`.
        #[serde(default, skip_serializing_if = "PhaseDesc::is_isotropic")]
        phase: PhaseDesc,
        /// Radiance the medium emits (times the absorption there). Default: none.
        #[serde(default, skip_serializing_if = "is_zero")]
        emission: V3,
        /// A volume the emission is multiplied by, point by point (pbrt-v4's `Lescale` grid
        /// of a `uniformgrid`, the `Le` grid of an `rgbgrid`). Default: none (1 everywhere).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        emission_grid: Option<VolumeDesc>,
        /// The medium's space to the world. Default: identity.
        #[serde(default, skip_serializing_if = "is_identity")]
        transform: TransformDesc,
        /// The box the medium fills, in its own space (min, max). Default: the unit cube.
        #[serde(default = "unit_box", skip_serializing_if = "is_unit_box")]
        bounds: (V3, V3),
    },
}

/// A value over a medium's box.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum VolumeDesc {
    /// The same everywhere.
    Constant(V3),
    /// A Mitsuba `.vol` grid (1 or 3 channels) filling the box, looked up trilinearly.
    Grid(String),
    /// A grid given inline (pbrt-v4's `density`): `size` voxels along x, y, z, one value each
    /// or three (an RGB each, together), `x` fastest.
    Values {
        size: (u32, u32, u32),
        values: Vec<f32>,
        /// What lies past the outermost voxel centres. Default: `Clamp`.
        #[serde(default, skip_serializing_if = "GridEdgeDesc::is_clamp")]
        edge: GridEdgeDesc,
    },
}

/// What a grid holds between its outermost voxel centres and the faces of its box.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
pub enum GridEdgeDesc {
    /// The nearest voxels' values hold up to the faces (Mitsuba 3's grids).
    #[default]
    Clamp,
    /// Voxels past the faces count as 0, so values fade to half the edge voxels' at the
    /// faces (pbrt-v4's grids).
    Zero,
}

impl GridEdgeDesc {
    fn is_clamp(&self) -> bool {
        *self == GridEdgeDesc::Clamp
    }
}

/// How a medium scatters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum PhaseDesc {
    /// The same in every direction.
    #[default]
    Isotropic,
    /// Henyey and Greenstein's lobe of mean cosine `g` in `(-1, 1)` (positive: forward).
    HenyeyGreenstein(f32),
}

impl PhaseDesc {
    fn is_isotropic(&self) -> bool {
        *self == PhaseDesc::Isotropic
    }
}

/// The media on the two sides of a surface: `inside` behind its normals, `outside` in front;
/// a side left out is vacuum. A surface without one bounds no medium: rays keep theirs.
#[derive(Clone, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MediumInterfaceDesc {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inside: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outside: Option<String>,
}

fn one() -> f32 {
    1.0
}

fn is_one(v: &f32) -> bool {
    *v == 1.0
}

fn white() -> V3 {
    [1.0; 3]
}

fn is_white(v: &V3) -> bool {
    *v == white()
}

fn is_zero(v: &V3) -> bool {
    *v == [0.0; 3]
}

fn is_identity(t: &TransformDesc) -> bool {
    *t == TransformDesc::default()
}

fn unit_box() -> (V3, V3) {
    ([0.0; 3], [1.0; 3])
}

fn is_unit_box(b: &(V3, V3)) -> bool {
    *b == unit_box()
}
