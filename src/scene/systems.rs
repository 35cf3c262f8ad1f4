//! ECS systems: plain functions over queries of the scene world.
//!
//! * [`validate`] checks every component and names the entity at fault;
//! * [`bake_transforms`] turns `Shape` + `Transform` into world-space `WorldShape`;
//! * [`collect_emitters`] gathers the lights the emitting entities define;
//! * [`super::assets::resolve_instances`] (in its own module) resolves `Instance` shapes to
//!   shared mesh assets.
//!
//! Queries visit entities in archetype order, which depends on the world's history; where
//! order shows in a result (which error is reported, the order of lights and shapes) a system
//! takes its entities in [`FileOrder`], so that results (and therefore images) never depend on
//! it.

use super::components::{
    new_geometry_id, Emitter, FileOrder, FlipNormals, GeometryId, Name, Shape, Transform,
    WorldShape,
};
use super::error::finite;
use crate::accel::{CurveKind, CurveSegment, Quadric, QuadricKind};
use glam::{Affine3A, Mat3A, Vec2, Vec3, Vec3A};
use hecs::{Entity, World};
use raylab_integrators::light::{
    CylinderLight, DirectionalLight, EnvMapLight, Planar, PlanarShape, ProjectorLight, SpotLight,
};
use raylab_integrators::Light;

/// An error message with the name of the entity it is about.
pub type EntityError = (String, String);

/// Checks every entity's components: finite numbers, positive sizes and scales, shapes that
/// make sense, emitters with non-negative radiance on the right kind of entity.
pub fn validate(world: &World) -> Result<(), EntityError> {
    let mut query = world.query::<(
        &FileOrder,
        &Name,
        &Transform,
        Option<&Shape>,
        Option<&Emitter>,
    )>();
    let mut entities: Vec<_> = query.iter().collect();
    entities.sort_by_key(|(order, ..)| **order);
    for (_, name, transform, shape, emitter) in entities {
        let fail = |m: String| (name.0.clone(), m);
        validate_transform(transform).map_err(fail)?;
        if let Some(shape) = shape {
            validate_shape(shape, transform).map_err(fail)?;
        }
        match (emitter, shape) {
            (Some(Emitter::Area { .. }), Some(Shape::Curves { .. })) => {
                return Err(fail(
                    "curves cannot emit light (nor can pbrt-v4's): give them no emitter".into(),
                ));
            }
            (Some(Emitter::Area { .. }), Some(Shape::Instance { mesh })) => {
                return Err(fail(format!(
                    "an instance of mesh `{mesh}` cannot emit light: instances share one mesh \
                     and its BVH, lights need their own triangles (put the mesh's shape on this \
                     entity instead of `Instance`)"
                )));
            }
            (
                Some(Emitter::Area {
                    radiance,
                    two_sided,
                    texture,
                    ..
                }),
                s,
            ) => {
                check_radiance("radiance", *radiance).map_err(fail)?;
                if texture.is_some()
                    && !matches!(s, Some(Shape::Mesh { .. } | Shape::Quad(_)) | None)
                {
                    return Err(fail(
                        "a textured area emitter needs a mesh or a rectangle (its texture coordinates)".into(),
                    ));
                }
                if s.is_none() {
                    return Err(fail(
                        "an area emitter needs a shape (use `Point` for a point light)".into(),
                    ));
                }
                if matches!(s, Some(Shape::SdfGrid { .. })) {
                    return Err(fail(
                        "an SDF grid cannot emit light (in Mitsuba neither)".into(),
                    ));
                }
                if *two_sided && matches!(s, Some(Shape::Sphere { .. })) {
                    return Err(fail(
                        "a sphere is closed and emits outwards: `two_sided` has no meaning on it"
                            .into(),
                    ));
                }
                if *two_sided && matches!(s, Some(Shape::Cylinder { .. })) {
                    return Err(fail(
                        "a cylinder emits from its outside, or with `flip_normals` from its \
                     inside: `two_sided` is not supported on it"
                            .into(),
                    ));
                }
            }
            (Some(Emitter::Point { intensity, .. }), s) => {
                check_radiance("intensity", *intensity).map_err(fail)?;
                if s.is_some() {
                    return Err(fail(
                        "a point light has no shape: put it on an entity of its own without `shape`".into(),
                    ));
                }
            }
            (
                Some(
                    em @ (Emitter::Spot { .. }
                    | Emitter::Projector { .. }
                    | Emitter::Directional { .. }
                    | Emitter::Environment(_)),
                ),
                s,
            ) => {
                if s.is_some() {
                    return Err(fail(
                        "a spot, projector, directional or environment light has no shape: put it on an entity of its own without `shape`".into(),
                    ));
                }
                match em {
                    Emitter::Spot {
                        intensity, look_at, ..
                    } => {
                        check_radiance("intensity", *intensity).map_err(fail)?;
                        if let Some(target) = look_at {
                            finite("look_at", &target.to_array()).map_err(fail)?;
                        }
                        spot_light(em, transform).map_err(fail)?;
                    }
                    Emitter::Projector { .. } => {
                        projector_light(em, transform).map_err(fail)?;
                    }
                    Emitter::Directional {
                        direction,
                        irradiance,
                        ..
                    } => {
                        check_radiance("irradiance", *irradiance).map_err(fail)?;
                        finite("direction", &direction.to_array()).map_err(fail)?;
                        if direction.length_squared() == 0.0 {
                            return Err(fail(
                                "a directional light's direction has no length".into(),
                            ));
                        }
                    }
                    _ => {}
                }
            }
            (None, None) => {
                return Err(fail("has neither a shape nor an emitter".into()));
            }
            (None, Some(_)) => {}
        }
    }
    Ok(())
}

fn check_radiance(what: &str, c: Vec3A) -> Result<(), String> {
    finite(what, &c.to_array())?;
    if c.min_element() < 0.0 {
        return Err(format!(
            "{what} must not be negative, got {:?}",
            c.to_array()
        ));
    }
    Ok(())
}

fn validate_transform(t: &Transform) -> Result<(), String> {
    if let Some(m) = t.matrix {
        // Row by row, as written.
        let rows: Vec<f32> = (0..3)
            .flat_map(|r| {
                let row = m.matrix3.row(r);
                [row.x, row.y, row.z, m.translation[r]]
            })
            .collect();
        finite("transform.matrix", &rows)?;
        let det = m.matrix3.determinant();
        if det == 0.0 || !det.is_finite() || !m.inverse().is_finite() {
            return Err(format!(
                "transform.matrix cannot be inverted (determinant {det:e}): it flattens the shape"
            ));
        }
        return Ok(());
    }
    finite("transform.translate", &t.translate.to_array())?;
    finite("transform.rotate", &t.rotate_degrees.to_array())?;
    finite("transform.scale", &t.scale.to_array())?;
    if t.scale.min_element() <= 0.0 {
        return Err(format!(
            "transform.scale must be positive, got {:?}",
            t.scale.to_array()
        ));
    }
    Ok(())
}

/// Checks a shape's own numbers (and, for a sphere, that `t` keeps it a sphere).
pub fn validate_shape(shape: &Shape, t: &Transform) -> Result<(), String> {
    let all = |what: &str, pts: &[Vec3A]| -> Result<(), String> {
        if pts.iter().all(|p| p.is_finite()) {
            Ok(())
        } else {
            Err(format!("{what} must be finite"))
        }
    };
    match shape {
        Shape::Curves {
            kind,
            split_depth,
            segments,
        } => validate_curves(*kind, *split_depth, segments, t)?,
        // Read from a file whose values and size are checked; its transform when it is baked.
        Shape::SdfGrid { .. } => {}
        Shape::Sphere { center, radius } => {
            all("sphere center", &[*center])?;
            finite("sphere radius", &[*radius])?;
            if *radius <= 0.0 {
                return Err(format!("sphere radius must be positive, got {radius}"));
            }
            // Orthogonal axes of one length (any rotation or mirror, a uniform scale).
            let m = t.matrix().matrix3;
            let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
            let l = x.length();
            let tol = 1e-5 * l * l;
            if (y.length_squared() - l * l).abs() > 2.0 * tol
                || (z.length_squared() - l * l).abs() > 2.0 * tol
                || x.dot(y).abs() > tol
                || x.dot(z).abs() > tol
                || y.dot(z).abs() > tol
            {
                return Err(match t.matrix {
                    None => format!(
                        "a sphere needs a uniform scale, got {:?}",
                        t.scale.to_array()
                    ),
                    Some(_) => {
                        "a sphere needs a uniform scale: transform.matrix stretches or shears it"
                            .into()
                    }
                });
            }
        }
        // Resolved, and its asset checked, by `assets::resolve_instances`.
        Shape::Instance { .. } => {}
        // Placed by the transform alone (checked on its own).
        Shape::Disk => {}
        Shape::Cylinder { p0, p1, radius } => {
            all("cylinder p0 and p1", &[*p0, *p1])?;
            finite("cylinder radius", &[*radius])?;
            if *radius <= 0.0 {
                return Err(format!("cylinder radius must be positive, got {radius}"));
            }
            if (*p1 - *p0).length() == 0.0 {
                return Err("cylinder p0 and p1 must differ".into());
            }
            let m = cylinder_to_world(*p0, *p1, *radius, &t.matrix()).matrix3;
            let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
            let (lx, ly, lz) = (x.length(), y.length(), z.length());
            let tol = 1e-4;
            if (lx - ly).abs() > tol * lx
                || x.dot(y).abs() > tol * lx * ly
                || x.dot(z).abs() > tol * lx * lz
                || y.dot(z).abs() > tol * ly * lz
            {
                return Err(format!(
                    "a cylinder must stay a circular cylinder: transform.scale {:?} stretches \
                     it unevenly across its axis (scale it uniformly, or along its axis only)",
                    t.scale.to_array()
                ));
            }
        }
        Shape::Triangle(v) => all("triangle vertices", v)?,
        Shape::Tetrahedron(v) => all("tetrahedron vertices", v)?,
        Shape::Quad(v) => {
            all("quad vertices", v)?;
            let size = (v[1] - v[0]).length().max((v[3] - v[0]).length());
            if ((v[0] + v[2]) - (v[1] + v[3])).length() > 1e-4 * size {
                return Err(
                    "quad vertices must form a parallelogram, in order around it \
                            (use `Mesh` for other polygons)"
                        .into(),
                );
            }
        }
        Shape::Icosphere {
            subdivisions,
            displacement,
        } => {
            if *subdivisions > MAX_SUBDIVISIONS {
                return Err(format!(
                    "icosphere subdivisions must be at most {MAX_SUBDIVISIONS} ({} triangles), got {subdivisions}",
                    20u64 << (2 * MAX_SUBDIVISIONS)
                ));
            }
            finite("icosphere displacement", &[*displacement])?;
            if !(0.0..=0.5).contains(displacement) {
                return Err(format!(
                    "icosphere displacement must be in [0, 0.5], got {displacement}"
                ));
            }
        }
        Shape::Box { min, max } => {
            all("box corners", &[*min, *max])?;
            if (*max - *min).min_element() <= 0.0 {
                return Err(format!(
                    "box max must exceed min on every axis, got min {:?} max {:?}",
                    min.to_array(),
                    max.to_array()
                ));
            }
        }
        Shape::Mesh {
            positions,
            indices,
            normals,
            uvs,
            attribute,
        } => {
            all("mesh positions", positions)?;
            if let Some(a) = attribute {
                let want = if a.per_face {
                    indices.len()
                } else {
                    positions.len()
                };
                if a.values.len() != want {
                    return Err(format!(
                        "mesh attribute `{}` has {} values for {want} {}",
                        a.name,
                        a.values.len(),
                        if a.per_face { "triangles" } else { "vertices" }
                    ));
                }
                if let Some((i, v)) = a.values.iter().enumerate().find(|(_, v)| {
                    !(v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0)
                }) {
                    return Err(format!(
                        "mesh attribute `{}`: value {i} is {:?}; a material reads it as a colour or weight in [0, 1]",
                        a.name,
                        v.to_array()
                    ));
                }
            }
            if let Some(uv) = uvs {
                if !uv.iter().all(|v| v.is_finite()) {
                    return Err("mesh uvs must be finite".into());
                }
                if uv.len() != positions.len() {
                    return Err(format!(
                        "mesh has {} uvs for {} positions",
                        uv.len(),
                        positions.len()
                    ));
                }
            }
            if indices.is_empty() {
                return Err("mesh has no triangles".into());
            }
            if let Some((i, tri)) = indices
                .iter()
                .enumerate()
                .find(|(_, t)| t.iter().any(|&k| k as usize >= positions.len()))
            {
                return Err(format!(
                    "mesh triangle {i} has index {:?} out of range (the mesh has {} positions)",
                    tri,
                    positions.len()
                ));
            }
            if let Some(n) = normals {
                all("mesh normals", n)?;
                if n.len() != positions.len() {
                    return Err(format!(
                        "mesh has {} normals for {} positions",
                        n.len(),
                        positions.len()
                    ));
                }
                if n.iter().any(|v| v.length_squared() == 0.0) {
                    return Err("mesh normals must not be zero".into());
                }
            }
        }
    }
    Ok(())
}

/// Checks curves' numbers (finite points, widths not negative, a ribbon's normals not zero,
/// the split depth) and that `t` keeps their width: a rotation or mirror, a uniform scale and
/// a translation.
fn validate_curves(
    kind: CurveKind,
    split_depth: u32,
    segments: &[super::components::LocalCurveSegment],
    t: &Transform,
) -> Result<(), String> {
    use crate::formats::schema::MAX_SPLIT_DEPTH;
    if split_depth > MAX_SPLIT_DEPTH {
        return Err(format!(
            "curves' split_depth must be at most {MAX_SPLIT_DEPTH} ({} pieces a segment), got \
             {split_depth}",
            1u32 << MAX_SPLIT_DEPTH
        ));
    }
    for (i, s) in segments.iter().enumerate() {
        if !s.cp.iter().all(|p| p.is_finite()) {
            return Err(format!("curve segment {i}: its points must be finite"));
        }
        if !(s.width.iter().all(|w| w.is_finite() && *w >= 0.0)) {
            return Err(format!(
                "curve segment {i}: its width must be finite and not negative, got {:?}",
                s.width
            ));
        }
        if kind == CurveKind::Ribbon {
            let normals = s.normals.unwrap_or([Vec3A::ZERO; 2]);
            if normals
                .iter()
                .any(|n| !n.is_finite() || n.length_squared() == 0.0)
            {
                return Err(format!(
                    "curve segment {i}: a ribbon's normals must be finite and not zero"
                ));
            }
        }
    }
    let m = t.matrix().matrix3;
    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
    let l = x.length();
    let tol = 1e-4 * l * l;
    if (y.length_squared() - l * l).abs() > 2.0 * tol
        || (z.length_squared() - l * l).abs() > 2.0 * tol
        || x.dot(y).abs() > tol
        || x.dot(z).abs() > tol
        || y.dot(z).abs() > tol
    {
        return Err(
            "curves need a transform that keeps their width: a rotation, a uniform scale and a \
             translation (this one stretches or shears them)"
                .into(),
        );
    }
    Ok(())
}

pub use crate::formats::memory::{
    check_bytes, check_mesh_memory, check_triangle_memory, curve_triangle_equivalent, mesh_bytes,
    BYTES_PER_ATTRIBUTED_TRIANGLE, BYTES_PER_TRIANGLE, BYTES_PER_VERTEX,
};

/// The texture coordinates of a quad's two triangles (as [`local_triangles`] splits it):
/// corners 0, 1, 2, 3 at `(0, 0)`, `(1, 0)`, `(1, 1)`, `(0, 1)`, as Mitsuba 3's rectangle.
const QUAD_UVS: [[Vec2; 3]; 2] = [
    [Vec2::ZERO, Vec2::X, Vec2::ONE],
    [Vec2::ZERO, Vec2::ONE, Vec2::Y],
];

/// Per-triangle texture coordinates of a shape's [`local_triangles`], where it has any: a
/// mesh's own, each face of a quad or a box spanning `[0, 1]^2`.
fn local_uvs(shape: &Shape) -> Option<Vec<[Vec2; 3]>> {
    match shape {
        Shape::Quad(_) => Some(QUAD_UVS.to_vec()),
        Shape::Box { .. } => Some(QUAD_UVS.repeat(6)),
        Shape::Mesh {
            indices,
            uvs: Some(uv),
            ..
        } => Some(indices.iter().map(|t| t.map(|k| uv[k as usize])).collect()),
        _ => None,
    }
}

/// Triangles a shape will make, known before making them (for curves, the triangles of as
/// much memory as their pieces take: [`curve_triangle_equivalent`]).
fn triangle_count(shape: &Shape) -> u64 {
    match shape {
        Shape::Curves {
            split_depth,
            segments,
            ..
        } => curve_triangle_equivalent(segments.len() as u64, *split_depth),
        Shape::Sphere { .. }
        | Shape::Disk
        | Shape::Cylinder { .. }
        | Shape::Instance { .. }
        | Shape::SdfGrid { .. } => 0,
        Shape::Icosphere { subdivisions, .. } => 20 * 4u64.pow((*subdivisions).min(31)),
        Shape::Triangle(_) => 1,
        Shape::Quad(_) => 2,
        Shape::Tetrahedron(_) => 4,
        Shape::Box { .. } => 12,
        Shape::Mesh { indices, .. } => indices.len() as u64,
    }
}

/// Local-space triangles of a shape, with outward (or right-handed) winding.
/// Largest icosphere subdivision level: 20 * 4^10 = 21 M triangles.
pub const MAX_SUBDIVISIONS: u32 = 10;

fn local_triangles(shape: &Shape) -> Vec<[Vec3A; 3]> {
    match shape {
        Shape::Sphere { .. }
        | Shape::Disk
        | Shape::Cylinder { .. }
        | Shape::Instance { .. }
        | Shape::Curves { .. }
        | Shape::SdfGrid { .. } => Vec::new(),
        Shape::Icosphere {
            subdivisions,
            displacement,
        } => {
            let (positions, indices) = super::procedural::icosphere(*subdivisions, *displacement);
            indices
                .iter()
                .map(|t| t.map(|i| positions[i as usize]))
                .collect()
        }
        Shape::Triangle(v) => vec![*v],
        Shape::Quad(v) => vec![[v[0], v[1], v[2]], [v[0], v[2], v[3]]],
        Shape::Tetrahedron(v) => {
            let faces = [[0, 1, 2, 3], [0, 1, 3, 2], [0, 2, 3, 1], [1, 2, 3, 0]];
            faces
                .iter()
                .map(|&[a, b, c, opposite]| {
                    let (a, b, c, d) = (v[a], v[b], v[c], v[opposite]);
                    // Orient so the normal points away from the opposite vertex.
                    if (b - a).cross(c - a).dot(d - a) > 0.0 {
                        [a, c, b]
                    } else {
                        [a, b, c]
                    }
                })
                .collect()
        }
        Shape::Box { min, max } => {
            let c = |x: usize, y: usize, z: usize| {
                Vec3A::new(
                    if x == 0 { min.x } else { max.x },
                    if y == 0 { min.y } else { max.y },
                    if z == 0 { min.z } else { max.z },
                )
            };
            // Each face as a counter-clockwise quad seen from outside.
            let faces = [
                [c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], // -x
                [c(1, 0, 0), c(1, 1, 0), c(1, 1, 1), c(1, 0, 1)], // +x
                [c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], // -y
                [c(0, 1, 0), c(0, 1, 1), c(1, 1, 1), c(1, 1, 0)], // +y
                [c(0, 0, 0), c(0, 1, 0), c(1, 1, 0), c(1, 0, 0)], // -z
                [c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], // +z
            ];
            faces
                .iter()
                .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
                .collect()
        }
        Shape::Mesh {
            positions, indices, ..
        } => indices
            .iter()
            .map(|t| {
                [
                    positions[t[0] as usize],
                    positions[t[1] as usize],
                    positions[t[2] as usize],
                ]
            })
            .collect(),
    }
}

/// True if a world-space triangle has (numerically) no area and could never be hit reliably.
pub fn is_degenerate(t: &[Vec3A; 3]) -> bool {
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let scale = e1.length_squared().max(e2.length_squared());
    let cross = e1.cross(e2).length_squared();
    cross.is_nan() || cross <= 1e-12 * scale * scale || !cross.is_finite()
}

/// How far from the origin world-space geometry may reach. Beyond it `f32` is too coarse to
/// trace (one unit is 1 ulp at 1e7), and bounding-box areas overflow soon after, which
/// breaks the BVH build.
pub const MAX_COORDINATE: f32 = 1e7;

/// Checks that a world-space shape stays within [`MAX_COORDINATE`] of the origin on every
/// axis (a finite transform of finite numbers can still overflow).
pub fn check_reach(shape: &WorldShape) -> Result<(), String> {
    match shape {
        WorldShape::Sphere { center, radius, .. } => check_reach_of(far(center) + radius),
        WorldShape::Quadric(q) => {
            let (min, max) = q.bounds();
            check_reach_of(far(&min).max(far(&max)))?;
            let area = q.area();
            if !(area > 0.0 && area.is_finite() && q.to_local.is_finite()) {
                return Err(format!(
                    "its transform makes it too thin to trace (area {area:e}): check \
                     transform.scale"
                ));
            }
            Ok(())
        }
        WorldShape::Triangles { triangles, .. } => {
            check_points_reach(triangles.iter().flatten().copied())
        }
        WorldShape::Curves { segments, .. } => {
            check_points_reach(segments.iter().flat_map(|s| s.cp))?;
            let width = segments.iter().flat_map(|s| s.width).fold(0.0f32, f32::max);
            check_reach_of(width)
        }
        WorldShape::SdfGrid(g) => check_points_reach(g.bounds().into_iter()),
    }
}

/// [`check_reach`] for a set of world-space points.
pub fn check_points_reach(points: impl Iterator<Item = Vec3A>) -> Result<(), String> {
    let mut reach = 0.0;
    for p in points {
        reach = far(&p);
        if !within(reach) {
            break;
        }
    }
    check_reach_of(reach)
}

fn within(r: f32) -> bool {
    r.is_finite() && r <= MAX_COORDINATE
}

/// Distance from the origin along the farthest axis; `max_element` skips NaN, so a point with
/// a NaN is infinitely far.
fn far(p: &Vec3A) -> f32 {
    if p.is_finite() {
        p.abs().max_element()
    } else {
        f32::INFINITY
    }
}

fn check_reach_of(reach: f32) -> Result<(), String> {
    if within(reach) {
        Ok(())
    } else {
        Err(format!(
            "in world space it reaches {reach:e} from the origin, beyond the {MAX_COORDINATE:e} \
             raylab can trace (check transform.scale and transform.translate)"
        ))
    }
}

/// Computes every shaped entity's world-space geometry and inserts it as a [`WorldShape`],
/// with a new [`GeometryId`]. The memory check counts `other_triangles` (the scene's triangles
/// outside `world`, kept from before an edit) first.
/// Geometry reaching beyond [`MAX_COORDINATE`] is an error. Degenerate triangles are dropped
/// with a warning (returned); an emitter left without area is an error.
pub fn bake_transforms(
    world: &mut World,
    other_triangles: u64,
) -> Result<Vec<String>, EntityError> {
    let mut warnings = Vec::new();
    let mut baked = hecs::CommandBuffer::new();
    {
        let mut query = world.query::<(
            Entity,
            &FileOrder,
            &Name,
            &Transform,
            &Shape,
            Option<&Emitter>,
            Option<&FlipNormals>,
        )>();
        let mut items: Vec<_> = query.iter().collect();
        items.sort_by_key(|(_, order, ..)| **order);
        // The scene's triangles, checked against memory before any shape is made: the
        // first entity past what fits is named.
        let mut triangles_so_far = other_triangles;
        for (_, _, name, _, shape, ..) in &items {
            triangles_so_far += triangle_count(shape);
            check_triangle_memory(triangles_so_far).map_err(|e| {
                (
                    name.0.clone(),
                    format!("the scene's triangles up to this entity: {e}"),
                )
            })?;
        }
        for (entity, _, name, transform, shape, emitter, flip) in items {
            if matches!(shape, Shape::Instance { .. }) {
                continue;
            }
            let m = transform.matrix();
            let world_shape = match shape {
                Shape::SdfGrid {
                    resolution,
                    values,
                    smooth,
                } => {
                    if flip.is_some() {
                        return Err((
                            name.0.clone(),
                            "flip_normals on an SDF grid is not supported: its normals are the function's gradient".into(),
                        ));
                    }
                    let grid = crate::accel::sdf_grid::SdfGrid::new(
                        *resolution,
                        values.clone(),
                        m,
                        *smooth,
                    )
                    .ok_or_else(|| {
                        (
                            name.0.clone(),
                            "the SDF grid's transform cannot be inverted".to_string(),
                        )
                    })?;
                    WorldShape::SdfGrid(std::sync::Arc::new(grid))
                }
                _ => bake_shape(shape, &m),
            };
            let world_shape = if flip.is_some() {
                flip_faces(world_shape)
            } else {
                world_shape
            };
            check_reach(&world_shape).map_err(|e| (name.0.clone(), e))?;
            if let WorldShape::Triangles {
                triangles,
                normals,
                uvs,
                attributes,
                parallelogram,
            } = world_shape
            {
                let before = triangles.len();
                let keep = nondegenerate(&triangles);
                let attributes = attributes.map(|a| kept(a, keep.as_deref()));
                let (triangles, normals, uvs) = drop_degenerate(triangles, normals, uvs);
                if triangles.len() < before {
                    warnings.push(format!(
                        "entity `{}`: dropped {} degenerate triangle(s) of {before}",
                        name.0,
                        before - triangles.len()
                    ));
                }
                if triangles.is_empty() {
                    if matches!(emitter, Some(Emitter::Area { .. })) {
                        return Err((name.0.clone(), "emitter has zero area".into()));
                    }
                    warnings.push(format!("entity `{}`: no triangles left; ignored", name.0));
                    continue;
                }
                let parallelogram = if triangles.len() == before {
                    parallelogram
                } else {
                    None
                };
                baked.insert(
                    entity,
                    (
                        WorldShape::Triangles {
                            triangles,
                            normals,
                            uvs,
                            attributes,
                            parallelogram,
                        },
                        GeometryId(new_geometry_id()),
                    ),
                );
            } else {
                baked.insert(entity, (world_shape, GeometryId(new_geometry_id())));
            }
        }
    }
    baked.run_on(world);
    Ok(warnings)
}

/// The shape with its faces turned around: triangles wound the other way, shading normals
/// negated, a parallelogram's edges swapped. A sphere keeps its geometry (its emitter is made
/// to emit inwards instead, see [`collect_emitters`]).
fn flip_faces(shape: WorldShape) -> WorldShape {
    match shape {
        WorldShape::Triangles {
            triangles,
            normals,
            uvs,
            attributes,
            parallelogram,
        } => WorldShape::Triangles {
            triangles: triangles.into_iter().map(|[a, b, c]| [a, c, b]).collect(),
            normals: normals.map(|n| n.into_iter().map(|[a, b, c]| [-a, -c, -b]).collect()),
            uvs: uvs.map(|u| u.into_iter().map(|[a, b, c]| [a, c, b]).collect()),
            attributes: attributes.map(|u| u.into_iter().map(|[a, b, c]| [a, c, b]).collect()),
            parallelogram: parallelogram.map(|[p0, e1, e2]| [p0, e2, e1]),
        },
        sphere @ WorldShape::Sphere { .. } => sphere,
        // Its normals are the function's gradient: `flip_normals` is refused on it.
        grid @ WorldShape::SdfGrid(_) => grid,
        WorldShape::Quadric(q) => WorldShape::Quadric(Quadric {
            flipped: !q.flipped,
            ..q
        }),
        WorldShape::Curves {
            segments,
            split_depth,
        } => WorldShape::Curves {
            segments: segments.into_iter().map(CurveSegment::flipped).collect(),
            split_depth,
        },
    }
}

/// Per-triangle vertex normals and texture coordinates, as triangles carry them.
type TriangleData = (
    Vec<[Vec3A; 3]>,
    Option<Vec<[Vec3A; 3]>>,
    Option<Vec<[Vec2; 3]>>,
);

/// Which triangles are not degenerate, or `None` when all are not.
fn nondegenerate(triangles: &[[Vec3A; 3]]) -> Option<Vec<bool>> {
    triangles
        .iter()
        .any(is_degenerate)
        .then(|| triangles.iter().map(|t| !is_degenerate(t)).collect())
}

/// The items whose `keep` is set (all of them without a mask).
fn kept<T>(items: Vec<T>, keep: Option<&[bool]>) -> Vec<T> {
    match keep {
        None => items,
        Some(keep) => items
            .into_iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(t, _)| t)
            .collect(),
    }
}

/// Triangles without the degenerate ones (see [`is_degenerate`]), with their normals and
/// texture coordinates.
pub fn drop_degenerate(
    triangles: Vec<[Vec3A; 3]>,
    normals: Option<Vec<[Vec3A; 3]>>,
    uvs: Option<Vec<[Vec2; 3]>>,
) -> TriangleData {
    let keep = nondegenerate(&triangles);
    let keep = keep.as_deref();
    (
        kept(triangles, keep),
        normals.map(|n| kept(n, keep)),
        uvs.map(|u| kept(u, keep)),
    )
}

/// The map from the unit cylinder (radius 1 around `z`, from `z = 0` to 1) to the cylinder of
/// `radius` from `p0` to `p1` placed by `m`: its axis' frame is Mitsuba 3's (`Frame3f`, as
/// [`raylab_integrators::Frame::from_normal`]), so that `u` starts where Mitsuba's does.
pub fn cylinder_to_world(p0: Vec3A, p1: Vec3A, radius: f32, m: &Affine3A) -> Affine3A {
    let d = p1 - p0;
    let length = d.length();
    let frame = raylab_integrators::Frame::from_normal(d / length);
    let local = Affine3A::from_mat3_translation(
        Mat3A::from_cols(frame.s * radius, frame.t * radius, frame.n * length).into(),
        p0.into(),
    );
    *m * local
}

/// A sphere's own axes from its placement's linear part `m` of scale `scale`: the identity
/// where `m` is a uniform scale (to the last bit, so that such spheres are parametrised as
/// before), else `m` over its scale.
fn sphere_frame(m: Mat3A, scale: f32) -> Mat3A {
    let frame = m * (1.0 / scale);
    let off = (frame - Mat3A::IDENTITY).to_cols_array();
    if off.iter().all(|x| x.abs() < 1e-6) {
        Mat3A::IDENTITY
    } else {
        frame
    }
}

/// The world-space geometry of one shape under matrix `m`.
pub fn bake_shape(shape: &Shape, m: &Affine3A) -> WorldShape {
    match shape {
        Shape::Disk => WorldShape::Quadric(Quadric::new(QuadricKind::Disk, *m, false)),
        Shape::Cylinder { p0, p1, radius } => WorldShape::Quadric(Quadric::new(
            QuadricKind::Cylinder,
            cylinder_to_world(*p0, *p1, *radius, m),
            false,
        )),
        Shape::Sphere { center, radius } => {
            let scale = m.matrix3.x_axis.length();
            WorldShape::Sphere {
                center: m.transform_point3a(*center),
                radius: radius * scale,
                frame: sphere_frame(m.matrix3, scale),
            }
        }
        Shape::Curves {
            kind,
            split_depth,
            segments,
        } => {
            // A uniform scale (validated), which widths take too; normals turn as directions
            // (the inverse transpose of a uniform scale and rotation is the same map).
            let scale = m.matrix3.x_axis.length();
            let segments = segments
                .iter()
                .map(|s| {
                    let normals = s
                        .normals
                        .map_or([Vec3A::ZERO; 2], |n| n.map(|n| (m.matrix3 * n).normalize()));
                    CurveSegment::new(
                        s.cp.map(|p| m.transform_point3a(p)),
                        s.width.map(|w| w * scale),
                        *kind,
                        normals,
                        false,
                    )
                })
                .collect();
            WorldShape::Curves {
                segments,
                split_depth: *split_depth,
            }
        }
        _ => {
            let triangles: Vec<[Vec3A; 3]> = local_triangles(shape)
                .iter()
                .map(|t| t.map(|p| m.transform_point3a(p)))
                .collect();
            let normals = match shape {
                Shape::Mesh {
                    normals: Some(n),
                    indices,
                    ..
                } => {
                    let nm: Mat3A = m.matrix3.inverse().transpose();
                    Some(
                        indices
                            .iter()
                            .map(|t| t.map(|k| (nm * n[k as usize]).normalize_or_zero()))
                            .collect(),
                    )
                }
                _ => None,
            };
            let parallelogram = match shape {
                Shape::Quad(v) => {
                    let w = v.map(|p| m.transform_point3a(p));
                    Some([w[0], w[1] - w[0], w[3] - w[0]])
                }
                _ => None,
            };
            let attributes = match shape {
                Shape::Mesh {
                    attribute: Some(a),
                    indices,
                    ..
                } => Some((0..indices.len()).map(|i| a.corners(indices, i)).collect()),
                _ => None,
            };
            WorldShape::Triangles {
                triangles,
                normals,
                uvs: local_uvs(shape),
                attributes,
                parallelogram,
            }
        }
    }
}

/// The lights of every emitting entity, in file order: one per sphere, one per emitting quad
/// (a parallelogram), one per triangle otherwise, one per point light.
pub fn collect_emitters(world: &World) -> Vec<(Entity, Vec<Light>)> {
    let mut query = world.query::<(
        Entity,
        &FileOrder,
        &Emitter,
        &Transform,
        Option<&WorldShape>,
        Option<&FlipNormals>,
    )>();
    let mut out: Vec<(FileOrder, Entity, Vec<Light>)> = query
        .iter()
        .filter_map(|(entity, order, emitter, transform, shape, flip)| {
            let lights = match (emitter.clone(), shape) {
                (Emitter::Point { intensity, .. }, _) => {
                    vec![Light::point(transform.translation(), intensity)]
                }
                (Emitter::Spot { .. }, _) => match spot_light(emitter, transform) {
                    Ok(spot) => vec![Light::Spot(spot)],
                    Err(_) => return None, // refused by validation
                },
                (Emitter::Projector { .. }, _) => match projector_light(emitter, transform) {
                    Ok(p) => vec![Light::Projector(Box::new(p))],
                    Err(_) => return None, // refused by validation
                },
                (
                    Emitter::Directional {
                        direction,
                        irradiance,
                        ..
                    },
                    _,
                ) => vec![Light::Directional(DirectionalLight {
                    direction: transform.direction(Vec3::from(direction)).into(),
                    irradiance,
                })],
                (Emitter::Environment(map), _) => vec![Light::EnvMap(EnvMapLight { map })],
                (
                    Emitter::Area {
                        radiance,
                        two_sided,
                        ..
                    },
                    Some(WorldShape::Quadric(q)),
                ) => vec![quadric_light(q, radiance, two_sided)],
                (
                    Emitter::Area { radiance, .. },
                    Some(WorldShape::Sphere { center, radius, .. }),
                ) => {
                    if flip.is_some() {
                        vec![Light::sphere_inward(*center, *radius, radiance)]
                    } else {
                        vec![Light::sphere(*center, *radius, radiance)]
                    }
                }
                (
                    Emitter::Area {
                        radiance,
                        two_sided,
                        texture: Some(texture),
                        ..
                    },
                    Some(WorldShape::Triangles { triangles, uvs, .. }),
                ) => {
                    // One light per triangle, with its texture coordinates (a triangle without
                    // any has Mitsuba's (0, 0), (1, 0), (0, 1)).
                    triangles
                        .iter()
                        .enumerate()
                        .map(|(i, t)| {
                            let uv = uvs
                                .as_ref()
                                .map_or([Vec2::ZERO, Vec2::X, Vec2::Y], |u| u[i]);
                            let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
                            let triangle = Planar::new(
                                PlanarShape::Triangle,
                                t[0],
                                e1,
                                e2,
                                radiance,
                                two_sided,
                            );
                            Light::Planar(triangle.with_texture(texture.clone(), uv))
                        })
                        .collect()
                }
                (
                    Emitter::Area {
                        radiance,
                        two_sided,
                        ..
                    },
                    Some(WorldShape::Triangles {
                        triangles,
                        parallelogram,
                        ..
                    }),
                ) => match parallelogram {
                    Some([p0, e1, e2]) => {
                        vec![Light::parallelogram(*p0, *e1, *e2, radiance, two_sided)]
                    }
                    None => triangles
                        .iter()
                        .map(|t| Light::triangle(t[0], t[1], t[2], radiance, two_sided))
                        .collect(),
                },
                // Validation guarantees area emitters have shapes; a shape dropped by the bake
                // step (all triangles degenerate) was already reported.
                (Emitter::Area { .. }, None) => return None,
                // Refused by validation: an SDF grid or curves cannot emit.
                (
                    Emitter::Area { .. },
                    Some(WorldShape::SdfGrid(_) | WorldShape::Curves { .. }),
                ) => return None,
            };
            Some((*order, entity, lights))
        })
        .collect();
    out.sort_by_key(|(order, ..)| *order);
    out.into_iter().map(|(_, e, lights)| (e, lights)).collect()
}

/// The light of an emitting disk (one-sided unless `two_sided`) or cylinder (never
/// two-sided), facing where the quadric's normals face.
fn quadric_light(q: &Quadric, radiance: raylab_integrators::Rgb, two_sided: bool) -> Light {
    let m = &q.to_world.matrix3;
    let center = q.to_world.translation;
    match q.kind {
        QuadricKind::Disk => {
            // Its front is e1 x e2, which a mirroring placement turns away from the hit's
            // normal (the inverse transpose's +z, Mitsuba's): swapping the axes turns it
            // around, as flip_normals does.
            let mirrored = m.determinant() < 0.0;
            let (e1, e2) = if q.flipped != mirrored {
                (m.y_axis, m.x_axis)
            } else {
                (m.x_axis, m.y_axis)
            };
            Light::disk(center, e1, e2, radiance, two_sided)
        }
        QuadricKind::Cylinder => Light::Cylinder(CylinderLight {
            base: center,
            axis: m.z_axis,
            u: m.x_axis.normalize(),
            v: m.y_axis.normalize(),
            radius: m.x_axis.length(),
            radiance,
            inward: q.flipped,
        }),
    }
}

/// The projector of a `Projector` emitter at `transform`: at its translation, its frame the
/// transform's orientation (its rotated axes, a mirror kept).
pub fn projector_light(emitter: &Emitter, transform: &Transform) -> Result<ProjectorLight, String> {
    let Emitter::Projector {
        irradiance,
        fov_x,
        aspect,
        scale,
    } = emitter
    else {
        return Err("not a projector".into());
    };
    let o = transform.orientation();
    let frame = raylab_integrators::Frame {
        s: o.x_axis,
        t: o.y_axis,
        n: o.z_axis,
    };
    ProjectorLight::new(
        transform.translation(),
        frame,
        irradiance.clone(),
        *scale,
        *fov_x,
        *aspect,
    )
}

/// The spot light of a `Spot` emitter at `transform`: at its translation, pointing at its
/// `look_at` or along its rotated `+z`.
pub fn spot_light(emitter: &Emitter, transform: &Transform) -> Result<SpotLight, String> {
    let Emitter::Spot {
        intensity,
        look_at,
        cutoff_angle,
        beam_width,
        falloff,
        texture,
        ..
    } = emitter
    else {
        return Err("not a spot light".into());
    };
    let position: Vec3A = transform.translation();
    let axis = match look_at {
        Some(target) => *target - position,
        None => transform.direction(Vec3::Z).into(),
    };
    // A constant texture only scales the intensity.
    let (intensity, texture) = match texture {
        Some(raylab_integrators::texture::Texture::Constant(c)) => (*intensity * *c, &None),
        t => (*intensity, t),
    };
    let spot = SpotLight::new(position, axis, intensity, *cutoff_angle, *beam_width)?
        .with_falloff(*falloff);
    Ok(match texture {
        None => spot,
        // The texture's frame: the entity's rotated x and y (a look_at: the axis's own frame).
        Some(t) => {
            let x = match look_at {
                Some(_) => raylab_integrators::Frame::from_normal(spot.axis).s,
                None => transform.direction(Vec3::X).into(),
            };
            spot.with_texture(t.clone(), x)?
        }
    })
}

#[cfg(test)]
mod memory_tests {
    /// The charge covers the peaks measured (`/usr/bin/time`, a 1M-triangle mesh file loaded
    /// and rendered): a grid without vertex data (0.5M vertices), the same grid with normals
    /// and texture coordinates, and a soup of 3M vertices with both. The former charge, 200
    /// bytes for a triangle and 100 for a vertex, fell short of the last two (250 and 500 MB).
    #[test]
    fn mesh_charges_cover_the_measured_peaks() {
        for (triangles, vertices, attributes, peak_mb) in [
            (1_002_528, 502_681, false, 214),
            (1_002_528, 502_681, true, 444),
            (1_000_000, 3_000_000, true, 546),
        ] {
            let charged = super::mesh_bytes(triangles, vertices, attributes);
            assert!(
                charged >= peak_mb * 1_000_000,
                "{triangles} triangles: charged {charged}, peak {peak_mb} MB"
            );
            // And not far beyond it (a charge that refuses what fits is a defect too).
            assert!(charged <= peak_mb * 1_000_000 * 13 / 10, "{charged}");
        }
    }

    /// The curves' charge covers the peaks measured (`/usr/bin/time`, a RON scene of 5000
    /// curves of 61 segments each loaded and built, the process's own 38 MB taken off), per
    /// segment at split depths 0, 1, 3 and 5 (1, 2, 8 and 32 pieces), and not far beyond.
    #[test]
    fn curve_charges_cover_the_measured_peaks() {
        let segments = 305_000;
        for (depth, peak_per_segment) in [(0, 518), (1, 714), (3, 1693), (5, 4475)] {
            let charged =
                super::curve_triangle_equivalent(segments, depth) * super::BYTES_PER_TRIANGLE;
            let peak = segments * peak_per_segment;
            assert!(charged >= peak, "depth {depth}: {charged} < {peak}");
            assert!(charged <= peak * 13 / 10, "depth {depth}: {charged}");
        }
    }
}
