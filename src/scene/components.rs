//! ECS components of scene entities, and the resources that live beside the world.

use crate::accel::{CurveKind, CurveSegment, Quadric};
use glam::{Affine3A, EulerRot, Quat, Vec2, Vec3, Vec3A};
use raylab_integrators::Rgb;
use std::sync::Arc;

/// Where an entity comes from in the scene file: its place in the `entities` list and, for
/// the parts a mesh file's materials split it into (`material: "from-file"`), the part's place
/// among them. Wherever order shows in the result (the BVH's input, the light table, which
/// error is reported first) entities are taken in this order: it comes from the file, not
/// from hecs's ids, which are only transiently unique and depend on the world's history.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct FileOrder {
    pub entity: u32,
    pub part: u32,
}

/// Display name of an entity (from the file, or `entity #N`).
#[derive(Clone, Debug, PartialEq)]
pub struct Name(pub String);

/// Placement of an entity: scale, then rotation (degrees about x, then y, then z, fixed
/// axes), then translation; or a whole affine matrix, which replaces the three.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub translate: Vec3,
    pub rotate_degrees: Vec3,
    pub scale: Vec3,
    pub matrix: Option<Affine3A>,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            translate: Vec3::ZERO,
            rotate_degrees: Vec3::ZERO,
            scale: Vec3::ONE,
            matrix: None,
        }
    }
}

impl Transform {
    /// The local-to-world matrix.
    pub fn matrix(&self) -> Affine3A {
        self.matrix.unwrap_or_else(|| {
            Affine3A::from_scale_rotation_translation(self.scale, self.rotation(), self.translate)
        })
    }

    /// The world direction of the local direction `v`, unit length: turned by the rotation,
    /// or, for a matrix, `v` mapped by it (as Mitsuba turns its emitters: a mirror mirrors).
    pub fn direction(&self, v: Vec3) -> Vec3 {
        match self.matrix {
            Some(m) => Vec3::from(m.matrix3 * Vec3A::from(v)).normalize(),
            None => (self.rotation() * v).normalize(),
        }
    }

    /// Whether the transform mirrors (a matrix of negative determinant).
    pub fn mirrors(&self) -> bool {
        self.matrix.is_some_and(|m| m.matrix3.determinant() < 0.0)
    }

    /// How the transform turns directions, without scale: its rotation, followed for a
    /// mirroring matrix by the mirror that reverses the rotated `z` (an orthogonal map; what
    /// an environment map's directions go through, as pbrt-v4 and Mitsuba 3 map them).
    pub fn orientation(&self) -> glam::Mat3A {
        let r = glam::Mat3A::from_quat(self.rotation());
        if self.mirrors() {
            glam::Mat3A::from_cols(r.x_axis, r.y_axis, -r.z_axis)
        } else {
            r
        }
    }

    /// Where the local origin lands.
    pub fn translation(&self) -> Vec3A {
        self.matrix().translation
    }

    /// The rotation alone: of a matrix, its columns made orthonormal (Gram-Schmidt from `x`,
    /// then `y`; `z` their cross product), exactly its rotation when it scales along its own
    /// axes; the identity for a degenerate matrix.
    pub fn rotation(&self) -> Quat {
        if let Some(m) = self.matrix {
            let x = m.matrix3.x_axis.normalize_or_zero();
            let y = (m.matrix3.y_axis - x * x.dot(m.matrix3.y_axis)).normalize_or_zero();
            let z = x.cross(y);
            if z.length_squared() < 0.5 {
                return Quat::IDENTITY;
            }
            return Quat::from_mat3a(&glam::Mat3A::from_cols(x, y, z)).normalize();
        }
        let r = self.rotate_degrees;
        // Extrinsic x, then y, then z  ==  R = Rz * Ry * Rx.
        Quat::from_euler(
            EulerRot::ZYX,
            r.z.to_radians(),
            r.y.to_radians(),
            r.x.to_radians(),
        )
    }
}

/// Geometry in the entity's local space.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Sphere {
        center: Vec3A,
        radius: f32,
    },
    Triangle([Vec3A; 3]),
    Quad([Vec3A; 4]),
    /// The unit disk of the local `xy` plane, front `+z`.
    Disk,
    /// An open cylinder of `radius` around the segment `p0` to `p1`.
    Cylinder {
        p0: Vec3A,
        p1: Vec3A,
        radius: f32,
    },
    Tetrahedron([Vec3A; 4]),
    Icosphere {
        subdivisions: u32,
        displacement: f32,
    },
    Box {
        min: Vec3A,
        max: Vec3A,
    },
    Mesh {
        positions: Vec<Vec3A>,
        indices: Vec<[u32; 3]>,
        normals: Option<Vec<Vec3A>>,
        uvs: Option<Vec<Vec2>>,
        /// The file's attribute the entity's material reads, if any.
        attribute: Option<crate::formats::mesh_files::MeshAttribute>,
    },
    /// An SDF grid over the unit cube (Mitsuba's `sdfgrid`): `values` in `x`, `y`, `z` order.
    SdfGrid {
        resolution: [usize; 3],
        values: std::sync::Arc<[f32]>,
        smooth: bool,
    },
    /// A mesh asset of the scene, by name; resolved to [`Instanced`] by
    /// [`super::assets::resolve_instances`].
    Instance {
        mesh: String,
    },
    /// Curves as cubic Bézier segments, each split into `2^split_depth` pieces for the BVH.
    Curves {
        kind: CurveKind,
        split_depth: u32,
        segments: Vec<LocalCurveSegment>,
    },
}

/// One cubic Bézier segment of a curve in its entity's space: control points, the width at
/// each end and, for a ribbon, the normals there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalCurveSegment {
    pub cp: [Vec3A; 4],
    pub width: [f32; 2],
    pub normals: Option<[Vec3A; 2]>,
}

/// A key no other geometry of this process carries ([`GeometryId`], [`LocalMesh::id`]):
/// a build may keep the BVH of geometry whose key it saw before. Only equality matters, never
/// the order in which keys were given, so images do not depend on it.
pub fn new_geometry_id() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// The identity of an entity's baked [`WorldShape`]: a new key ([`new_geometry_id`]) each
/// time it is baked, so a build can tell geometry it already has a BVH for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeometryId(pub u64);

/// What an edit changed on an entity (see [`crate::scene::edit`]); the rebuild after the
/// edit reads it and removes it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Changed {
    /// The entity is new (no entity of its name was there before).
    pub added: bool,
    pub transform: bool,
    /// Its shape, its `flip_normals`, or a file its shape is read from.
    pub shape: bool,
    /// Which material it uses (an edit of the material itself changes no entity).
    pub material: bool,
    pub emitter: bool,
    /// Its place in the file (an entity added or removed before it).
    pub order: bool,
}

impl Changed {
    /// Whether the change moves, adds or reshapes geometry, or changes which material its
    /// primitives report: the BVH must be rebuilt. (An emitter's change rebuilds the light
    /// table, and the BVH too if the lights' indices move.)
    pub fn geometry(&self) -> bool {
        self.added || self.transform || self.shape || self.material || self.order
    }

    /// The parts that changed, for messages: `transform, material`.
    pub fn describe(&self) -> String {
        let parts = [
            (self.added, "added"),
            (self.transform, "transform"),
            (self.shape, "shape"),
            (self.material, "material"),
            (self.emitter, "emitter"),
            (self.order, "place in the file"),
        ];
        let named: Vec<&str> = parts.iter().filter(|p| p.0).map(|p| p.1).collect();
        named.join(", ")
    }
}

/// A mesh asset in its own space, loaded once and shared by every instance of it.
#[derive(Debug, PartialEq)]
pub struct LocalMesh {
    /// A key no other mesh carries ([`new_geometry_id`]).
    pub id: u64,
    /// The asset's name in the scene's `meshes` table.
    pub name: String,
    /// Triangles (none degenerate), right-handed winding.
    pub triangles: Vec<[Vec3A; 3]>,
    /// Per-triangle vertex normals for smooth shading, if the source has them.
    pub normals: Option<Vec<[Vec3A; 3]>>,
    /// Per-triangle texture coordinates, if the source has them.
    pub uvs: Option<Vec<[Vec2; 3]>>,
    /// Local bounds (min, max).
    pub bounds: (Vec3A, Vec3A),
}

/// An entity that places a shared mesh asset: the asset's index in
/// [`super::LoadedScene::meshes`] and the asset itself.
#[derive(Clone, Debug)]
pub struct Instanced {
    pub mesh: u32,
    pub asset: Arc<LocalMesh>,
}

/// The media an entity's surface bounds, by name (resolved when the scene is flattened, so
/// that an entity kept across an edit of the media table never holds a stale index).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MediumBoundary(pub crate::formats::schema::MediumInterfaceDesc);

/// Marks an entity whose shape's faces are turned around (`flip_normals`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlipNormals;

/// Index of the entity's material in the scene's material table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialRef(pub u32);

/// Light emission of an entity.
#[derive(Clone, Debug, PartialEq)]
pub enum Emitter {
    /// Emits `radiance` from the front of the shape (both sides if `two_sided`).
    Area {
        radiance: Rgb,
        two_sided: bool,
        /// A texture over the radiance, looked up at the shape's texture coordinates.
        texture: Option<raylab_integrators::texture::Texture>,
        /// The emission by wavelength, of which `radiance` is the colour.
        spectrum: Option<raylab_integrators::spectrum::curve::Curve>,
    },
    /// Isotropic point light at the entity's translation.
    Point {
        intensity: Rgb,
        /// The intensity by wavelength, of which `intensity` is the colour.
        spectrum: Option<raylab_integrators::spectrum::curve::Curve>,
    },
    /// A spot light at the entity's translation, pointing at `look_at` or along its rotated
    /// `+z`; angles in degrees.
    Spot {
        intensity: Rgb,
        look_at: Option<Vec3A>,
        cutoff_angle: f32,
        beam_width: f32,
        falloff: raylab_integrators::light::Falloff,
        /// A projected texture, looked up in the spot's frame.
        texture: Option<raylab_integrators::texture::Texture>,
        /// The intensity by wavelength, of which `intensity` is the colour.
        spectrum: Option<raylab_integrators::spectrum::curve::Curve>,
    },
    /// Parallel light travelling along `direction` (before the entity's rotation).
    Directional {
        direction: Vec3A,
        irradiance: Rgb,
        /// The irradiance by wavelength, of which `irradiance` is the colour.
        spectrum: Option<raylab_integrators::spectrum::curve::Curve>,
    },
    /// A projector: its image, horizontal field of view (degrees) and scale.
    Projector {
        irradiance: raylab_integrators::texture::Texture,
        fov_x: f32,
        aspect: f32,
        scale: f32,
    },
    /// An environment map, already turned into the world by the entity's rotation.
    Environment(Arc<raylab_integrators::light::EnvMap>),
}

impl Emitter {
    /// What the emitter emits by wavelength, where the scene gave it so, with the colour that
    /// stands for it in RGB mode (its nominal radiance, intensity or irradiance).
    pub fn spectrum(&self) -> Option<(&raylab_integrators::spectrum::curve::Curve, Rgb)> {
        match self {
            Emitter::Area {
                radiance: c,
                spectrum: Some(s),
                ..
            }
            | Emitter::Point {
                intensity: c,
                spectrum: Some(s),
            }
            | Emitter::Spot {
                intensity: c,
                spectrum: Some(s),
                ..
            }
            | Emitter::Directional {
                irradiance: c,
                spectrum: Some(s),
                ..
            } => Some((s, *c)),
            _ => None,
        }
    }
}

/// World-space geometry, produced from `Shape` and `Transform` by the bake system.
#[derive(Clone, Debug, PartialEq)]
pub enum WorldShape {
    /// Triangles with optional per-vertex shading normals and texture coordinates.
    /// `parallelogram` is set for quads (corner, edge, edge), so an emitting quad is sampled
    /// as one light.
    Triangles {
        triangles: Vec<[Vec3A; 3]>,
        normals: Option<Vec<[Vec3A; 3]>>,
        uvs: Option<Vec<[Vec2; 3]>>,
        /// The mesh attribute its material reads, at each triangle's corners.
        attributes: Option<Vec<[Vec3A; 3]>>,
        parallelogram: Option<[Vec3A; 3]>,
    },
    Sphere {
        center: Vec3A,
        radius: f32,
        /// The sphere's own axes in the world (a rotation, perhaps a mirror): Mitsuba's
        /// parametrisation is the object's, so a rotated sphere's texture turns with it.
        frame: glam::Mat3A,
    },
    /// A disk or cylinder, placed.
    Quadric(Quadric),
    /// Curves' segments, placed, each split into `2^split_depth` pieces for the BVH.
    Curves {
        segments: Vec<CurveSegment>,
        split_depth: u32,
    },
    /// An SDF grid, placed.
    SdfGrid(std::sync::Arc<crate::accel::sdf_grid::SdfGrid>),
}

impl WorldShape {
    /// Total surface area (of curves, pbrt-v4's approximation).
    pub fn area(&self) -> f32 {
        match self {
            WorldShape::Triangles { triangles, .. } => triangles
                .iter()
                .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
                .sum(),
            WorldShape::Sphere { radius, .. } => 4.0 * std::f32::consts::PI * radius * radius,
            WorldShape::Quadric(q) => q.area(),
            WorldShape::Curves { segments, .. } => segments.iter().map(CurveSegment::area).sum(),
            // Not measured: an SDF grid cannot emit, and nothing else asks.
            WorldShape::SdfGrid(_) => 0.0,
        }
    }
}

impl From<crate::formats::mesh_files::FileMesh> for Shape {
    /// A mesh file's geometry alone (its materials are the file materials' business).
    fn from(mesh: crate::formats::mesh_files::FileMesh) -> Shape {
        Shape::Mesh {
            positions: mesh.positions,
            indices: mesh.indices,
            normals: mesh.normals,
            uvs: mesh.uvs,
            attribute: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A matrix's orientation is its rotation, with the mirror where it mirrors: the map of
    /// directions the matrix makes, scale removed.
    #[test]
    fn orientation_keeps_a_mirror_and_drops_the_scale() {
        let m = glam::Mat3A::from_quat(Quat::from_rotation_y(0.6))
            * glam::Mat3A::from_diagonal(Vec3::new(-2.0, 2.0, 2.0));
        let t = Transform {
            matrix: Some(Affine3A::from_mat3_translation(
                m.into(),
                Vec3::new(1.0, 2.0, 3.0),
            )),
            ..Transform::default()
        };
        assert!(t.mirrors());
        let o = t.orientation();
        assert!((o.determinant() + 1.0).abs() < 1e-5);
        for v in [Vec3A::X, Vec3A::Y, Vec3A::new(0.3, -0.5, 0.8).normalize()] {
            let want = (m * v).normalize();
            assert!((o * v - want).length() < 1e-5, "{v}: {} vs {want}", o * v);
        }
        let plain = Transform {
            rotate_degrees: Vec3::new(0.0, 30.0, 0.0),
            ..Transform::default()
        };
        assert!((plain.orientation().determinant() - 1.0).abs() < 1e-5);
    }
}
