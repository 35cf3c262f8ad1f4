//! The RON scene format: what a scene file may say, with defaults for everything optional.
//!
//! Every struct rejects unknown fields. `Option` fields may be written bare (the
//! `implicit_some` extension is on), so `emitter: Area(radiance: (1, 1, 1))` works.
//! See `scenes/README.md` for a guide with examples.

pub use super::medium_desc::{
    GridEdgeDesc, MediumDesc, MediumInterfaceDesc, PhaseDesc, VolumeDesc,
};
pub use super::texture_desc::{ColorDesc, FloatDesc};
pub use super::transform_desc::TransformDesc;
use raylab_integrators::bsdf::{ior, ComplexIor, Distribution};
use raylab_integrators::sampler::SamplerKind;
use raylab_integrators::Filter;
use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;
use std::fmt;

/// Largest image side accepted, and largest pixel count (the film alone would need 24 bytes
/// per pixel more than this allows).
pub const MAX_SIDE: u32 = 1 << 16;
pub const MAX_PIXELS: u64 = 1 << 28;

/// A 3-vector as written in RON: `(x, y, z)`.
pub type V3 = [f32; 3];

/// A whole scene file.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The camera (required).
    pub camera: CameraDesc,
    /// Defaults for `raylab render`; command-line flags override them.
    #[serde(default)]
    pub render: RenderDesc,
    /// Named materials that entities refer to. Default: none.
    #[serde(default)]
    pub materials: MaterialTable,
    /// Named mesh assets that `Instance` shapes place, e.g.
    /// `{"ball": Icosphere(subdivisions: 6)}`: any shape made of triangles (`Obj`, `Gltf`,
    /// `Icosphere`, `Mesh`, `Box`, ...). Each is loaded once, when an entity first uses it, and
    /// shared by all its instances. Default: none.
    #[serde(default, skip_serializing_if = "NamedTable::is_empty")]
    pub meshes: MeshTable,
    /// Constant radiance arriving from every direction that escapes the scene (an environment
    /// emitter). Default: none (black).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub environment: Option<V3>,
    /// Named participating media that entities bound (`medium`) and the camera may sit in
    /// (`camera_medium`), e.g. `{"fog": Homogeneous(sigma_t: (0.5, 0.5, 0.5), albedo: (0.9,
    /// 0.9, 0.9))}`. Default: none.
    #[serde(default, skip_serializing_if = "NamedTable::is_empty")]
    pub media: MediumTable,
    /// The medium around the camera, by name. Default: vacuum.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub camera_medium: Option<String>,
    /// The objects of the scene (required, may not be empty).
    pub entities: Vec<EntityDesc>,
}

/// A pinhole camera.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum CameraDesc {
    /// Looks from `eye` towards `look_at`; `fov` is the vertical field of view in degrees.
    LookAt {
        eye: V3,
        look_at: V3,
        /// Up direction. Default: `(0, 0, 1)` (z up, as in the report's room).
        #[serde(default = "z_up")]
        up: V3,
        fov: f32,
        /// Image size in pixels. Default: `(400, 400)`.
        #[serde(default = "default_resolution")]
        resolution: (u32, u32),
    },
    /// Parallel rays along `look_at - eye` from a `width` x `height` rectangle (scene units)
    /// centred on `eye`, its top edge towards `up` (Mitsuba's `orthographic` sensor). Default
    /// `height`: `width` times the resolution's height over its width (square pixels).
    Orthographic {
        eye: V3,
        look_at: V3,
        #[serde(default = "z_up")]
        up: V3,
        width: f32,
        #[serde(skip_serializing_if = "Option::is_none", default)]
        height: Option<f32>,
        /// Image size in pixels. Default: `(400, 400)`.
        #[serde(default = "default_resolution")]
        resolution: (u32, u32),
    },
    /// The report's camera: an eye point and the four corners of the image plane, which must
    /// form a parallelogram.
    ImagePlane {
        eye: V3,
        top_left: V3,
        top_right: V3,
        bottom_left: V3,
        bottom_right: V3,
        /// Image size in pixels. Default: `(400, 400)`.
        #[serde(default = "default_resolution")]
        resolution: (u32, u32),
    },
}

fn z_up() -> V3 {
    [0.0, 0.0, 1.0]
}

fn default_resolution() -> (u32, u32) {
    (400, 400)
}

/// Render defaults.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    /// Integrator name. Default: `"path"`.
    #[serde(default = "default_integrator")]
    pub integrator: String,
    /// Samples per pixel. Default: 16.
    #[serde(default = "default_spp")]
    pub spp: u32,
    /// Random seed. Default: 0.
    #[serde(default)]
    pub seed: u64,
    /// Integrator parameters, e.g. `{"max-depth": 8}` (`inf` for unlimited). Default: none.
    #[serde(default)]
    pub params: BTreeMap<String, f64>,
    /// Pixel reconstruction filter: `"box"`, `"tent"` or `"gaussian"` (Mitsuba 3's default).
    /// Default: `"box"`.
    #[serde(default, deserialize_with = "filter_name", serialize_with = "display")]
    pub filter: Filter,
    /// How a light sample picks an emitter: `"power"` (each light in proportion to its
    /// power, the default), `"uniform"` (each emitting entity alike, then its parts in
    /// proportion to their power: Mitsuba 3's, which its importer sets) or `"bvh"` (a light
    /// BVH weighing each light by what it could send to the shading point: pbrt-v4's
    /// default). Integrators with a `light-selection` parameter may choose another.
    #[serde(default, skip_serializing_if = "LightSelection::is_power")]
    pub light_selection: LightSelection,
    /// How camera samples draw their numbers: `"independent"` (the default), `"stratified"`,
    /// `"sobol"` (Owen-scrambled, padded Sobol points), `"zsobol"` (pbrt-v4's default) or
    /// `"halton"` (see `--sampler`).
    #[serde(
        default,
        deserialize_with = "sampler_name",
        serialize_with = "display",
        skip_serializing_if = "is_independent"
    )]
    pub sampler: SamplerKind,
    /// Render with sampled wavelengths rather than RGB (see `--spectral`). Default: false.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub spectral: bool,
}

/// A sampler by name; an unknown name is an error at its place in the file.
fn sampler_name<'de, D: serde::Deserializer<'de>>(d: D) -> Result<SamplerKind, D::Error> {
    let name = String::deserialize(d)?;
    SamplerKind::parse(&name).map_err(serde::de::Error::custom)
}

fn is_independent(kind: &SamplerKind) -> bool {
    *kind == SamplerKind::Independent
}

/// How light sampling picks an emitter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LightSelection {
    #[default]
    Power,
    Uniform,
    Bvh,
}

impl LightSelection {
    fn is_power(&self) -> bool {
        *self == LightSelection::Power
    }
}

/// A filter by name; an unknown name is an error at its place in the file.
fn filter_name<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Filter, D::Error> {
    let name = String::deserialize(d)?;
    name.parse().map_err(serde::de::Error::custom)
}

impl Default for RenderDesc {
    fn default() -> Self {
        RenderDesc {
            integrator: default_integrator(),
            spp: default_spp(),
            seed: 0,
            params: BTreeMap::new(),
            filter: Filter::Box,
            light_selection: LightSelection::Power,
            sampler: SamplerKind::Independent,
            spectral: false,
        }
    }
}

fn default_integrator() -> String {
    "path".to_string()
}

fn default_spp() -> u32 {
    16
}

/// A material model with its parameters. Colours are linear RGB reflectances in `[0, 1]`:
/// `(r, g, b)`, a grey number, or a texture (see [`crate::scene::textures`]); so may be the rough
/// metals' and glasses' `alpha`.
///
/// The principled variants are larger than the others; a description is read once and
/// flattened, never held per hit, so they stay inline (RON writes them as the others).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum MaterialDesc {
    /// Ideal diffuse reflector.
    Lambert { albedo: ColorDesc },
    /// Diffuse reflection and transmission (pbrt-v4's `diffusetransmission`: a leaf, a
    /// lampshade): `reflectance / pi` on the side light arrives from, `transmittance / pi`
    /// on the other; their sum at most 1 per channel.
    DiffuseTransmission {
        reflectance: ColorDesc,
        transmittance: ColorDesc,
    },
    /// Rough diffuse reflector; `sigma` is the facet slope deviation in DEGREES (0 = Lambert).
    OrenNayar { albedo: ColorDesc, sigma: f32 },
    /// Energy-conserving Phong: diffuse `kd` plus a glossy lobe `ks` of `exponent`;
    /// `kd + ks <= 1` per channel.
    Phong {
        kd: ColorDesc,
        ks: ColorDesc,
        exponent: f32,
    },
    /// Perfect mirror. Default tint: `(1, 1, 1)`.
    Mirror {
        #[serde(default = "white")]
        tint: V3,
    },
    /// Smooth dielectric with one tint for both lobes (the `Dielectric` of raylab 1).
    /// Defaults: `ior: 1.5`, `tint: (1, 1, 1)`.
    Glass {
        #[serde(default = "glass_ior")]
        ior: f32,
        #[serde(default = "white")]
        tint: V3,
    },
    /// Smooth dielectric (Mitsuba's `dielectric`). IORs are numbers or names (`"bk7"`,
    /// `"water"`, `"air"`, ...). Defaults: `int_ior: "bk7"`, `ext_ior: "air"`, both tints white.
    Dielectric {
        #[serde(default = "bk7")]
        int_ior: Ior,
        #[serde(default = "air")]
        ext_ior: Ior,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
        #[serde(default = "white_colour")]
        specular_transmittance: ColorDesc,
        /// The index inside by wavelength, for spectral rendering (RGB rendering keeps
        /// `int_ior`, best the glass's index at 587.6 nm): a glass of the table (`Glass("BK7")`,
        /// `"BAF10"`, `"SF11"`, `"F2"`, `"fused silica"`, `"diamond"`), Sellmeier's
        /// coefficients (`Sellmeier(b: (..), c: (..))`, `c` in square micrometres) or Cauchy's
        /// (`Cauchy(a: .., b: ..)`, `b` in square micrometres). A path through it carries only
        /// its hero wavelength on. Default: none.
        #[serde(skip_serializing_if = "Option::is_none", default)]
        dispersion: Option<DispersionDesc>,
    },
    /// Frosted glass (Mitsuba's `roughdielectric`): as `Dielectric` plus the microfacet
    /// distribution. Defaults: `distribution: "beckmann"`, `alpha: 0.1`.
    RoughDielectric {
        #[serde(default = "bk7")]
        int_ior: Ior,
        #[serde(default = "air")]
        ext_ior: Ior,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
        #[serde(default = "white_colour")]
        specular_transmittance: ColorDesc,
        #[serde(
            default,
            deserialize_with = "distribution_name",
            serialize_with = "distribution_text"
        )]
        distribution: Distribution,
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha: Option<FloatDesc>,
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha_u: Option<FloatDesc>,
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha_v: Option<FloatDesc>,
    },
    /// A thin pane (Mitsuba's `thindielectric`): reflection and straight transmission.
    /// Defaults as `Dielectric`.
    ThinDielectric {
        #[serde(default = "bk7")]
        int_ior: Ior,
        #[serde(default = "air")]
        ext_ior: Ior,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
        #[serde(default = "white_colour")]
        specular_transmittance: ColorDesc,
    },
    /// Smooth metal (Mitsuba's `conductor`): a named `metal` (`"Au"`, `"Ag"`, `"Cu"`, ...;
    /// `"none"` is a perfect mirror) or `eta` and `k`. Defaults: `metal: "none"`,
    /// `specular_reflectance: (1, 1, 1)`.
    Conductor {
        #[serde(skip_serializing_if = "Option::is_none")]
        metal: Option<Metal>,
        #[serde(skip_serializing_if = "Option::is_none")]
        eta: Option<V3>,
        #[serde(skip_serializing_if = "Option::is_none")]
        k: Option<V3>,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
    },
    /// Rough metal (Mitsuba's `roughconductor`): as `Conductor` plus the microfacet
    /// distribution. Defaults: `distribution: "beckmann"`, `alpha: 0.1`.
    RoughConductor {
        #[serde(skip_serializing_if = "Option::is_none")]
        metal: Option<Metal>,
        #[serde(skip_serializing_if = "Option::is_none")]
        eta: Option<V3>,
        #[serde(skip_serializing_if = "Option::is_none")]
        k: Option<V3>,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
        #[serde(
            default,
            deserialize_with = "distribution_name",
            serialize_with = "distribution_text"
        )]
        distribution: Distribution,
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha: Option<FloatDesc>,
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha_u: Option<FloatDesc>,
        #[serde(skip_serializing_if = "Option::is_none")]
        alpha_v: Option<FloatDesc>,
    },
    /// Diffuse base under a smooth coating (Mitsuba's `plastic`). Defaults:
    /// `diffuse_reflectance: (0.5, 0.5, 0.5)`, `specular_reflectance: (1, 1, 1)`,
    /// `int_ior: "polypropylene"` (1.49), `ext_ior: "air"`, `nonlinear: false`.
    Plastic {
        #[serde(default = "half_colour")]
        diffuse_reflectance: ColorDesc,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
        #[serde(default = "polypropylene")]
        int_ior: Ior,
        #[serde(default = "air")]
        ext_ior: Ior,
        #[serde(default)]
        nonlinear: bool,
    },
    /// Diffuse base under a rough coating (Mitsuba's `roughplastic`): as `Plastic` plus the
    /// distribution and an isotropic `alpha` (a number: the coating's tables depend on it).
    /// Defaults: `distribution: "beckmann"`, `alpha: 0.1`.
    RoughPlastic {
        #[serde(default = "half_colour")]
        diffuse_reflectance: ColorDesc,
        #[serde(default = "white_colour")]
        specular_reflectance: ColorDesc,
        #[serde(default = "polypropylene")]
        int_ior: Ior,
        #[serde(default = "air")]
        ext_ior: Ior,
        #[serde(default)]
        nonlinear: bool,
        #[serde(
            default,
            deserialize_with = "distribution_name",
            serialize_with = "distribution_text"
        )]
        distribution: Distribution,
        #[serde(default = "default_alpha")]
        alpha: FloatDesc,
    },
    /// Burley's principled BSDF as Mitsuba 3's `principled`: a diffuse base with a sheen, a
    /// GGX dielectric specular that `metallic` turns into a metal, a glossy transmission
    /// (`spec_trans`, present or not) and a clear coat. Every weight lies in [0, 1] and may be
    /// a texture. `eta` or `specular` (not both) sets the dielectric (`eta = 2 / (1 -
    /// sqrt(0.08 specular)) - 1`). Defaults as Mitsuba's: `base_color` 0.5, `roughness` 0.5,
    /// `specular` 0.5, the rest 0. Without `spec_trans` it is opaque (and two-sided).
    Principled {
        #[serde(default = "half_colour")]
        base_color: ColorDesc,
        #[serde(default = "half_float")]
        roughness: FloatDesc,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        anisotropic: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        metallic: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        spec_trans: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        spec_tint: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sheen: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sheen_tint: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        flatness: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        clearcoat: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        clearcoat_gloss: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        eta: Option<f32>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        specular: Option<f32>,
    },
    /// Burley's thin-sheet model as Mitsuba 3's `principledthin`: two-sided, with a diffuse
    /// transmission `diff_trans` in [0, 2] and a glossy one through the sheet (`spec_trans`);
    /// `eta` the sheet's IOR (default 1.5). Other parameters as `Principled`.
    PrincipledThin {
        #[serde(default = "half_colour")]
        base_color: ColorDesc,
        #[serde(default = "half_float")]
        roughness: FloatDesc,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        anisotropic: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        spec_trans: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        spec_tint: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sheen: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sheen_tint: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        flatness: Option<FloatDesc>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        diff_trans: Option<FloatDesc>,
        #[serde(default = "glass_ior")]
        eta: f32,
    },
    /// An opaque material seen from its front only (Mitsuba 3's opaque BSDFs outside a
    /// `twosided`): from behind its shading normal it reflects nothing. raylab's own opaque
    /// materials are two-sided; the Mitsuba importer wraps Mitsuba's one-sided ones in this.
    OneSided(Box<MaterialDesc>),
    /// The same material on both faces (Mitsuba's `twosided`). raylab's opaque materials are
    /// two-sided already, so this is the material itself; a dielectric inside is an error.
    TwoSided(Box<MaterialDesc>),
    /// `material` with its shading normal read from a tangent-space normal map (Mitsuba's
    /// `normalmap`): `texture`'s `2 rgb - 1`, in the frame of the surface's normal and `dpdu`.
    ///
    /// As Mitsuba 3.7's, by default: `flip_invalid_normals` (a tilted normal facing away
    /// from the viewer has its tangential part negated) and `shadowing` (the BSDF carries
    /// Estevez et al.'s microfacet shadowing term and refuses directions below the surface's
    /// own shading normal). Both `true` unless set `false` (pbrt's maps have neither).
    NormalMap {
        texture: ColorDesc,
        material: Box<MaterialDesc>,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        flip_invalid_normals: bool,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        shadowing: bool,
    },
    /// `material` cut out by a mask (Mitsuba's `mask`): where `opacity` (a number or a
    /// texture's value, in [0, 1]) is below 1, a path goes on straight through the surface
    /// with probability 1 - opacity, and the material's value is scaled by it. Shadow rays
    /// stop at the surface (as in Mitsuba 3's path tracer), but for `volpath`'s, which pass
    /// with weight 1 - opacity (as Mitsuba 3's `volpath`'s).
    Mask {
        opacity: FloatDesc,
        material: Box<MaterialDesc>,
    },
    /// No surface at all: the boundary of a participating medium that does not scatter
    /// (Mitsuba 3's `null`, pbrt-v4's `interface`). Rays cross it unchanged, into the medium
    /// on its other side; volumetric integrators count no scattering event there.
    Null,
    /// `material` on a surface cut out by pbrt-v4's `alpha` (a number or a texture's value):
    /// where it is below 1 a ray passes the surface with probability `1 - alpha`, as if it
    /// were not there (no scattering, shadow rays too); pbrt-v4 decides by a hash of the ray,
    /// and so does raylab. Not on emitters.
    Cutout {
        alpha: FloatDesc,
        material: Box<MaterialDesc>,
    },
    /// Hair fibres (pbrt-v4's `hair`, Chiang et al. 2016) for `Curves`: a dielectric fibre of
    /// index `eta` (default 1.55) with an absorbing interior and cuticle scales tilted by
    /// `alpha` degrees (default 2), longitudinal and azimuthal roughness `beta_m` and `beta_n`
    /// in [0, 1] (default 0.3 each). The interior's absorption is one of: `sigma_a` (per unit
    /// radius, per channel), `reflectance` (the colour a head of such hair takes, per Chiang's
    /// fit), or the concentrations of `eumelanin` and `pheomelanin` (pigments: about 0.3
    /// blond, 1.3 brown, 8 black); none given is eumelanin 1.3 (pbrt's default). `h`, where
    /// across the fibre a ray meets it, is `2 v - 1` of the hit.
    Hair {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        sigma_a: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reflectance: Option<V3>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        eumelanin: Option<f32>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        pheomelanin: Option<f32>,
        #[serde(default = "hair_eta")]
        eta: f32,
        #[serde(default = "hair_roughness")]
        beta_m: f32,
        #[serde(default = "hair_roughness")]
        beta_n: f32,
        #[serde(default = "hair_alpha")]
        alpha: f32,
    },
    /// `material` on a surface displaced along its normal by `scale` times `texture`'s
    /// luminance (Mitsuba's `bumpmap`), shaded with the displaced surface's normal. Default
    /// `scale: 1`; `flip_invalid_normals` and `shadowing` as for `NormalMap`.
    BumpMap {
        texture: FloatDesc,
        #[serde(default = "one")]
        scale: f32,
        material: Box<MaterialDesc>,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        flip_invalid_normals: bool,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        shadowing: bool,
    },
}

impl MaterialDesc {
    /// The names of the mesh attributes its textures read (`Attribute(...)`), each once.
    pub fn attributes(&self) -> Vec<String> {
        use MaterialDesc::*;
        let mut out = Vec::new();
        let colour = |c: &ColorDesc, out: &mut Vec<String>| {
            if let ColorDesc::Texture(t) = c {
                t.attributes(out);
            }
        };
        let float = |f: &FloatDesc, out: &mut Vec<String>| {
            if let FloatDesc::Texture(t) = f {
                t.attributes(out);
            }
        };
        let floats = |fs: &[&Option<FloatDesc>], out: &mut Vec<String>| {
            for f in fs.iter().copied().flatten() {
                float(f, out);
            }
        };
        match self {
            Null => {}
            Lambert { albedo } | OrenNayar { albedo, .. } => colour(albedo, &mut out),
            DiffuseTransmission {
                reflectance: a,
                transmittance: b,
            }
            | Phong { kd: a, ks: b, .. }
            | Dielectric {
                specular_reflectance: a,
                specular_transmittance: b,
                ..
            }
            | ThinDielectric {
                specular_reflectance: a,
                specular_transmittance: b,
                ..
            } => {
                colour(a, &mut out);
                colour(b, &mut out);
            }
            Plastic {
                diffuse_reflectance: a,
                specular_reflectance: b,
                ..
            } => {
                colour(a, &mut out);
                colour(b, &mut out);
            }
            RoughPlastic {
                diffuse_reflectance: a,
                specular_reflectance: b,
                alpha,
                ..
            } => {
                colour(a, &mut out);
                colour(b, &mut out);
                float(alpha, &mut out);
            }
            RoughDielectric {
                specular_reflectance: a,
                specular_transmittance: b,
                alpha,
                alpha_u,
                alpha_v,
                ..
            } => {
                colour(a, &mut out);
                colour(b, &mut out);
                floats(&[alpha, alpha_u, alpha_v], &mut out);
            }
            Mirror { .. } | Glass { .. } | Hair { .. } => {}
            Conductor {
                specular_reflectance,
                ..
            } => colour(specular_reflectance, &mut out),
            RoughConductor {
                specular_reflectance,
                alpha,
                alpha_u,
                alpha_v,
                ..
            } => {
                colour(specular_reflectance, &mut out);
                floats(&[alpha, alpha_u, alpha_v], &mut out);
            }
            Principled {
                base_color,
                roughness,
                anisotropic,
                metallic,
                spec_trans,
                spec_tint,
                sheen,
                sheen_tint,
                flatness,
                clearcoat,
                clearcoat_gloss,
                ..
            } => {
                colour(base_color, &mut out);
                float(roughness, &mut out);
                floats(
                    &[
                        anisotropic,
                        metallic,
                        spec_trans,
                        spec_tint,
                        sheen,
                        sheen_tint,
                        flatness,
                        clearcoat,
                        clearcoat_gloss,
                    ],
                    &mut out,
                );
            }
            PrincipledThin {
                base_color,
                roughness,
                anisotropic,
                spec_trans,
                spec_tint,
                sheen,
                sheen_tint,
                flatness,
                diff_trans,
                ..
            } => {
                colour(base_color, &mut out);
                float(roughness, &mut out);
                floats(
                    &[
                        anisotropic,
                        spec_trans,
                        spec_tint,
                        sheen,
                        sheen_tint,
                        flatness,
                        diff_trans,
                    ],
                    &mut out,
                );
            }
            TwoSided(inner) | OneSided(inner) => out = inner.attributes(),
            NormalMap {
                texture, material, ..
            } => {
                colour(texture, &mut out);
                out.extend(material.attributes());
            }
            Mask { opacity, material } => {
                float(opacity, &mut out);
                out.extend(material.attributes());
            }
            Cutout { alpha, material } => {
                float(alpha, &mut out);
                out.extend(material.attributes());
            }
            BumpMap {
                texture, material, ..
            } => {
                float(texture, &mut out);
                out.extend(material.attributes());
            }
        }
        out.sort();
        out.dedup();
        out
    }

    /// Whether any of its parameters is a texture (a normal or bump map always is).
    pub fn is_textured(&self) -> bool {
        use MaterialDesc::*;
        let c = |c: &ColorDesc| matches!(c, ColorDesc::Texture(_));
        let f = |f: &FloatDesc| matches!(f, FloatDesc::Texture(_));
        let any = |a: [&Option<FloatDesc>; 3]| a.iter().any(|a| a.as_ref().is_some_and(f));
        match self {
            Null => false,
            Lambert { albedo } | OrenNayar { albedo, .. } => c(albedo),
            DiffuseTransmission {
                reflectance,
                transmittance,
            } => c(reflectance) || c(transmittance),
            Phong { kd, ks, .. } => c(kd) || c(ks),
            Mirror { .. } | Glass { .. } | Hair { .. } => false,
            Dielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            }
            | ThinDielectric {
                specular_reflectance,
                specular_transmittance,
                ..
            } => c(specular_reflectance) || c(specular_transmittance),
            RoughDielectric {
                specular_reflectance,
                specular_transmittance,
                alpha,
                alpha_u,
                alpha_v,
                ..
            } => {
                c(specular_reflectance)
                    || c(specular_transmittance)
                    || any([alpha, alpha_u, alpha_v])
            }
            Conductor {
                specular_reflectance,
                ..
            } => c(specular_reflectance),
            RoughConductor {
                specular_reflectance,
                alpha,
                alpha_u,
                alpha_v,
                ..
            } => c(specular_reflectance) || any([alpha, alpha_u, alpha_v]),
            Plastic {
                diffuse_reflectance,
                specular_reflectance,
                ..
            } => c(diffuse_reflectance) || c(specular_reflectance),
            RoughPlastic {
                diffuse_reflectance,
                specular_reflectance,
                alpha,
                ..
            } => c(diffuse_reflectance) || c(specular_reflectance) || f(alpha),
            Principled {
                base_color,
                roughness,
                anisotropic,
                metallic,
                spec_trans,
                spec_tint,
                sheen,
                sheen_tint,
                flatness,
                clearcoat,
                clearcoat_gloss,
                ..
            } => {
                c(base_color)
                    || f(roughness)
                    || [
                        anisotropic,
                        metallic,
                        spec_trans,
                        spec_tint,
                        sheen,
                        sheen_tint,
                        flatness,
                        clearcoat,
                        clearcoat_gloss,
                    ]
                    .iter()
                    .any(|a| a.as_ref().is_some_and(f))
            }
            PrincipledThin {
                base_color,
                roughness,
                anisotropic,
                spec_trans,
                spec_tint,
                sheen,
                sheen_tint,
                flatness,
                diff_trans,
                ..
            } => {
                c(base_color)
                    || f(roughness)
                    || [
                        anisotropic,
                        spec_trans,
                        spec_tint,
                        sheen,
                        sheen_tint,
                        flatness,
                        diff_trans,
                    ]
                    .iter()
                    .any(|a| a.as_ref().is_some_and(f))
            }
            TwoSided(inner) | OneSided(inner) => inner.is_textured(),
            NormalMap { .. } | BumpMap { .. } => true,
            Mask { opacity, material } => f(opacity) || material.is_textured(),
            Cutout { material, .. } => material.is_textured(),
        }
    }
}

/// An index of refraction: a number, or a name from the table of dielectrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ior(pub f32);

impl<'de> Deserialize<'de> for Ior {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct IorVisitor;
        impl Visitor<'_> for IorVisitor {
            type Value = Ior;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an index of refraction: a number or a name such as \"bk7\"")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Ior, E> {
                Ok(Ior(v as f32))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Ior, E> {
                Ok(Ior(v as f32))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Ior, E> {
                Ok(Ior(v as f32))
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<Ior, E> {
                ior::dielectric(v).map(Ior).map_err(E::custom)
            }
        }
        d.deserialize_any(IorVisitor)
    }
}

impl Serialize for Ior {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f32(self.0)
    }
}

/// How a dielectric's index of refraction varies with wavelength.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum DispersionDesc {
    Glass(String),
    Sellmeier { b: V3, c: V3 },
    Cauchy { a: f32, b: f32 },
}

impl DispersionDesc {
    /// The index by wavelength.
    pub fn curve(&self) -> Result<raylab_integrators::spectrum::curve::Curve, String> {
        use raylab_integrators::spectrum::curve::Curve;
        let curve = match self {
            DispersionDesc::Glass(name) => raylab_integrators::bsdf::ior::glass(name)?,
            DispersionDesc::Sellmeier { b, c } => Curve::Sellmeier { b: *b, c: *c },
            DispersionDesc::Cauchy { a, b } => Curve::Cauchy { a: *a, b: *b },
        };
        // Finite and at least 1 over the visible range.
        for i in 0..=94 {
            let n = curve.at(360.0 + 5.0 * i as f32);
            if !(n.is_finite() && n >= 1.0) {
                return Err(format!(
                    "the dispersion gives an index of {n} at {} nm",
                    360 + 5 * i
                ));
            }
        }
        Ok(curve)
    }
}

/// A metal by name, resolved when it is read (so that an unknown name is an error at its
/// place in the file): its name as the table spells it, and its complex IOR, or none for
/// `"none"` (a perfect mirror).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metal {
    pub name: &'static str,
    pub ior: Option<ComplexIor>,
}

impl Metal {
    /// The metal `name` of the table of metals (or `"none"`).
    pub fn named(name: &str) -> Result<Metal, String> {
        let ior = ior::metal(name)?;
        let name = ior::METALS
            .iter()
            .map(|(n, _, _)| *n)
            .find(|n| *n == name)
            .unwrap_or("none");
        Ok(Metal { name, ior })
    }
}

impl<'de> Deserialize<'de> for Metal {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Metal::named(&name).map_err(de::Error::custom)
    }
}

impl Serialize for Metal {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name)
    }
}

/// A value written as its `Display` text (a filter: `"box"`, `"tent(radius: 2)"`).
fn display<T: fmt::Display, S: Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(v)
}

/// A microfacet distribution as its name.
fn distribution_text<S: Serializer>(d: &Distribution, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(match d {
        Distribution::Ggx => "ggx",
        Distribution::Beckmann => "beckmann",
    })
}

/// A microfacet distribution by name: `"ggx"` or `"beckmann"` (Mitsuba's names).
fn distribution_name<'de, D: Deserializer<'de>>(d: D) -> Result<Distribution, D::Error> {
    let name = String::deserialize(d)?;
    match name.as_str() {
        "ggx" | "GGX" => Ok(Distribution::Ggx),
        "beckmann" | "Beckmann" => Ok(Distribution::Beckmann),
        _ => Err(de::Error::custom(format!(
            "unknown microfacet distribution {name:?}; known: \"ggx\", \"beckmann\""
        ))),
    }
}

pub(crate) fn bk7() -> Ior {
    Ior(1.5046)
}

pub(crate) fn air() -> Ior {
    Ior(1.000_277)
}

pub(crate) fn polypropylene() -> Ior {
    Ior(1.49)
}

pub(crate) fn half_colour() -> ColorDesc {
    ColorDesc::Constant([0.5; 3])
}

pub(crate) fn white_colour() -> ColorDesc {
    ColorDesc::Constant([1.0; 3])
}

pub(crate) fn half_float() -> FloatDesc {
    FloatDesc::Constant(0.5)
}

pub(crate) fn default_alpha() -> FloatDesc {
    FloatDesc::Constant(0.1)
}

fn hair_eta() -> f32 {
    1.55
}

fn hair_roughness() -> f32 {
    0.3
}

fn hair_alpha() -> f32 {
    2.0
}

fn default_subdivisions() -> u32 {
    4
}

pub(crate) fn white() -> V3 {
    [1.0; 3]
}

fn glass_ior() -> f32 {
    1.5
}

/// What a [`NamedTable`] holds, for its messages.
pub trait TableEntry {
    /// "material", "mesh": used in "duplicate material name `x`".
    const KIND: &'static str;
}

impl TableEntry for MaterialDesc {
    const KIND: &'static str = "material";
}

impl TableEntry for ShapeDesc {
    const KIND: &'static str = "mesh";
}

/// A map from names to entries, in file order. Rejects a name given twice.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedTable<T>(pub Vec<(String, T)>);

impl<T> NamedTable<T> {
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl<T> Default for NamedTable<T> {
    fn default() -> Self {
        NamedTable(Vec::new())
    }
}

/// The named materials, in file order.
pub type MaterialTable = NamedTable<MaterialDesc>;

/// The named mesh assets (shapes made of triangles), in file order.
pub type MeshTable = NamedTable<ShapeDesc>;

/// The named participating media, in file order.
pub type MediumTable = NamedTable<MediumDesc>;

impl<'de, T: Deserialize<'de> + TableEntry> Deserialize<'de> for NamedTable<T> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct TableVisitor<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de> + TableEntry> Visitor<'de> for TableVisitor<T> {
            type Value = NamedTable<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "a map from {} names to {}es", T::KIND, T::KIND)
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
                let mut out: Vec<(String, T)> = Vec::new();
                while let Some(name) = map.next_key::<String>()? {
                    if out.iter().any(|(n, _)| *n == name) {
                        return Err(de::Error::custom(format!(
                            "duplicate {} name `{name}`",
                            T::KIND
                        )));
                    }
                    let entry = map.next_value::<T>()?;
                    out.push((name, entry));
                }
                Ok(NamedTable(out))
            }
        }
        deserializer.deserialize_map(TableVisitor(std::marker::PhantomData))
    }
}

impl<T: Serialize> Serialize for NamedTable<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (name, entry) in &self.0 {
            map.serialize_entry(name, entry)?;
        }
        map.end()
    }
}

/// One object of the scene.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct EntityDesc {
    /// Name used in messages. Default: `entity #N` (N counts from 0 in file order).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub name: Option<String>,
    /// Placement. Default: identity.
    #[serde(default, skip_serializing_if = "is_identity")]
    pub transform: TransformDesc,
    /// Geometry in the entity's local space. Default: none (only a point light may lack it).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub shape: Option<ShapeDesc>,
    /// Name of a material in `materials`. Required for shapes, except pure area emitters,
    /// which default to black.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub material: Option<String>,
    /// Light emission. Default: none.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub emitter: Option<EmitterDesc>,
    /// The media the shape's surface bounds (Mitsuba's `interior`/`exterior`, pbrt-v4's
    /// `MediumInterface`), e.g. `(inside: "fog")`. Default: none (rays keep their medium).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub medium: Option<MediumInterfaceDesc>,
    /// Turns the shape's faces around (Mitsuba's `flip_normals`): a one-sided emitter then
    /// emits from its other side, and a sphere emits into its inside. Default: false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub flip_normals: bool,
}

impl EntityDesc {
    /// A light that is not a shape (a point, spot or directional light, an environment map),
    /// placed by `transform`.
    pub fn light(name: String, transform: TransformDesc, emitter: EmitterDesc) -> EntityDesc {
        EntityDesc {
            name: Some(name),
            transform,
            shape: None,
            material: None,
            emitter: Some(emitter),
            medium: None,
            flip_normals: false,
        }
    }
}

/// Geometry in local space.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeDesc {
    /// Sphere (analytic). Default centre: origin. Needs a uniform scale.
    Sphere {
        #[serde(default)]
        center: V3,
        radius: f32,
    },
    /// One triangle, `vertices: [a, b, c]`; its front (for one-sided emitters) is where the vertices run
    /// counter-clockwise.
    Triangle { vertices: Vec<V3> },
    /// A parallelogram given by its 4 corners in order (counter-clockwise seen from the front).
    Quad { vertices: Vec<V3> },
    /// Mitsuba's `rectangle`: the square `[-1, 1]^2` of the local `xy` plane, its front
    /// facing `+z`. Size and place it with `transform`.
    Rectangle,
    /// Mitsuba's `disk`: the unit disk of the local `xy` plane, its front facing `+z`. Size
    /// and place it with `transform` (a scale that differs in `x` and `y` makes an ellipse).
    Disk,
    /// Mitsuba's `cylinder`: an open tube (no end caps) of `radius` around the segment from
    /// `p0` to `p1`, its front facing outwards. The transform must keep its cross-section a
    /// circle. Defaults: `p0: (0, 0, 0)`, `p1: (0, 0, 1)`, `radius: 1`.
    Cylinder {
        #[serde(default)]
        p0: V3,
        #[serde(default = "unit_z")]
        p1: V3,
        #[serde(default = "one")]
        radius: f32,
    },
    /// Four corners; faces are oriented outwards automatically.
    Tetrahedron { vertices: Vec<V3> },
    /// Axis-aligned box in local space, faces oriented outwards.
    Box { min: V3, max: V3 },
    /// A unit sphere as a triangle mesh: an icosahedron subdivided `subdivisions` times
    /// (`20 * 4^n` triangles; 8 gives 1.31 M), each vertex moved along its normal by up to
    /// `displacement` (smooth bumps). Size it with `transform.scale`. Defaults: 4, 0.
    Icosphere {
        #[serde(default = "default_subdivisions")]
        subdivisions: u32,
        #[serde(default)]
        displacement: f32,
    },
    /// A Wavefront OBJ file, `path` relative to the scene file; every object in it, triangulated,
    /// with its normals when the file has them (see [`MeshNormals`]). Its materials are not
    /// used.
    Obj {
        path: String,
        #[serde(default)]
        normals: MeshNormals,
    },
    /// A glTF 2.0 file (`.gltf` or `.glb`), `path` relative to the scene file: the triangles of
    /// every mesh in its default scene, placed by the node transforms, with their normals when
    /// present. Its materials are not used.
    Gltf { path: String },
    /// A Stanford PLY file (ASCII or binary), `path` relative to the scene file: its faces
    /// (polygons split into triangles), with vertex normals (see [`MeshNormals`]) and texture
    /// coordinates when present. `attribute` names one of its other per-vertex or per-face
    /// values (Mitsuba 3's names: `vertex_color`, `face_NAME`, ...) for the material's
    /// `Attribute` textures to read.
    Ply {
        path: String,
        #[serde(default)]
        normals: MeshNormals,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        attribute: Option<String>,
    },
    /// Mesh `shape_index` (default 0) of a Mitsuba `.serialized` file (versions 3 and 4),
    /// `path` relative to the scene file, with its normals (see [`MeshNormals`]) and texture
    /// coordinates when present.
    Serialized {
        path: String,
        #[serde(default)]
        shape_index: u32,
        #[serde(default)]
        normals: MeshNormals,
    },
    /// A signed distance function sampled on a grid (Mitsuba 3's `sdfgrid`): a `.vol` file of
    /// one channel, `path` relative to the scene file, over the unit cube of the entity's
    /// space, interpolated trilinearly, its zero set the surface; shaded with Hansson-Söderlund
    /// et al.'s smooth normals unless `smooth_normals: false` (the interpolant's gradient).
    /// No texture coordinates; not an emitter.
    SdfGrid {
        path: String,
        #[serde(default = "yes", skip_serializing_if = "is_true")]
        smooth_normals: bool,
    },
    /// A mesh asset of the scene's `meshes` table, placed by the entity's transform. Every
    /// instance shares one copy of the mesh and its BVH. Instances cannot emit light.
    Instance { mesh: String },
    /// Triangle mesh: vertex positions, triangles as index triples, optional per-vertex normals
    /// for smooth shading and texture coordinates `(u, v)` (`v` running down the image from
    /// its top row, as in Mitsuba 3).
    Mesh {
        positions: Vec<V3>,
        indices: Vec<[u32; 3]>,
        #[serde(skip_serializing_if = "Option::is_none", default)]
        normals: Option<Vec<V3>>,
        #[serde(skip_serializing_if = "Option::is_none", default)]
        uvs: Option<Vec<[f32; 2]>>,
    },
    /// pbrt-v4's `curve`: cubic Bézier curves swept to a width (hair, fur, grass), each
    /// [`CurveDesc`]. `type` is `"flat"` (the default: a ribbon facing every ray),
    /// `"cylinder"` (the same, shaded as a cylinder) or `"ribbon"` (oriented by the curves'
    /// `normals`). Each segment is split into `2^split_depth` pieces that the BVH bounds
    /// (pbrt's `splitdepth`, default 3, at most [`MAX_SPLIT_DEPTH`]). The transform must be a
    /// rotation (or mirror), a uniform scale and a translation, which keep a curve's width.
    /// Curves cannot emit, nor be mesh assets.
    Curves {
        #[serde(rename = "type", default)]
        kind: CurveType,
        #[serde(default = "default_split_depth")]
        split_depth: u32,
        curves: Vec<CurveDesc>,
    },
}

/// Deepest `split_depth` of [`ShapeDesc::Curves`]: 256 pieces a segment.
pub const MAX_SPLIT_DEPTH: u32 = 8;

fn default_split_depth() -> u32 {
    3
}

/// One curve of [`ShapeDesc::Curves`]: `points`, the control points of `n` cubic Bézier
/// segments one after the other (`3 n + 1`: each segment's last point is the next one's
/// first); `width`, its width at the start and at the end, linear in between along the
/// segments (default `(1, 1)`, pbrt's); for a ribbon, `normals` at the `n + 1` ends of its
/// segments, which orient it (interpolated along each segment on the great circle).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CurveDesc {
    pub points: Vec<V3>,
    #[serde(default = "unit_widths")]
    pub width: (f32, f32),
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub normals: Option<Vec<V3>>,
}

fn unit_widths() -> (f32, f32) {
    (1.0, 1.0)
}

/// How a curve faces rays (pbrt-v4's curve `type`): `"flat"`, `"cylinder"` or `"ribbon"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CurveType {
    #[default]
    Flat,
    Cylinder,
    Ribbon,
}

impl<'de> Deserialize<'de> for CurveType {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        match name.as_str() {
            "flat" => Ok(CurveType::Flat),
            "cylinder" => Ok(CurveType::Cylinder),
            "ribbon" => Ok(CurveType::Ribbon),
            _ => Err(de::Error::custom(format!(
                "unknown curve type {name:?}; known: \"flat\", \"cylinder\", \"ribbon\""
            ))),
        }
    }
}

impl Serialize for CurveType {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match self {
            CurveType::Flat => "flat",
            CurveType::Cylinder => "cylinder",
            CurveType::Ribbon => "ribbon",
        })
    }
}

/// How a mesh file's triangles are shaded: `"file"` (the default) with the file's vertex
/// normals where it has them and flat where it has none (pbrt-v4's rule); `"smooth"` with the
/// file's normals, or where it has none with normals computed from the faces around each
/// vertex, weighted by their angles there (Mitsuba 3's rule); `"flat"` with each face's own
/// normal, ignoring the file's (Mitsuba's `face_normals`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MeshNormals {
    #[default]
    File,
    Smooth,
    Flat,
}

impl<'de> Deserialize<'de> for MeshNormals {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        match name.as_str() {
            "file" => Ok(MeshNormals::File),
            "smooth" => Ok(MeshNormals::Smooth),
            "flat" => Ok(MeshNormals::Flat),
            _ => Err(de::Error::custom(format!(
                "unknown mesh normals {name:?}; known: \"file\", \"smooth\", \"flat\""
            ))),
        }
    }
}

impl Serialize for MeshNormals {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(match self {
            MeshNormals::File => "file",
            MeshNormals::Smooth => "smooth",
            MeshNormals::Flat => "flat",
        })
    }
}

/// Light emission attached to an entity.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum EmitterDesc {
    /// Emits `radiance` (W sr^-1 m^-2 per channel) from the shape's front side, or both sides,
    /// times `texture` (a colour or a texture over the shape's texture coordinates: Mitsuba's
    /// textured `radiance`) if given; a texture needs a mesh or rectangle.
    Area {
        radiance: V3,
        /// Default: false.
        #[serde(default)]
        two_sided: bool,
        #[serde(skip_serializing_if = "Option::is_none", default)]
        texture: Option<ColorDesc>,
        /// The emission by wavelength, `[(nm, value), ...]` in W sr^-1 m^-2 nm^-1 (linear
        /// between the pairs, zero outside them), times `radiance`, which must then be grey
        /// (a scale). Spectral rendering emits the spectrum; RGB rendering its colour.
        #[serde(skip_serializing_if = "Option::is_none", default)]
        spectrum: Option<Vec<(f64, f64)>>,
    },
    /// Isotropic point light of `intensity` (W/sr per channel) at the entity's translation.
    Point {
        intensity: V3,
        /// The intensity by wavelength, as an area emitter's `spectrum`: times `intensity`,
        /// which must then be grey (a scale).
        #[serde(skip_serializing_if = "Option::is_none", default)]
        spectrum: Option<Vec<(f64, f64)>>,
    },
    /// A spot light at the entity's translation (Mitsuba's `spot`), pointing at `look_at` or,
    /// without it, along the entity's rotated `+z`. `intensity` (W/sr per channel) on the
    /// axis, falling off linearly in the angle from `beam_width` to `cutoff_angle` (degrees).
    /// Defaults: `cutoff_angle: 20`, `beam_width: 3/4 of cutoff_angle`, `falloff: "linear"`.
    Spot {
        intensity: V3,
        #[serde(skip_serializing_if = "Option::is_none")]
        look_at: Option<V3>,
        #[serde(default = "default_cutoff")]
        cutoff_angle: f32,
        #[serde(skip_serializing_if = "Option::is_none")]
        beam_width: Option<f32>,
        /// `"linear"` in the angle (Mitsuba 3's, the default) or `"smoothstep"` in its
        /// cosine (pbrt-v4's).
        #[serde(skip_serializing_if = "Option::is_none", default)]
        falloff: Option<String>,
        /// A texture projected by the spot (Mitsuba's `texture`): the intensity towards a
        /// direction `d` of the spot's frame (its rotated axes) is times the texture at
        /// `u = 1/2 + d.x / (2 d.z tan(cutoff))`, `v = 1/2 + d.y / (2 d.z tan(cutoff))` (a
        /// constant colour just scales it).
        #[serde(skip_serializing_if = "Option::is_none", default)]
        texture: Option<ColorDesc>,
        /// The intensity by wavelength, as an area emitter's `spectrum`: times `intensity`,
        /// which must then be grey (a scale).
        #[serde(skip_serializing_if = "Option::is_none", default)]
        spectrum: Option<Vec<(f64, f64)>>,
    },
    /// Parallel light from infinitely far away (a sun, Mitsuba's `directional`) travelling
    /// along `direction` (turned by the entity's rotation), with `irradiance` (W m^-2 per
    /// channel) on a surface facing it.
    Directional {
        direction: V3,
        irradiance: V3,
        /// The irradiance by wavelength, as an area emitter's `spectrum`: times `irradiance`,
        /// which must then be grey (a scale).
        #[serde(skip_serializing_if = "Option::is_none", default)]
        spectrum: Option<Vec<(f64, f64)>>,
    },
    /// A projector (Mitsuba's `projector`) at the entity's translation, throwing the image
    /// `irradiance` (a colour or a texture) along the entity's rotated `+z` over a field of
    /// view of `fov` degrees along `fov_axis` (`"x"`, the default, `"y"`, `"diagonal"`,
    /// `"smaller"` or `"larger"` side of the image), the image's left edge towards the rotated
    /// `+x`. The irradiance on the plane at distance 1 facing it is `pi scale` times the
    /// image (as Mitsuba's). Default `scale: 1`.
    Projector {
        irradiance: ColorDesc,
        fov: f32,
        #[serde(skip_serializing_if = "Option::is_none", default)]
        fov_axis: Option<String>,
        #[serde(default = "one")]
        scale: f32,
    },
    /// A latitude-longitude environment map (Mitsuba's `envmap`): an EXR, Radiance HDR or
    /// PNG file (8-bit images are decoded from sRGB), `+y` up in the map's frame, turned by
    /// the entity's rotation (rotate `(90, 0, 0)` for a z-up scene), radiance times `scale`.
    /// Default: `scale: 1`.
    Environment {
        path: String,
        #[serde(default = "one")]
        scale: f32,
        /// `"latlong"` (the default) or `"octahedral"`: a square image in pbrt-v4's
        /// equal-area octahedral mapping (`+z` up in its frame, i.e. raylab's map `+y`),
        /// resampled at load into a latitude-longitude map at its nearest pixels.
        #[serde(skip_serializing_if = "Option::is_none", default)]
        mapping: Option<String>,
    },
}

// What a written scene leaves out, being the default.
fn is_false(b: &bool) -> bool {
    !*b
}
fn is_identity(t: &TransformDesc) -> bool {
    *t == TransformDesc::default()
}

fn default_cutoff() -> f32 {
    20.0
}

fn one() -> f32 {
    1.0
}

fn yes() -> bool {
    true
}

fn is_true(b: &bool) -> bool {
    *b
}

fn unit_z() -> V3 {
    [0.0, 0.0, 1.0]
}

impl TableEntry for MediumDesc {
    const KIND: &'static str = "medium";
}
