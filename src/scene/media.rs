//! Participating media loaded: the scene file's `media` table made into the integrators'
//! [`Medium`]s (grid files read through the scene's files), and the names entities and the
//! camera give resolved to them.

use super::describe::transform_from_desc;
use crate::formats::access::SceneFiles;
use crate::formats::schema::{
    GridEdgeDesc, MediumDesc, MediumInterfaceDesc, MediumTable, PhaseDesc, SceneFile, VolumeDesc,
    V3,
};
use glam::{Affine3A, Vec3, Vec3A};
use raylab_integrators::medium::{
    Coefficients, DensityGrid, GridEdge, Heterogeneous, Homogeneous, Volume,
};
use raylab_integrators::{Medium, MediumId, MediumInterface, Phase, Rgb};
use std::sync::Arc;

/// The scene's media, in file order, and their names.
#[derive(Clone, Debug)]
pub struct Media {
    pub media: Vec<Medium>,
    pub names: Vec<String>,
    /// The medium around the camera.
    pub camera: MediumId,
}

impl Default for Media {
    /// No media; the camera in vacuum.
    fn default() -> Self {
        Media {
            media: Vec::new(),
            names: Vec::new(),
            camera: MediumId::VACUUM,
        }
    }
}

impl Media {
    /// The media `file` describes, each named in its errors, and the camera's.
    pub fn from_file(file: &SceneFile, files: &SceneFiles) -> Result<Media, String> {
        let (media, names) = media_from_table(&file.media, files)?;
        let mut out = Media {
            media,
            names,
            camera: MediumId::VACUUM,
        };
        if let Some(name) = &file.camera_medium {
            out.camera = out.id(name).map_err(|e| format!("`camera_medium`: {e}"))?;
        }
        Ok(out)
    }

    /// The medium named `name`.
    pub fn id(&self, name: &str) -> Result<MediumId, String> {
        match self.names.iter().position(|n| n == name) {
            Some(i) => Ok(MediumId(i as u32)),
            None if self.names.is_empty() => Err(format!(
                "no medium `{name}`: the scene defines no media (`media`)"
            )),
            None => Err(format!(
                "no medium `{name}`; defined media: {}",
                self.names.join(", ")
            )),
        }
    }

    /// The interface an entity's `medium` describes: each side named, vacuum where left out.
    pub fn interface(&self, desc: &MediumInterfaceDesc) -> Result<MediumInterface, String> {
        let side = |name: &Option<String>, which: &str| match name {
            None => Ok(MediumId::VACUUM),
            Some(n) => self.id(n).map_err(|e| format!("`medium` {which}: {e}")),
        };
        Ok(MediumInterface {
            inside: side(&desc.inside, "inside")?,
            outside: side(&desc.outside, "outside")?,
        })
    }
}

/// Every medium of `table`, in file order, with its name.
fn media_from_table(
    table: &MediumTable,
    files: &SceneFiles,
) -> Result<(Vec<Medium>, Vec<String>), String> {
    let mut media = Vec::with_capacity(table.0.len());
    let mut names = Vec::with_capacity(table.0.len());
    for (name, desc) in &table.0 {
        let medium = medium_from_desc(desc, files).map_err(|e| format!("medium `{name}`: {e}"))?;
        media.push(medium);
        names.push(name.clone());
    }
    Ok((media, names))
}

fn rgb(v: V3) -> Rgb {
    Vec3A::from_array(v)
}

/// `v` if each component is finite and non-negative.
fn non_negative(what: &str, v: V3) -> Result<Rgb, String> {
    if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
        Ok(rgb(v))
    } else {
        Err(format!(
            "`{what}` must be finite and non-negative, not {v:?}"
        ))
    }
}

fn phase_from_desc(desc: PhaseDesc) -> Result<Phase, String> {
    match desc {
        PhaseDesc::Isotropic => Ok(Phase::Isotropic),
        PhaseDesc::HenyeyGreenstein(g) => Phase::henyey_greenstein(g),
    }
}

/// One medium.
pub fn medium_from_desc(desc: &MediumDesc, files: &SceneFiles) -> Result<Medium, String> {
    match desc {
        MediumDesc::Homogeneous {
            sigma_t,
            albedo,
            scale,
            phase,
            emission,
        } => {
            let scale = check_scale(*scale)?;
            Ok(Medium::Homogeneous(Homogeneous::new(
                non_negative("sigma_t", *sigma_t)? * scale,
                albedo_of(*albedo)?,
                non_negative("emission", *emission)?,
                phase_from_desc(*phase)?,
            )))
        }
        MediumDesc::Heterogeneous {
            sigma_t,
            albedo,
            sigma_a,
            sigma_s,
            scale,
            tint,
            phase,
            emission,
            emission_grid,
            transform,
            bounds,
        } => {
            let scale = check_scale(*scale)?;
            let tint = non_negative("tint", *tint)?;
            let (lo, hi) = (Vec3::from_array(bounds.0), Vec3::from_array(bounds.1));
            if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
                return Err(format!(
                    "`bounds` must be a box with min below max on each axis, not {bounds:?}"
                ));
            }
            let placement = transform_from_desc(transform)
                .map_err(|e| format!("`transform`: {e}"))?
                .matrix();
            let det = placement.matrix3.determinant();
            if det == 0.0 || !det.is_finite() {
                return Err("`transform` is singular".into());
            }
            // World to the unit cube of the box: the inverse placement, then the box's own
            // corner to the origin and its size to 1.
            let to_unit = Affine3A::from_scale((hi - lo).recip())
                * Affine3A::from_translation(-lo)
                * placement.inverse();
            let volume =
                |what: &str, desc: &VolumeDesc| volume_from_desc(what, desc, to_unit, files);
            let coefficients = match (sigma_t, albedo, sigma_a, sigma_s) {
                (Some(sigma_t), Some(albedo), None, None) => {
                    let albedo = volume("albedo", albedo)?;
                    if albedo.max().max_element() > 1.0 + 1e-4 {
                        return Err(format!(
                            "`albedo` must lie in [0, 1]; its largest value is {}",
                            albedo.max().max_element()
                        ));
                    }
                    Coefficients::Albedo {
                        sigma_t: volume("sigma_t", sigma_t)?.scaled(tint * scale),
                        albedo,
                    }
                }
                (None, None, Some(sigma_a), Some(sigma_s)) => Coefficients::Separate {
                    sigma_a: volume("sigma_a", sigma_a)?.scaled(tint * scale),
                    sigma_s: volume("sigma_s", sigma_s)?.scaled(tint * scale),
                },
                _ => {
                    return Err(
                        "give `sigma_t` and `albedo`, or `sigma_a` and `sigma_s` (not a mix)"
                            .into(),
                    )
                }
            };
            let emission = non_negative("emission", *emission)?;
            let le = match emission_grid {
                None => Volume::Constant(emission),
                Some(grid) => volume("emission_grid", grid)?.scaled(emission),
            };
            Ok(Medium::Heterogeneous(Box::new(Heterogeneous::new(
                coefficients,
                le,
                phase_from_desc(*phase)?,
                Some(to_unit),
            ))))
        }
    }
}

fn check_scale(scale: f32) -> Result<f32, String> {
    if scale.is_finite() && scale >= 0.0 {
        Ok(scale)
    } else {
        Err(format!(
            "`scale` must be finite and non-negative, not {scale}"
        ))
    }
}

fn albedo_of(albedo: V3) -> Result<Rgb, String> {
    let a = non_negative("albedo", albedo)?;
    if a.max_element() > 1.0 {
        return Err(format!("`albedo` must lie in [0, 1], not {albedo:?}"));
    }
    Ok(a)
}

/// A volume of `what`, filling the box `to_unit` maps to the unit cube.
fn volume_from_desc(
    what: &str,
    desc: &VolumeDesc,
    to_unit: Affine3A,
    files: &SceneFiles,
) -> Result<Volume, String> {
    let grid = match desc {
        VolumeDesc::Constant(c) => return Ok(Volume::Constant(non_negative(what, *c)?)),
        VolumeDesc::Grid(path) => {
            let g = crate::formats::volume_grid::load_volume_grid(&files.named(path)?)?;
            DensityGrid::new(g.resolution, g.channels, g.values)
                .map_err(|e| format!("`{what}` grid `{path}`: {e}"))?
        }
        VolumeDesc::Values { size, values, edge } => {
            let size = [size.0 as usize, size.1 as usize, size.2 as usize];
            let voxels = size.iter().fold(1usize, |n, s| n.saturating_mul(*s));
            // One value a voxel, or an RGB.
            let channels = if values.len() == voxels.saturating_mul(3) {
                3
            } else {
                1
            };
            DensityGrid::new(size, channels, values.clone())
                .map_err(|e| format!("`{what}`: {e}"))?
                .with_edge(match edge {
                    GridEdgeDesc::Clamp => GridEdge::Clamp,
                    GridEdgeDesc::Zero => GridEdge::Zero,
                })
        }
    };
    Ok(Volume::Grid {
        grid: Arc::new(grid),
        to_local: to_unit,
        scale: Rgb::ONE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::schema::TransformDesc;
    use std::path::Path;

    fn grid_medium(edge: GridEdgeDesc, tint: V3) -> Medium {
        let desc = MediumDesc::Heterogeneous {
            sigma_t: Some(VolumeDesc::Values {
                size: (2, 1, 1),
                values: vec![1.0, 3.0],
                edge,
            }),
            albedo: Some(VolumeDesc::Constant([0.5; 3])),
            sigma_a: None,
            sigma_s: None,
            scale: 2.0,
            tint,
            phase: PhaseDesc::Isotropic,
            emission: [0.0; 3],
            emission_grid: None,
            transform: TransformDesc::default(),
            // The box [0, 2] x [0, 1] x [0, 1].
            bounds: ([0.0; 3], [2.0, 1.0, 1.0]),
        };
        let files = SceneFiles::new(Path::new("scene.ron"), &[]);
        medium_from_desc(&desc, &files).unwrap()
    }

    /// A grid's extinction is its values times `scale` times `tint`, channel by channel;
    /// `edge: Zero` fades it to half the edge voxel's at the box's faces where `Clamp` holds.
    #[test]
    fn grid_extinction_takes_the_tint_and_the_edge() {
        let sigma_t = |m: &Medium, x: f32| {
            let p = m.at(Vec3A::new(x, 0.5, 0.5), &Default::default());
            raylab_integrators::spectrum::rgb_of(p.sigma_a + p.sigma_s)
        };
        let clamp = grid_medium(GridEdgeDesc::Clamp, [1.0, 0.5, 0.25]);
        let zero = grid_medium(GridEdgeDesc::Zero, [1.0, 0.5, 0.25]);
        // Voxel centres at x = 0.5 and 1.5.
        assert_eq!(sigma_t(&clamp, 0.5), Rgb::new(2.0, 1.0, 0.5));
        assert_eq!(sigma_t(&zero, 1.5), Rgb::new(6.0, 3.0, 1.5));
        assert_eq!(sigma_t(&clamp, 0.0), Rgb::new(2.0, 1.0, 0.5));
        assert_eq!(sigma_t(&zero, 0.0), Rgb::new(1.0, 0.5, 0.25));
        assert_eq!(sigma_t(&zero, 2.0), Rgb::new(3.0, 1.5, 0.75));
        let white = grid_medium(GridEdgeDesc::Clamp, [1.0; 3]);
        assert_eq!(sigma_t(&white, 1.0), Rgb::splat(4.0));
    }

    #[test]
    fn a_negative_tint_is_refused() {
        let desc = MediumDesc::Heterogeneous {
            sigma_t: Some(VolumeDesc::Constant([1.0; 3])),
            albedo: Some(VolumeDesc::Constant([0.5; 3])),
            sigma_a: None,
            sigma_s: None,
            scale: 1.0,
            tint: [1.0, -1.0, 1.0],
            phase: PhaseDesc::Isotropic,
            emission: [0.0; 3],
            emission_grid: None,
            transform: TransformDesc::default(),
            bounds: ([0.0; 3], [1.0; 3]),
        };
        let files = SceneFiles::new(Path::new("scene.ron"), &[]);
        let err = medium_from_desc(&desc, &files).unwrap_err();
        assert!(err.contains("`tint`"), "{err}");
    }

    /// The coefficients come as `sigma_t` and `albedo` or as `sigma_a` and `sigma_s`; a mix,
    /// or a pair left half given, is refused by name.
    #[test]
    fn coefficients_come_in_one_pair_or_the_other() {
        let files = SceneFiles::new(Path::new("scene.ron"), &[]);
        let constant = |v: f32| Some(VolumeDesc::Constant([v; 3]));
        let medium = |sigma_t, albedo, sigma_a, sigma_s| MediumDesc::Heterogeneous {
            sigma_t,
            albedo,
            sigma_a,
            sigma_s,
            scale: 2.0,
            tint: [1.0; 3],
            phase: PhaseDesc::Isotropic,
            emission: [3.0; 3],
            emission_grid: Some(VolumeDesc::Values {
                size: (1, 1, 2),
                values: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                edge: GridEdgeDesc::Clamp,
            }),
            transform: TransformDesc::default(),
            bounds: ([0.0; 3], [1.0; 3]),
        };
        let separate =
            medium_from_desc(&medium(None, None, constant(0.25), constant(0.5)), &files).unwrap();
        let p = separate.at(Vec3A::new(0.5, 0.5, 0.25), &Default::default());
        let rgb = raylab_integrators::spectrum::rgb_of;
        assert_eq!(
            (rgb(p.sigma_a), rgb(p.sigma_s)),
            (Rgb::splat(0.5), Rgb::splat(1.0))
        );
        // An RGB grid of emission, times `emission`.
        assert_eq!(rgb(p.le), Rgb::new(3.0, 6.0, 9.0));
        for (t, a, sa, ss) in [
            (constant(1.0), None, None, constant(1.0)),
            (constant(1.0), constant(0.5), constant(1.0), None),
            (None, None, constant(1.0), None),
        ] {
            let err = medium_from_desc(&medium(t, a, sa, ss), &files).unwrap_err();
            assert!(
                err.contains("give `sigma_t` and `albedo`, or `sigma_a` and `sigma_s`"),
                "{err}"
            );
        }
    }
}
