//! The scene description made into components: a camera, a transform, a shape (reading its
//! mesh file), an emitter (reading an environment map), each checked, with the error naming
//! what is wrong. Loading a file ([`super::load`]) and applying an edit ([`super::edit`]) both
//! make their components here.

use super::components::{Emitter, LocalCurveSegment, Shape, Transform};
use super::error::finite;
use crate::accel::CurveKind;
use crate::formats::access::SceneFiles;
use crate::formats::mesh_files;
use crate::formats::schema::{
    CameraDesc, CurveDesc, CurveType, EmitterDesc, RenderDesc, ShapeDesc,
};
use crate::formats::spectra::Use;
use crate::formats::texture_desc::{narrow, ColorDesc};
use glam::{Vec3, Vec3A};
use raylab_integrators::light::EnvMap;
use raylab_integrators::registry;
use raylab_integrators::spectrum::curve::Curve;
use raylab_integrators::Camera;

pub use crate::formats::schema::{MAX_PIXELS, MAX_SIDE};

pub(super) fn v3(a: [f32; 3]) -> Vec3A {
    Vec3A::from_array(a)
}

/// Turns an emitter description into the component; an environment map's image is read
/// here, and turned into the world by the entity's rotation.
pub(super) fn emitter_from_desc(
    desc: EmitterDesc,
    transform: &Transform,
    files: &SceneFiles,
) -> Result<Emitter, String> {
    Ok(match desc {
        EmitterDesc::Area {
            radiance,
            two_sided,
            texture,
            spectrum,
        } => {
            let (radiance, texture) = match texture {
                None => (v3(radiance), None),
                Some(ColorDesc::Constant(c)) => (v3(radiance) * v3(c), None),
                Some(ColorDesc::Spectrum(p)) => {
                    (v3(radiance) * v3(ColorDesc::spectrum_colour(&p)), None)
                }
                Some(ColorDesc::Texture(t)) => (
                    v3(radiance),
                    Some(emitter_texture(&t, "emitter's texture", files)?),
                ),
            };
            if spectrum.is_some() && texture.is_some() {
                return Err("an emitter with a spectrum takes no texture".into());
            }
            let (radiance, spectrum) = given_spectrum(radiance, spectrum, "radiance")?;
            Emitter::Area {
                radiance,
                two_sided,
                texture,
                spectrum,
            }
        }
        EmitterDesc::Point {
            intensity,
            spectrum,
        } => {
            let (intensity, spectrum) = given_spectrum(v3(intensity), spectrum, "intensity")?;
            Emitter::Point {
                intensity,
                spectrum,
            }
        }
        EmitterDesc::Spot {
            intensity,
            look_at,
            cutoff_angle,
            beam_width,
            falloff,
            texture,
            spectrum,
        } => {
            if spectrum.is_some() && texture.is_some() {
                return Err("an emitter with a spectrum takes no texture".into());
            }
            let (intensity, spectrum) = given_spectrum(v3(intensity), spectrum, "intensity")?;
            Emitter::Spot {
                spectrum,
                intensity,
                texture: match texture {
                    None => None,
                    Some(ColorDesc::Constant(c)) => {
                        Some(raylab_integrators::texture::Texture::Constant(v3(c)))
                    }
                    Some(ColorDesc::Spectrum(p)) => {
                        Some(raylab_integrators::texture::Texture::Constant(v3(
                            ColorDesc::spectrum_colour(&p),
                        )))
                    }
                    Some(ColorDesc::Texture(t)) => {
                        Some(emitter_texture(&t, "spot's texture", files)?)
                    }
                },
                look_at: look_at.map(v3),
                cutoff_angle,
                beam_width: beam_width.unwrap_or(0.75 * cutoff_angle),
                falloff: match falloff.as_deref() {
                    None | Some("linear") => raylab_integrators::light::Falloff::Linear,
                    Some("smoothstep") => raylab_integrators::light::Falloff::Smoothstep,
                    Some(other) => {
                        return Err(format!(
                            "a spot's falloff is \"linear\" or \"smoothstep\", not \"{other}\""
                        ))
                    }
                },
            }
        }
        EmitterDesc::Directional {
            direction,
            irradiance,
            spectrum,
        } => {
            let (irradiance, spectrum) = given_spectrum(v3(irradiance), spectrum, "irradiance")?;
            Emitter::Directional {
                direction: v3(direction),
                irradiance,
                spectrum,
            }
        }
        EmitterDesc::Projector {
            irradiance,
            fov,
            fov_axis,
            scale,
        } => {
            let (irradiance, aspect) = match irradiance {
                ColorDesc::Spectrum(p) => (
                    raylab_integrators::texture::Texture::Constant(v3(ColorDesc::spectrum_colour(
                        &p,
                    ))),
                    1.0,
                ),
                ColorDesc::Constant(c) => {
                    (raylab_integrators::texture::Texture::Constant(v3(c)), 1.0)
                }
                ColorDesc::Texture(t) => {
                    let t = emitter_texture(&t, "projector's image", files)?;
                    let aspect = t.aspect().unwrap_or(1.0);
                    (t, aspect)
                }
            };
            Emitter::Projector {
                irradiance,
                fov_x: horizontal_fov(fov, fov_axis.as_deref(), aspect)?,
                aspect,
                scale,
            }
        }
        EmitterDesc::Environment {
            path,
            scale,
            mapping,
        } => {
            let file = files.named(&path)?;
            let image = crate::formats::images::read_linear_rgb(&file, false)?;
            let (width, height, texels) = match mapping.as_deref() {
                None | Some("latlong") => (image.width, image.height, image.texels),
                Some("octahedral") => {
                    if image.width != image.height || image.width < 1 {
                        return Err(format!(
                            "environment map `{}`: an octahedral map is square, this one is {} x {}",
                            file.display(),
                            image.width,
                            image.height
                        ));
                    }
                    crate::formats::octahedral::to_lat_long(image.width, &image.texels)
                }
                Some(other) => {
                    return Err(format!(
                        "an environment map's mapping is \"latlong\" or \"octahedral\", not \"{other}\""
                    ))
                }
            };
            let map = EnvMap::new(width, height, texels, scale, transform.orientation())
                .map_err(|e| format!("environment map `{}`: {e}", file.display()))?;
            Emitter::Environment(std::sync::Arc::new(map))
        }
    })
}

/// The entity's transform: translate, rotate and scale, or a whole matrix (without them).
pub(super) fn transform_from_desc(
    t: &crate::formats::schema::TransformDesc,
) -> Result<Transform, String> {
    let mut transform = Transform {
        translate: Vec3::from_array(t.translate),
        rotate_degrees: Vec3::from_array(t.rotate),
        scale: Vec3::from_array(t.scale),
        matrix: None,
    };
    let Some(values) = &t.matrix else {
        return Ok(transform);
    };
    if transform != Transform::default() {
        return Err(
            "transform.matrix replaces translate, rotate and scale: give the matrix alone".into(),
        );
    }
    let rows: [[f32; 4]; 3] = match values.len() {
        12 | 16 => std::array::from_fn(|r| std::array::from_fn(|c| values[4 * r + c])),
        n => {
            return Err(format!(
                "transform.matrix takes 12 or 16 numbers (rows of four), got {n}"
            ))
        }
    };
    if values.len() == 16 && values[12..] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "transform.matrix's last row must be 0 0 0 1 (an affine map), got {:?}",
            &values[12..]
        ));
    }
    let column = |c: usize| Vec3A::new(rows[0][c], rows[1][c], rows[2][c]);
    transform.matrix = Some(glam::Affine3A::from_cols(
        column(0),
        column(1),
        column(2),
        column(3),
    ));
    Ok(transform)
}

fn check_resolution((w, h): (u32, u32)) -> Result<(), String> {
    check_size(w, h)
}

/// Refuses image sizes that are zero or too large to allocate.
pub fn check_size(w: u32, h: u32) -> Result<(), String> {
    if w == 0 || h == 0 {
        return Err(format!("resolution must be at least 1x1, got {w}x{h}"));
    }
    if w > MAX_SIDE || h > MAX_SIDE || (w as u64) * (h as u64) > MAX_PIXELS {
        return Err(format!(
            "resolution {w}x{h} is too large (at most {MAX_SIDE} pixels a side and {MAX_PIXELS} pixels)"
        ));
    }
    Ok(())
}

/// Checks the render defaults: at least 1 spp, a known integrator, and parameters it takes,
/// in range (as `raylab render` would read them, so a bad scene fails whatever the flags).
pub(super) fn check_render(render: &RenderDesc) -> Result<(), String> {
    if render.spp == 0 {
        return Err("render.spp must be at least 1".into());
    }
    let entry =
        registry::find(&render.integrator).map_err(|e| format!("render.integrator: {e}"))?;
    let given: Vec<(String, String)> = render
        .params
        .iter()
        .map(|(k, v)| (k.clone(), format!("{v}")))
        .collect();
    entry
        .resolve(&given)
        .map_err(|e| format!("render.params: {e}"))?;
    Ok(())
}

pub(super) fn camera_from_desc(desc: &CameraDesc) -> Result<Camera, String> {
    match desc {
        CameraDesc::LookAt {
            eye,
            look_at,
            up,
            fov,
            resolution,
        } => {
            for (what, v) in [("eye", eye), ("look_at", look_at), ("up", up)] {
                finite(what, v)?;
            }
            finite("fov", &[*fov])?;
            check_resolution(*resolution)?;
            if !(*fov > 0.0 && *fov < 180.0) {
                return Err(format!(
                    "fov is the vertical field of view in degrees, in (0, 180); got {fov}"
                ));
            }
            check_view(eye, look_at, up)?;
            Ok(Camera::look_at(
                v3(*eye),
                v3(*look_at),
                v3(*up),
                *fov,
                *resolution,
            ))
        }
        CameraDesc::Orthographic {
            eye,
            look_at,
            up,
            width,
            height,
            resolution,
        } => {
            for (what, v) in [("eye", eye), ("look_at", look_at), ("up", up)] {
                finite(what, v)?;
            }
            check_resolution(*resolution)?;
            let height = height.unwrap_or(width * resolution.1 as f32 / resolution.0 as f32);
            for (what, v) in [("width", *width), ("height", height)] {
                if !(v > 0.0 && v < 1e7) {
                    return Err(format!(
                        "an orthographic camera's {what} is its view's size in scene units, \
                         in (0, 1e7); got {v}"
                    ));
                }
            }
            check_view(eye, look_at, up)?;
            Ok(Camera::orthographic(
                v3(*eye),
                v3(*look_at),
                v3(*up),
                (*width, height),
                *resolution,
            ))
        }
        CameraDesc::ImagePlane {
            eye,
            top_left,
            top_right,
            bottom_left,
            bottom_right,
            resolution,
        } => {
            for (what, v) in [
                ("eye", eye),
                ("top_left", top_left),
                ("top_right", top_right),
                ("bottom_left", bottom_left),
                ("bottom_right", bottom_right),
            ] {
                finite(what, v)?;
            }
            check_resolution(*resolution)?;
            let (tl, tr, bl, br) = (
                v3(*top_left),
                v3(*top_right),
                v3(*bottom_left),
                v3(*bottom_right),
            );
            let scale = (tr - tl).length().max((bl - tl).length());
            if (tr - tl).cross(bl - tl).length() < 1e-8 * scale * scale || scale == 0.0 {
                return Err("the image plane corners are degenerate".into());
            }
            if ((tr + bl) - (tl + br)).length() > 1e-4 * scale {
                return Err("the four image plane corners must form a parallelogram".into());
            }
            let n = (tr - tl).cross(bl - tl);
            if n.dot(tl - v3(*eye)).abs() < 1e-6 * scale * scale {
                return Err("the eye must not lie in the image plane".into());
            }
            Ok(Camera::image_plane(v3(*eye), tl, tr, bl, *resolution))
        }
    }
}

/// A view direction from `eye` to `look_at` that `up` is not parallel to.
fn check_view(
    eye: &crate::formats::schema::V3,
    look_at: &crate::formats::schema::V3,
    up: &crate::formats::schema::V3,
) -> Result<(), String> {
    let forward = v3(*look_at) - v3(*eye);
    if forward.length() < 1e-6 {
        return Err("eye and look_at must differ".into());
    }
    if forward
        .normalize()
        .cross(v3(*up).normalize_or_zero())
        .length()
        < 1e-4
    {
        return Err("up must not be zero or parallel to the view direction".into());
    }
    Ok(())
}

/// Exactly `N` points, or an error naming the shape.
fn corners<const N: usize>(shape: &str, vertices: &[[f32; 3]]) -> Result<[Vec3A; N], String> {
    let points: Vec<Vec3A> = vertices.iter().copied().map(v3).collect();
    points.try_into().map_err(|_| {
        format!(
            "a {shape} needs exactly {N} vertices, got {}",
            vertices.len()
        )
    })
}

/// `mesh`, read from `path`, with what its reader repaired noted as a warning of the load.
fn noted(mesh: mesh_files::FileMesh, path: &str, files: &SceneFiles) -> mesh_files::FileMesh {
    if mesh.repaired_normals > 0 {
        files.note(format!(
            "mesh file `{path}`: {} vertex normal(s) were not finite (or zero) and were replaced by the normal of the triangles around the vertex",
            mesh.repaired_normals
        ));
    }
    mesh
}

pub(crate) fn shape_from_desc(desc: ShapeDesc, files: &SceneFiles) -> Result<Shape, String> {
    Ok(match desc {
        ShapeDesc::Gltf { path } => Shape::from(noted(
            mesh_files::load_gltf(&files.named(&path)?, files)?,
            &path,
            files,
        )),
        ShapeDesc::Obj { path, normals } => Shape::from(
            noted(
                mesh_files::load_obj(&files.named(&path)?, false, files)?,
                &path,
                files,
            )
            .shaded(normals),
        ),
        ShapeDesc::Ply {
            path,
            normals,
            attribute,
        } => {
            let mut mesh = noted(
                crate::formats::ply::load_ply(&files.named(&path)?)?,
                &path,
                files,
            );
            let chosen = match attribute {
                None => None,
                Some(name) => {
                    let Some(i) = mesh.attributes.iter().position(|a| a.name == name) else {
                        let have: Vec<&str> =
                            mesh.attributes.iter().map(|a| a.name.as_str()).collect();
                        return Err(format!(
                            "`{path}` has no attribute `{name}` (it has: {})",
                            if have.is_empty() {
                                "none".to_string()
                            } else {
                                have.join(", ")
                            }
                        ));
                    };
                    Some(mesh.attributes.swap_remove(i))
                }
            };
            match Shape::from(mesh.shaded(normals)) {
                Shape::Mesh {
                    positions,
                    indices,
                    normals,
                    uvs,
                    ..
                } => Shape::Mesh {
                    positions,
                    indices,
                    normals,
                    uvs,
                    attribute: chosen,
                },
                other => other,
            }
        }
        ShapeDesc::SdfGrid {
            path,
            smooth_normals,
        } => {
            let g = crate::formats::volume_grid::load_volume_grid(&files.named(&path)?)?;
            if g.channels != 1 {
                return Err(format!(
                    "`{path}` holds {} channels; an SDF grid has one",
                    g.channels
                ));
            }
            if g.resolution.iter().any(|&r| r < 2) {
                return Err(format!(
                    "`{path}` is {} x {} x {}: an SDF grid needs at least 2 values along each axis",
                    g.resolution[0], g.resolution[1], g.resolution[2]
                ));
            }
            Shape::SdfGrid {
                resolution: g.resolution,
                values: g.values.into(),
                smooth: smooth_normals,
            }
        }
        ShapeDesc::Serialized {
            path,
            shape_index,
            normals,
        } => Shape::from(
            noted(
                crate::formats::serialized::load_serialized(&files.named(&path)?, shape_index)?,
                &path,
                files,
            )
            .shaded(normals),
        ),
        ShapeDesc::Instance { mesh } => Shape::Instance { mesh },
        ShapeDesc::Sphere { center, radius } => Shape::Sphere {
            center: v3(center),
            radius,
        },
        ShapeDesc::Triangle { vertices } => Shape::Triangle(corners("Triangle", &vertices)?),
        ShapeDesc::Quad { vertices } => Shape::Quad(corners("Quad", &vertices)?),
        ShapeDesc::Rectangle => Shape::Quad([
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(1.0, 1.0, 0.0),
            Vec3A::new(-1.0, 1.0, 0.0),
        ]),
        ShapeDesc::Disk => Shape::Disk,
        ShapeDesc::Cylinder { p0, p1, radius } => Shape::Cylinder {
            p0: v3(p0),
            p1: v3(p1),
            radius,
        },
        ShapeDesc::Tetrahedron { vertices } => {
            Shape::Tetrahedron(corners("Tetrahedron", &vertices)?)
        }
        ShapeDesc::Icosphere {
            subdivisions,
            displacement,
        } => Shape::Icosphere {
            subdivisions,
            displacement,
        },
        ShapeDesc::Box { min, max } => Shape::Box {
            min: v3(min),
            max: v3(max),
        },
        ShapeDesc::Mesh {
            positions,
            indices,
            normals,
            uvs,
        } => Shape::Mesh {
            positions: positions.into_iter().map(v3).collect(),
            indices,
            normals: normals.map(|n| n.into_iter().map(v3).collect()),
            uvs: uvs.map(|t| t.into_iter().map(glam::Vec2::from_array).collect()),
            attribute: None,
        },
        ShapeDesc::Curves {
            kind,
            split_depth,
            curves,
        } => curves_from_desc(kind, split_depth, &curves)?,
    })
}

/// `Curves` as their cubic Bézier segments: each curve's `3 n + 1` points make `n` segments,
/// its width runs linearly along them (pbrt-v4's `Lerp(i / n, width0, width1)` at the ends of
/// segment `i`), and a ribbon's `n + 1` normals orient them.
fn curves_from_desc(
    kind: CurveType,
    split_depth: u32,
    curves: &[CurveDesc],
) -> Result<Shape, String> {
    if curves.is_empty() {
        return Err("Curves has no curves".into());
    }
    let ribbon = kind == CurveType::Ribbon;
    let segment_count: usize = curves.iter().map(|c| c.points.len() / 3).sum();
    let mut segments = Vec::with_capacity(segment_count);
    for (i, c) in curves.iter().enumerate() {
        let n = c.points.len();
        if n < 4 || (n - 1) % 3 != 0 {
            return Err(format!(
                "curve {i} has {n} points; a curve of cubic Bézier segments has 3 n + 1 (4, 7, \
                 10, ...), each segment's last point the next one's first"
            ));
        }
        let count = (n - 1) / 3;
        let normals = match (&c.normals, ribbon) {
            (Some(normals), true) if normals.len() == count + 1 => Some(normals),
            (Some(normals), true) => {
                return Err(format!(
                    "curve {i}: a ribbon of {count} segment(s) needs {} normals (one at each \
                     segment's ends), got {}",
                    count + 1,
                    normals.len()
                ))
            }
            (None, true) => {
                return Err(format!(
                    "curve {i}: a ribbon needs `normals` at its segments' ends"
                ))
            }
            (Some(_), false) => {
                return Err(format!(
                    "curve {i}: `normals` orient ribbons only (`type: \"ribbon\"`)"
                ))
            }
            (None, false) => None,
        };
        let (w0, w1) = c.width;
        if !(w0.is_finite() && w1.is_finite() && w0 >= 0.0 && w1 >= 0.0) {
            return Err(format!(
                "curve {i}: its width must be finite and not negative, got ({w0}, {w1})"
            ));
        }
        for s in 0..count {
            let at = |k: usize| k as f32 / count as f32;
            let width = |t: f32| (1.0 - t) * w0 + t * w1;
            segments.push(LocalCurveSegment {
                cp: std::array::from_fn(|k| v3(c.points[3 * s + k])),
                width: [width(at(s)), width(at(s + 1))],
                normals: normals.map(|n| [v3(n[s]), v3(n[s + 1])]),
            });
        }
    }
    Ok(Shape::Curves {
        kind: match kind {
            CurveType::Flat => CurveKind::Flat,
            CurveType::Cylinder => CurveKind::Cylinder,
            CurveType::Ribbon => CurveKind::Ribbon,
        },
        split_depth,
        segments,
    })
}

/// An emitter's colour `scale` with its spectrum by wavelength `pairs`, if given: then the
/// colour must be grey (a scale), the spectrum not negative; the result is the spectrum's
/// colour (as an emission: not weighted by D65) times the scale, and the spectrum times the
/// scale.
fn given_spectrum(
    scale: Vec3A,
    pairs: Option<Vec<(f64, f64)>>,
    what: &str,
) -> Result<(Vec3A, Option<Curve>), String> {
    let Some(pairs) = pairs else {
        return Ok((scale, None));
    };
    if let Some(&(nm, v)) = pairs.iter().find(|p| p.1 < 0.0) {
        return Err(format!(
            "the emitter's spectrum is negative ({v} at {nm} nm)"
        ));
    }
    if scale.x != scale.y || scale.y != scale.z {
        return Err(format!(
            "an emitter with a spectrum takes a grey {what} (a scale), not {scale}"
        ));
    }
    let curve = Curve::table(&narrow(&pairs))
        .map_err(|e| format!("the emitter's spectrum: {e}"))?
        .scaled(scale.x);
    let rgb = crate::formats::spectra::to_srgb(&pairs, Use::Emission)
        .map_err(|e| format!("the emitter's spectrum: {e}"))?;
    // A narrow band's colour may lie outside sRGB: its negative channels are cut (RGB mode's
    // light), the spectrum itself is kept.
    Ok((v3(rgb.map(|c| c.max(0.0) as f32)) * scale.x, Some(curve)))
}

/// An emitter's texture (`what` names it in messages): finite values, none negative, 8-bit
/// images decoded from sRGB unless the description says `raw`.
fn emitter_texture(
    t: &crate::formats::texture_desc::TextureDesc,
    what: &str,
    files: &SceneFiles,
) -> Result<raylab_integrators::texture::Texture, String> {
    super::textures::TextureLoader::new(files)
        .texture(t, super::textures::Role::Emission)
        .map_err(|e| format!("the {what}: {e}"))
}

/// The horizontal field of view (degrees) of a field of view `fov` along `axis` of an image of
/// `aspect` = width / height, as Mitsuba's `parse_fov` reads it.
fn horizontal_fov(fov: f32, axis: Option<&str>, aspect: f32) -> Result<f32, String> {
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!(
            "a field of view must lie in (0, 180) degrees, got {fov}"
        ));
    }
    let t = (0.5 * fov).to_radians().tan();
    let x = match axis.unwrap_or("x") {
        "x" => return Ok(fov),
        "y" => t * aspect,
        "diagonal" => t * aspect / (1.0 + aspect * aspect).sqrt(),
        "smaller" if aspect > 1.0 => t * aspect,
        "smaller" => return Ok(fov),
        "larger" if aspect > 1.0 => return Ok(fov),
        "larger" => t * aspect,
        other => {
            return Err(format!(
                "fov_axis is \"x\", \"y\", \"diagonal\", \"smaller\" or \"larger\", not \"{other}\""
            ))
        }
    };
    Ok(2.0 * x.atan().to_degrees())
}
