//! pbrt-v4's participating media: `MakeNamedMedium` (`homogeneous`, `uniformgrid`, `rgbgrid`) as
//! raylab's media, `MediumInterface` in the graphics state, the media shapes bound and the
//! one around the camera.
//!
//! pbrt-v4 looks media up by name when it builds the scene, so a shape may name a medium the
//! file defines further on; the names used are checked once the file is read, each against
//! the `MediumInterface` that gave it. Only the camera's must come before `WorldBegin`.

use super::media_presets::preset;
use super::*;
use crate::formats::pbrt::params::Values;
use crate::formats::schema::{
    GridEdgeDesc, MediumDesc, MediumInterfaceDesc, PhaseDesc, VolumeDesc,
};
use std::collections::HashSet;

/// The media on the two sides of the shapes to come (`MediumInterface`; "" is vacuum) and
/// where they were named.
#[derive(Clone)]
pub(super) struct MediumSides {
    pub inside: String,
    pub outside: String,
    pub at: Pos,
}

impl MediumSides {
    /// Vacuum on both sides, as before any `MediumInterface`.
    pub(super) fn vacuum() -> MediumSides {
        MediumSides {
            inside: String::new(),
            outside: String::new(),
            at: Pos {
                file: 0,
                line: 1,
                col: 1,
            },
        }
    }
}

/// pbrt-v4's render space (`Option "rendercoordsys"`), which a grid medium made before the
/// `Camera` directive is placed in.
#[derive(Clone, Copy, Default, PartialEq)]
pub(super) enum RenderSpace {
    /// The world moved so that the camera is at the origin (pbrt-v4's default).
    #[default]
    CameraWorld,
    Camera,
    World,
}

/// The participating media as the scene defines and uses them.
#[derive(Default)]
pub(super) struct MediaBook {
    /// The media made, by name, in file order.
    pub made: Vec<(String, MediumDesc)>,
    /// Media `--approximate` renders as vacuum (types raylab has no counterpart of).
    vacuum: HashSet<String>,
    /// Each medium name a shape, light or the camera uses, first use first, with the
    /// `MediumInterface` that named it.
    uses: Vec<(String, Pos)>,
    used: HashSet<String>,
    /// The medium around the camera (the outside one at `Camera`) and where it was named.
    pub camera: Option<(String, Pos)>,
    /// The `Null` material of the `interface` shapes that bound a medium, once made.
    null_material: Option<String>,
    /// Grid media made before `Camera`, by index, with the transform then: pbrt-v4 places
    /// them in its render space, known once the camera is.
    before_camera: Vec<(usize, DMat4)>,
    pub render_space: RenderSpace,
}

impl MediaBook {
    fn is_defined(&self, name: &str) -> bool {
        self.vacuum.contains(name) || self.made.iter().any(|(n, _)| n == name)
    }
}

/// A medium's absorption and scattering coefficients, per unit length (RGB).
#[derive(Clone, Copy)]
struct Coefficients {
    sigma_a: [f64; 3],
    sigma_s: [f64; 3],
}

impl Coefficients {
    /// The extinction, `sigma_a + sigma_s`.
    fn sigma_t(&self) -> [f64; 3] {
        std::array::from_fn(|i| self.sigma_a[i] + self.sigma_s[i])
    }

    /// `sigma_s / sigma_t` by channel, 0 where nothing scatters or absorbs.
    fn albedo(&self) -> [f32; 3] {
        let sigma_t = self.sigma_t();
        std::array::from_fn(|i| {
            if sigma_t[i] > 0.0 {
                (self.sigma_s[i] / sigma_t[i]) as f32
            } else {
                0.0
            }
        })
    }
}

/// A grid medium's `density`: its voxels along x, y, z and their values, x fastest.
struct Density {
    size: (u32, u32, u32),
    values: Vec<f32>,
}

/// A grid medium's placement and its box in its own space (min, max).
type GridBox = (TransformDesc, ([f32; 3], [f32; 3]));

/// What an `rgbgrid`'s `Le` is multiplied by: pbrt-v4 leaves its RGB illuminant spectra
/// unnormalised (its other emitters divide by their luminance), so an `Le` of (1, 1, 1) has
/// the luminance of its colour space's illuminant, whose Y integral this is.
const CIE_Y_INTEGRAL: f64 = 106.856895;

/// pbrt-v4 clamps a Henyey-Greenstein `g` into [-0.99, 0.99].
const MAX_PBRT_G: f64 = 0.99;

impl<'a> Converter<'a> {
    /// `MakeNamedMedium "name" "string type" ...`.
    pub(super) fn make_named_medium(&mut self, d: &mut Directive) -> Result<(), Located> {
        let name = d.strings[0].clone();
        if self.media.is_defined(&name) {
            return Err((
                d.pos,
                format!("MakeNamedMedium: \"{name}\" is defined twice"),
            ));
        }
        let mut p = self.params(d)?;
        let kind = p.string("type")?.ok_or_else(|| {
            (
                d.pos,
                format!("MakeNamedMedium \"{name}\" needs \"string type\""),
            )
        })?;
        let medium = match kind.as_str() {
            "homogeneous" => self.homogeneous(&mut p)?,
            "uniformgrid" => self.uniform_grid(&mut p)?,
            "rgbgrid" => self.rgb_grid(&mut p)?,
            "cloud" | "nanovdb" => {
                self.approximate(
                    d.pos,
                    format!("MakeNamedMedium \"{name}\": a `{kind}` medium is not supported (homogeneous, uniformgrid and rgbgrid are): rendered as vacuum"),
                )?;
                // Its parameters are pbrt-v4's to check.
                self.media.vacuum.insert(name);
                return Ok(());
            }
            other => {
                let hint = if other == "heterogeneous" {
                    " (pbrt-v3's `heterogeneous` is pbrt-v4's `uniformgrid`)"
                } else {
                    ""
                };
                return Err((
                    d.pos,
                    format!("MakeNamedMedium \"{name}\": `{other}` is not a pbrt-v4 medium (homogeneous, uniformgrid, rgbgrid, cloud, nanovdb are){hint}"),
                ));
            }
        };
        p.finish()?;
        if matches!(medium, MediumDesc::Heterogeneous { .. })
            && !self.world
            && self.camera.is_none()
        {
            self.media
                .before_camera
                .push((self.media.made.len(), self.state.ctm));
        }
        self.media.made.push((name, medium));
        Ok(())
    }

    /// pbrt-v4's `homogeneous`: `sigma_a` and `sigma_s` (1 each unless given, or a `preset`),
    /// `scale`, `g`, and the emission `Le` times `Lescale`.
    fn homogeneous(&mut self, p: &mut ParamList) -> Result<MediumDesc, Located> {
        let coefficients = match self.preset(p)? {
            Some(found) => found,
            None => self.coefficients(p)?,
        };
        let scale = self.sigma_scale(p)?;
        let phase = self.phase(p)?;
        let le_scale = p.float("Lescale")?.unwrap_or(1.0);
        let le = self.emitted_rgb(p, "Le")?.unwrap_or([0.0; 3]);
        if le.iter().any(|x| *x < 0.0) || le_scale < 0.0 {
            return Err((
                p.at,
                format!("{}: negative emission (`Le`, `Lescale`)", p.what),
            ));
        }
        Ok(MediumDesc::Homogeneous {
            sigma_t: coefficients.sigma_t().map(|x| x as f32),
            albedo: coefficients.albedo(),
            scale: scale as f32,
            phase,
            emission: le.map(|x| (x * le_scale) as f32),
        })
    }

    /// A `preset`'s coefficients (which take the place of `sigma_a` and `sigma_s`), if one
    /// is named and pbrt-v4 has it.
    fn preset(&mut self, p: &mut ParamList) -> Result<Option<Coefficients>, Located> {
        let Some((name, pos)) = p.string_at("preset")? else {
            return Ok(None);
        };
        let Some(found) = preset(&name) else {
            self.approximate(
                pos,
                format!("{}: preset \"{name}\" is not one of pbrt-v4's (it warns and uses sigma_a and sigma_s, as raylab then does)", p.what),
            )?;
            return Ok(None);
        };
        for given in ["sigma_a", "sigma_s"] {
            if let Some(at) = p.present(given) {
                return Err((
                    at,
                    format!(
                        "{}: `{given}` is not read with a `preset` (pbrt-v4 reports it unused)",
                        p.what
                    ),
                ));
            }
        }
        Ok(Some(Coefficients {
            sigma_a: found.sigma_a,
            sigma_s: found.sigma_prime_s,
        }))
    }

    /// `sigma_a` and `sigma_s`, 1 where not given (pbrt-v4's defaults).
    fn coefficients(&mut self, p: &mut ParamList) -> Result<Coefficients, Located> {
        let sigma_a = self.coefficient(p, "sigma_a")?;
        let sigma_s = self.coefficient(p, "sigma_s")?;
        Ok(Coefficients { sigma_a, sigma_s })
    }

    /// One coefficient (per unit length of the scene): an RGB, a number, or (with
    /// `--approximate`) a spectrum's RGB; 1 if absent.
    fn coefficient(&mut self, p: &mut ParamList, name: &str) -> Result<[f64; 3], Located> {
        let Some((c, pos)) = p.colour(name)? else {
            return Ok([1.0; 3]);
        };
        let what = format!("{}: `{name}`", p.what);
        let rgb = match &c {
            Colour::Rgb(rgb) => *rgb,
            Colour::Texture(t) => {
                return Err((pos, format!("{what} cannot be a texture (\"{t}\")")))
            }
            // A spectrum: its RGB, as a material's colour is made.
            _ => {
                let textures = std::mem::take(&mut self.textures);
                let made = materials::colour(&c, pos, &what, &textures, self);
                self.textures = textures;
                match made? {
                    ColorDesc::Constant(rgb) => rgb.map(f64::from),
                    _ => return Err((pos, format!("{what} must be a constant"))),
                }
            }
        };
        if rgb.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err((pos, format!("{what} must not be negative")));
        }
        Ok(rgb)
    }

    /// `scale`, which multiplies `sigma_a` and `sigma_s`.
    fn sigma_scale(&mut self, p: &mut ParamList) -> Result<f64, Located> {
        match p.float("scale")? {
            None => Ok(1.0),
            Some(s) if s >= 0.0 => Ok(s),
            Some(s) => Err((
                p.present("scale").unwrap_or(p.at),
                format!("{}: `scale` {s} is negative", p.what),
            )),
        }
    }

    /// The phase function of `g`, clamped into [-0.99, 0.99] as pbrt-v4 clamps it.
    fn phase(&mut self, p: &mut ParamList) -> Result<PhaseDesc, Located> {
        let g = p.float("g")?.unwrap_or(0.0);
        let clamped = g.clamp(-MAX_PBRT_G, MAX_PBRT_G);
        if clamped != g {
            self.report(format!(
                "{}: `g` {g} clamped to {clamped}, as pbrt-v4 clamps it",
                p.what
            ));
        }
        Ok(if clamped == 0.0 {
            PhaseDesc::Isotropic
        } else {
            PhaseDesc::HenyeyGreenstein(clamped as f32)
        })
    }

    /// pbrt-v4's `uniformgrid`: `density` on an `nx` x `ny` x `nz` grid (x fastest) over the
    /// box `p0`..`p1` of the medium's space (placed by the transform at the directive), times
    /// `scale (sigma_a + sigma_s)`, zero past the outermost voxel centres as pbrt-v4 reads it;
    /// emission `Le` times a grid of `Lescale`.
    fn uniform_grid(&mut self, p: &mut ParamList) -> Result<MediumDesc, Located> {
        let density = self.density_grid(p)?;
        let (emission, emission_grid) = self.grid_emission(p, density.size)?;
        let coefficients = self.coefficients(p)?;
        let scale = self.sigma_scale(p)?;
        let phase = self.phase(p)?;
        let (transform, bounds) = self.grid_box(p)?;
        // The extinction's colour: folded into `scale` when grey, else a tint.
        let sigma_t = coefficients.sigma_t();
        let (scale, tint) = if sigma_t[0] == sigma_t[1] && sigma_t[1] == sigma_t[2] {
            (scale * sigma_t[0], [1.0; 3])
        } else {
            (scale, sigma_t)
        };
        Ok(MediumDesc::Heterogeneous {
            sigma_t: Some(VolumeDesc::Values {
                size: density.size,
                values: density.values,
                edge: GridEdgeDesc::Zero,
            }),
            albedo: Some(VolumeDesc::Constant(coefficients.albedo())),
            sigma_a: None,
            sigma_s: None,
            scale: scale as f32,
            tint: tint.map(|x| x as f32),
            phase,
            emission,
            emission_grid,
            transform,
            bounds,
        })
    }

    /// pbrt-v4's `rgbgrid`: `sigma_a` and `sigma_s` each an RGB grid (1 everywhere where one
    /// is not given) times `scale`, over the box `p0`..`p1` as `uniformgrid`'s, and an RGB
    /// emission grid `Le` times `Lescale`.
    fn rgb_grid(&mut self, p: &mut ParamList) -> Result<MediumDesc, Located> {
        let what = p.what.clone();
        let sigma_a = p.numbers("sigma_a", &["rgb", "color"])?;
        let sigma_s = p.numbers("sigma_s", &["rgb", "color"])?;
        let le = p.numbers("Le", &["rgb", "color"])?;
        if sigma_a.is_none() && sigma_s.is_none() {
            return Err((
                p.at,
                format!("{what} needs `sigma_a` or `sigma_s` (or both)"),
            ));
        }
        if let (Some((_, at)), None) = (&le, &sigma_a) {
            return Err((*at, format!("{what}: `Le` needs `sigma_a`")));
        }
        let size = self.grid_size(p)?;
        let voxels = u64::from(size.0) * u64::from(size.1) * u64::from(size.2);
        for (name, given) in [("sigma_a", &sigma_a), ("sigma_s", &sigma_s), ("Le", &le)] {
            if let Some((v, at)) = given {
                if v.len() as u64 != 3 * voxels {
                    return Err((
                        *at,
                        format!(
                            "{what}: {} `{name}` RGB values for a grid of {} x {} x {} = {voxels}",
                            v.len() as f64 / 3.0,
                            size.0,
                            size.1,
                            size.2
                        ),
                    ));
                }
                if let Some(bad) = v.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                    return Err((*at, format!("{what}: a negative `{name}` {bad}")));
                }
            }
        }
        let le_scale = p.float("Lescale")?.unwrap_or(1.0);
        if le_scale.is_nan() || le_scale < 0.0 {
            return Err((
                p.present("Lescale").unwrap_or(p.at),
                format!("{what}: `Lescale` {le_scale} is negative"),
            ));
        }
        let scale = self.sigma_scale(p)?;
        let phase = self.phase(p)?;
        let (transform, bounds) = self.grid_box(p)?;
        let grid = |given: Option<(Vec<f64>, Pos)>| {
            given.map(|(v, _)| VolumeDesc::Values {
                size,
                values: v.iter().map(|x| *x as f32).collect(),
                edge: GridEdgeDesc::Zero,
            })
        };
        let emission = match le {
            Some(_) if le_scale > 0.0 => {
                self.report(format!("{what}: `Le` taken as pbrt-v4 takes it, unnormalised: {CIE_Y_INTEGRAL} times the radiance a homogeneous medium's `Le` of the same RGB gives"));
                [(le_scale * CIE_Y_INTEGRAL) as f32; 3]
            }
            _ => [0.0; 3],
        };
        let one = || VolumeDesc::Constant([1.0; 3]);
        Ok(MediumDesc::Heterogeneous {
            sigma_t: None,
            albedo: None,
            sigma_a: Some(grid(sigma_a).unwrap_or_else(one)),
            sigma_s: Some(grid(sigma_s).unwrap_or_else(one)),
            scale: scale as f32,
            tint: [1.0; 3],
            phase,
            emission,
            emission_grid: grid(le).filter(|_| emission != [0.0; 3]),
            transform,
            bounds,
        })
    }

    /// A grid medium's box `p0`..`p1` (default the unit cube) and the transform at the
    /// directive that places it.
    fn grid_box(&mut self, p: &mut ParamList) -> Result<GridBox, Located> {
        let what = p.what.clone();
        let p0 = p.point("p0")?.unwrap_or([0.0; 3]);
        let p1 = p.point("p1")?.unwrap_or([1.0; 3]);
        let lo: [f64; 3] = std::array::from_fn(|i| p0[i].min(p1[i]));
        let hi: [f64; 3] = std::array::from_fn(|i| p0[i].max(p1[i]));
        if (0..3).any(|i| lo[i] == hi[i]) {
            return Err((p.at, format!("{what}: p0 and p1 bound no volume")));
        }
        let placed_by = affine(&self.state.ctm)
            .ok_or_else(|| (p.at, format!("{what}: a projective transform")))?;
        let transform = if placed_by == Affine3A::IDENTITY {
            TransformDesc::default()
        } else {
            placed(&placed_by)
        };
        Ok((transform, (lo.map(|x| x as f32), hi.map(|x| x as f32))))
    }

    /// A grid's `nx`, `ny`, `nz` (1 each unless given).
    fn grid_size(&mut self, p: &mut ParamList) -> Result<(u32, u32, u32), Located> {
        let what = p.what.clone();
        let mut size = [1u32; 3];
        for (axis, name) in ["nx", "ny", "nz"].iter().enumerate() {
            let n = p.integer(name)?.unwrap_or(1);
            size[axis] = u32::try_from(n).ok().filter(|n| *n > 0).ok_or_else(|| {
                (
                    p.present(name).unwrap_or(p.at),
                    format!("{what}: `{name}` {n} must be 1 or more"),
                )
            })?;
        }
        Ok((size[0], size[1], size[2]))
    }

    /// A grid's `density` values and their `nx`, `ny`, `nz`.
    fn density_grid(&mut self, p: &mut ParamList) -> Result<Density, Located> {
        let what = p.what.clone();
        let (values, at) = p
            .numbers("density", &["float"])?
            .ok_or_else(|| (p.at, format!("{what} needs \"float density\"")))?;
        let size = self.grid_size(p)?;
        let voxels = u64::from(size.0) * u64::from(size.1) * u64::from(size.2);
        if voxels != values.len() as u64 {
            return Err((
                at,
                format!(
                    "{what}: {} density values for a grid of {} x {} x {} = {voxels}",
                    values.len(),
                    size.0,
                    size.1,
                    size.2
                ),
            ));
        }
        if let Some(bad) = values.iter().find(|v| **v < 0.0) {
            return Err((at, format!("{what}: a negative density {bad}")));
        }
        Ok(Density {
            size,
            values: values.iter().map(|v| *v as f32).collect(),
        })
    }

    /// A `uniformgrid`'s emission: `Le` times a grid of `Lescale` (over the density's
    /// `size`), as pbrt-v4 renders it; without a `Lescale` grid pbrt-v4 multiplies by a grid
    /// of one voxel of 1, which fades from the box's centre to half at its faces (an eighth at
    /// its corners), and so does raylab. A `temperature` grid (blackbody emission) is left out
    /// with `--approximate`.
    fn grid_emission(
        &mut self,
        p: &mut ParamList,
        size: (u32, u32, u32),
    ) -> Result<([f32; 3], Option<VolumeDesc>), Located> {
        let what = p.what.clone();
        let voxels = u64::from(size.0) * u64::from(size.1) * u64::from(size.2);
        let le = self.emitted_rgb(p, "Le")?;
        let temperature = p.numbers("temperature", &["float"])?;
        if let (Some(_), Some((_, at))) = (le, &temperature) {
            return Err((
                *at,
                format!("{what}: both `Le` and `temperature` are given"),
            ));
        }
        let le_scale = p.numbers("Lescale", &["float"])?;
        for (name, given) in [("temperature", &temperature), ("Lescale", &le_scale)] {
            if let Some((v, at)) = given {
                if v.len() as u64 != voxels {
                    return Err((
                        *at,
                        format!("{what}: {} `{name}` values for {voxels} voxels", v.len()),
                    ));
                }
            }
        }
        p.ignore(&["temperatureoffset", "temperaturecutoff", "temperaturescale"]);
        if temperature.is_some() {
            self.approximate(
                p.at,
                format!("{what}: the blackbody emission of a `temperature` grid is not supported: left out"),
            )?;
            return Ok(([0.0; 3], None));
        }
        let Some(le) = le.filter(|c| c.iter().any(|x| *x != 0.0)) else {
            return Ok(([0.0; 3], None));
        };
        if le.iter().any(|x| *x < 0.0) {
            return Err((p.at, format!("{what}: a negative `Le`")));
        }
        let (size, values) = match le_scale {
            Some((v, at)) => {
                if let Some(bad) = v.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                    return Err((at, format!("{what}: a negative `Lescale` {bad}")));
                }
                (size, v.iter().map(|x| *x as f32).collect())
            }
            None => ((1, 1, 1), vec![1.0]),
        };
        Ok((
            le.map(|x| x as f32),
            Some(VolumeDesc::Values {
                size,
                values,
                edge: GridEdgeDesc::Zero,
            }),
        ))
    }

    /// `Option "string rendercoordsys"`: pbrt-v4's render space, which places grid media
    /// made before `Camera`.
    pub(super) fn render_space(&mut self, d: &Directive) -> Result<(), Located> {
        let value = match d.params.first().map(|p| &p.values) {
            Some(Values::Strs(v)) if v.len() == 1 => v[0].clone(),
            _ => return Err((d.pos, "Option rendercoordsys takes one string".into())),
        };
        self.media.render_space = match value.as_str() {
            "cameraworld" => RenderSpace::CameraWorld,
            "camera" => RenderSpace::Camera,
            "world" => RenderSpace::World,
            other => {
                return Err((
                    d.pos,
                    format!("Option rendercoordsys: `{other}` is not camera, cameraworld or world"),
                ))
            }
        };
        self.report(format!("Option rendercoordsys \"{value}\": places grid media made before Camera, as pbrt-v4 does; the image is the same"));
        Ok(())
    }

    /// `MediumInterface "inside" "outside"` (one name: both sides).
    pub(super) fn medium_interface(&mut self, d: &Directive) {
        let inside = d.strings[0].clone();
        let outside = d.strings.get(1).cloned().unwrap_or_else(|| inside.clone());
        self.state.medium = MediumSides {
            inside,
            outside,
            at: d.pos,
        };
    }

    /// Notes `name` as used (checked once the file is read).
    fn use_medium(&mut self, name: &str, at: Pos) {
        if !name.is_empty() && self.media.used.insert(name.to_string()) {
            self.media.uses.push((name.to_string(), at));
        }
    }

    /// The media a shape made now bounds: `None` unless its two sides differ (pbrt-v4's
    /// `IsMediumTransition`; rays crossing it keep their medium).
    pub(super) fn shape_media(&mut self) -> Option<MediumInterfaceDesc> {
        let sides = self.state.medium.clone();
        self.use_medium(&sides.inside, sides.at);
        self.use_medium(&sides.outside, sides.at);
        if sides.inside == sides.outside {
            return None;
        }
        let side = |name: String| (!name.is_empty()).then_some(name);
        Some(MediumInterfaceDesc {
            inside: side(sides.inside),
            outside: side(sides.outside),
        })
    }

    /// A light's medium (the outside one), which pbrt-v4 looks up.
    pub(super) fn note_light_medium(&mut self) {
        let sides = self.state.medium.clone();
        self.use_medium(&sides.outside, sides.at);
    }

    /// At `Camera`: the camera sits in the outside medium, and grid media made before it are
    /// placed from pbrt-v4's render space into the world.
    pub(super) fn camera_media(
        &mut self,
        world_from_camera: DMat4,
        pos: Pos,
    ) -> Result<(), Located> {
        let sides = self.state.medium.clone();
        self.media.camera = (!sides.outside.is_empty()).then(|| (sides.outside.clone(), sides.at));
        self.use_medium(&sides.outside, sides.at);
        let world_from_render = match self.media.render_space {
            RenderSpace::CameraWorld => {
                DMat4::from_translation(world_from_camera.transform_point3(DVec3::ZERO))
            }
            RenderSpace::Camera => world_from_camera,
            RenderSpace::World => DMat4::IDENTITY,
        };
        for (index, ctm) in std::mem::take(&mut self.media.before_camera) {
            let placed_by = affine(&(world_from_render * ctm))
                .ok_or_else(|| (pos, "Camera: a projective transform".to_string()))?;
            if let Some((_, MediumDesc::Heterogeneous { transform, .. })) =
                self.media.made.get_mut(index)
            {
                *transform = placed(&placed_by);
            }
        }
        Ok(())
    }

    /// At `WorldBegin`: pbrt-v4 needs the camera's medium defined by then.
    pub(super) fn check_camera_medium(&self) -> Result<(), Located> {
        match &self.media.camera {
            Some((name, at)) if !self.media.is_defined(name) => Err((
                *at,
                format!("MediumInterface: the camera's medium \"{name}\" is not defined before WorldBegin (MakeNamedMedium must come before)"),
            )),
            _ => Ok(()),
        }
    }

    /// The `Null` material of a shape with the `interface` material that bounds a medium
    /// (made once); `None` where it bounds none, and the shape is left out (with
    /// `--approximate`). An area light on it is dropped, as pbrt-v4 drops it.
    pub(super) fn interface_material(
        &mut self,
        pos: Pos,
        what: &str,
        bounds_medium: bool,
        alpha: bool,
    ) -> Result<Option<String>, Located> {
        if self.state.area.is_some() {
            self.report(format!("{what}: the area light on a shape with the `interface` material ignored, as pbrt-v4 ignores it"));
        }
        if !bounds_medium {
            self.approximate(
                pos,
                format!(
                    "{what}: a shape with the `interface` material (a medium's boundary) left out"
                ),
            )?;
            return Ok(None);
        }
        if alpha {
            self.approximate(
                pos,
                format!("{what}: `alpha` on a medium's boundary ignored"),
            )?;
        }
        if let Some(name) = &self.media.null_material {
            return Ok(Some(name.clone()));
        }
        let name = self.add_material("interface", MaterialDesc::Null);
        self.media.null_material = Some(name.clone());
        Ok(Some(name))
    }

    /// Once the file is read: every medium used is defined; media rendered as vacuum
    /// (`--approximate`) are left out of the interfaces; emission takes the exposure.
    pub(super) fn finish_media(&mut self) -> Result<(), Located> {
        if let Some((name, at)) = self
            .media
            .uses
            .iter()
            .find(|(n, _)| !self.media.is_defined(n))
        {
            return Err((
                *at,
                format!("MediumInterface: no medium is named \"{name}\" (MakeNamedMedium defines media)"),
            ));
        }
        let vacuum = std::mem::take(&mut self.media.vacuum);
        if !vacuum.is_empty() {
            let keep = |side: &mut Option<String>| {
                if side.as_ref().is_some_and(|n| vacuum.contains(n)) {
                    *side = None;
                }
            };
            for e in &mut self.entities {
                if let Some(m) = &mut e.medium {
                    keep(&mut m.inside);
                    keep(&mut m.outside);
                    if m.inside == m.outside {
                        e.medium = None;
                    }
                }
            }
            if self
                .media
                .camera
                .as_ref()
                .is_some_and(|(n, _)| vacuum.contains(n))
            {
                self.media.camera = None;
            }
        }
        let exposure = self.exposure as f32;
        for (_, m) in &mut self.media.made {
            let (MediumDesc::Homogeneous { emission, .. }
            | MediumDesc::Heterogeneous { emission, .. }) = m;
            *emission = emission.map(|x| x * exposure);
        }
        Ok(())
    }
}
