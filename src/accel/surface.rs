//! The surface record of a triangle hit: the shading normal, texture coordinates and the
//! position's derivatives along them, from what the triangle carries per vertex.

use glam::{Vec2, Vec3A};

/// What a triangle carries per vertex beyond its corners: shading normals (zero where its
/// mesh has none) and texture coordinates ([`DEFAULT_UVS`] where it has none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexData {
    pub normals: [Vec3A; 3],
    pub uvs: [Vec2; 3],
    /// Whether `normals` and `uvs` are the mesh's own.
    pub has_normals: bool,
    pub has_uvs: bool,
}

/// The texture coordinates of a triangle without any (Mitsuba 3's): `uv` is then the hit's
/// barycentric weights `(b1, b2)`.
pub const DEFAULT_UVS: [Vec2; 3] = [Vec2::ZERO, Vec2::X, Vec2::Y];

impl VertexData {
    /// Triangle `i`'s vertex data in a mesh with these per-triangle `normals` and `uvs`, or
    /// `None` when the mesh has neither.
    pub fn of(
        normals: Option<&[[Vec3A; 3]]>,
        uvs: Option<&[[Vec2; 3]]>,
        i: usize,
    ) -> Option<VertexData> {
        (normals.is_some() || uvs.is_some()).then(|| VertexData {
            normals: normals.map_or([Vec3A::ZERO; 3], |n| n[i]),
            uvs: uvs.map_or(DEFAULT_UVS, |u| u[i]),
            has_normals: normals.is_some(),
            has_uvs: uvs.is_some(),
        })
    }
}

/// Texture coordinates and tangents of a triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parametrisation {
    pub uv: Vec2,
    pub dpdu: Vec3A,
    pub dpdv: Vec3A,
    /// The mesh attribute interpolated at the hit (zero without one).
    pub attribute: Vec3A,
}

impl Parametrisation {
    /// The same with its tangents mapped by `m` (an instance's local-to-world linear map).
    #[inline]
    pub fn mapped(self, m: glam::Mat3A) -> Parametrisation {
        Parametrisation {
            dpdu: m * self.dpdu,
            dpdv: m * self.dpdv,
            ..self
        }
    }

    /// Writes it into `hit`, whose parametrisation is then complete.
    #[inline]
    pub fn write_to(self, hit: &mut raylab_integrators::Hit) {
        (hit.uv, hit.dpdu, hit.dpdv) = (self.uv, self.dpdu, self.dpdv);
        hit.attribute = self.attribute;
        hit.pending = raylab_integrators::Pending::None;
    }
}

/// The parametrisation at barycentric weights `b` of the triangle with edges `e1 = v1 - v0`
/// and `e2 = v2 - v0` (in whatever space the caller works in): `uv` interpolated from the
/// vertices' texture coordinates, `dpdu` and `dpdv` solved from them as Mitsuba 3 does. A
/// triangle without texture coordinates (or with degenerate ones) has no tangents: its frame
/// is its normal's, as Mitsuba 3's `coordinate_system(n)`. The triangle's `attribute` at its
/// corners, if it has one, is interpolated likewise.
#[inline]
pub fn parametrisation(
    b: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    data: Option<&VertexData>,
    attribute: Option<&[Vec3A; 3]>,
) -> Parametrisation {
    let attribute = attribute.map_or(Vec3A::ZERO, |a| a[0] * b.x + a[1] * b.y + a[2] * b.z);
    let Some(data) = data.filter(|d| d.has_uvs) else {
        return Parametrisation {
            uv: Vec2::new(b.y, b.z),
            dpdu: Vec3A::ZERO,
            dpdv: Vec3A::ZERO,
            attribute,
        };
    };
    let [uv0, uv1, uv2] = data.uvs;
    let uv = uv0 * b.x + uv1 * b.y + uv2 * b.z;
    let (duv0, duv1) = (uv1 - uv0, uv2 - uv0);
    let det = duv0.x * duv1.y - duv0.y * duv1.x;
    let (dpdu, dpdv) = if det != 0.0 && det.is_finite() {
        let inv = 1.0 / det;
        (
            (e1 * duv1.y - e2 * duv0.y) * inv,
            (e2 * duv0.x - e1 * duv1.x) * inv,
        )
    } else {
        (Vec3A::ZERO, Vec3A::ZERO)
    };
    Parametrisation {
        uv,
        dpdu,
        dpdv,
        attribute,
    }
}

/// The shading normal at barycentric weights `b` from the vertex normals `n`, turned to the
/// side of the geometric normal `ng` (`ng` itself where the interpolation vanishes).
#[inline]
pub fn interpolated_normal(ng: Vec3A, b: Vec3A, n: [Vec3A; 3]) -> Vec3A {
    let s = (n[0] * b.x + n[1] * b.y + n[2] * b.z).normalize_or_zero();
    if s == Vec3A::ZERO {
        ng
    } else if s.dot(ng) < 0.0 {
        -s
    } else {
        s
    }
}

/// The shading normal of a triangle hit at barycentric weights `b` from its vertex normals
/// (which it must have), each mapped by `to_world` first.
#[inline]
pub fn shading_normal(
    ng: Vec3A,
    b: Vec3A,
    data: &VertexData,
    to_world: impl Fn(Vec3A) -> Vec3A,
) -> Vec3A {
    debug_assert!(data.has_normals);
    interpolated_normal(ng, b, data.normals.map(to_world))
}

/// Barycentric weights of `p` (on the triangle's plane) for v0, v1, v2, from the triangle's
/// `v0` and edges `e1 = v1 - v0`, `e2 = v2 - v0`.
#[inline]
pub fn barycentrics(v0: Vec3A, e1: Vec3A, e2: Vec3A, p: Vec3A) -> Vec3A {
    let d = p - v0;
    let n = e1.cross(e2);
    let inv = 1.0 / n.length_squared();
    let b1 = d.cross(e2).dot(n) * inv;
    let b2 = e1.cross(d).dot(n) * inv;
    Vec3A::new(1.0 - b1 - b2, b1, b2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangents_follow_the_texture_coordinates() {
        // A right triangle in the xy plane whose uvs run along -y (u) and +x (v), scaled 2x.
        let (e1, e2) = (Vec3A::new(0.0, -1.0, 0.0), Vec3A::new(1.0, 0.0, 0.0));
        let data = VertexData {
            normals: [Vec3A::ZERO; 3],
            uvs: [Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::new(0.0, 2.0)],
            has_normals: false,
            has_uvs: true,
        };
        let b = Vec3A::new(0.5, 0.25, 0.25);
        let p = parametrisation(b, e1, e2, Some(&data), None);
        assert!((p.uv - Vec2::new(0.5, 0.5)).length() < 1e-6);
        assert!(
            (p.dpdu - Vec3A::new(0.0, -0.5, 0.0)).length() < 1e-6,
            "{}",
            p.dpdu
        );
        assert!(
            (p.dpdv - Vec3A::new(0.5, 0.0, 0.0)).length() < 1e-6,
            "{}",
            p.dpdv
        );
        // Without texture coordinates: uv is (b1, b2) and there are no tangents.
        let q = parametrisation(b, e1, e2, None, None);
        assert_eq!((q.uv, q.dpdu), (Vec2::new(0.25, 0.25), Vec3A::ZERO));
        // Degenerate uvs give no tangents rather than infinities.
        let flat = VertexData {
            uvs: [Vec2::ONE; 3],
            ..data
        };
        assert_eq!(
            parametrisation(b, e1, e2, Some(&flat), None).dpdu,
            Vec3A::ZERO
        );
        // An attribute is interpolated with the barycentric weights.
        let a = [Vec3A::X, Vec3A::Y, Vec3A::Z];
        let with = parametrisation(b, e1, e2, None, Some(&a));
        assert_eq!(with.attribute, Vec3A::new(0.5, 0.25, 0.25));
    }
}
