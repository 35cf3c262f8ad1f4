//! Rays, hit records and orthonormal frames.

use glam::{Vec2, Vec3A};
use std::f32::consts::{PI, TAU};

/// A ray `origin + t * dir` for `t` in `[0, tmax)`. `dir` is unit length. `medium` is the
/// participating medium it travels through (it fits in the padding after `tmax`: a ray is
/// 48 bytes with it or without it).
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub tmax: f32,
    pub medium: MediumId,
}

impl Ray {
    /// A ray through vacuum.
    pub fn new(origin: Vec3A, dir: Vec3A) -> Self {
        Ray {
            origin,
            dir,
            tmax: f32::INFINITY,
            medium: MediumId::VACUUM,
        }
    }

    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.dir * t
    }
}

/// A participating medium: its index in the scene's media, or [`MediumId::VACUUM`], what
/// every ray of a scene without media travels through.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MediumId(pub u32);

impl MediumId {
    pub const VACUUM: MediumId = MediumId(u32::MAX);

    /// Whether this is vacuum (no medium).
    #[inline]
    pub fn is_vacuum(self) -> bool {
        self == MediumId::VACUUM
    }
}

/// The media on the two sides of a surface (pbrt-v4's `MediumInterface`): `inside` behind its
/// geometric normal, `outside` in front. A surface that only bounds a medium (a smoke's box)
/// has no material of its own; rays cross it unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MediumInterface {
    pub inside: MediumId,
    pub outside: MediumId,
}

impl MediumInterface {
    /// Vacuum on both sides.
    pub const VACUUM: MediumInterface = MediumInterface {
        inside: MediumId::VACUUM,
        outside: MediumId::VACUUM,
    };

    /// The medium a ray leaving the surface along `dir` enters, for geometric normal `ng`.
    #[inline]
    pub fn towards(&self, ng: Vec3A, dir: Vec3A) -> MediumId {
        if ng.dot(dir) > 0.0 {
            self.outside
        } else {
            self.inside
        }
    }
}

/// Everything an integrator needs to know about the closest intersection of a ray.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// World-space position.
    pub p: Vec3A,
    /// Unit geometric normal as the shape defines it (outward for closed shapes, right-handed
    /// winding for triangles). Not flipped towards the ray.
    pub ng: Vec3A,
    /// Unit shading normal, in the same hemisphere as `ng`.
    pub ns: Vec3A,
    /// Index of the surface's material in the scene's material table.
    pub material: u32,
    /// Index of the surface's emitter in the scene's light table, if it emits.
    pub light: Option<u32>,
    /// The surface's tangent along its `u` parameter, which orients the shading frame: on a
    /// sphere its direction (around the `z` axis, as Mitsuba 3's) from the start, its length
    /// once parametrised; on a triangle zero until parametrised, and zero after where it has
    /// no texture coordinates (the frame is then built from the normal alone).
    pub dpdu: Vec3A,
    /// The surface's tangent along its `v` parameter; zero until parametrised.
    pub dpdv: Vec3A,
    /// Texture coordinates, once parametrised: the mesh's, interpolated, or the shape's
    /// parametrisation (Mitsuba 3's for spheres and rectangles; `(b1, b2)` on triangles
    /// without any).
    pub uv: Vec2,
    /// The mesh attribute the surface carries (a vertex colour interpolated, a face's value),
    /// once parametrised; zero where it has none.
    pub attribute: Vec3A,
    /// What `uv`, `dpdu` and `dpdv` still wait for: most hits never need them, so they are
    /// computed only when a material asks ([`crate::Scene::parametrise`]).
    pub pending: Pending,
    /// The media on either side of the surface.
    pub media: MediumInterface,
    /// The least distance spawned rays start from the surface along `ng`: zero but on
    /// curves, which rays leave a width away (pbrt-v4's error bounds of a curve hit), out of
    /// the fibre they model.
    pub spawn_offset: f32,
}

/// A hit's parametrisation not yet computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pending {
    /// Computed (or there is none).
    None,
    /// An analytic sphere's `uv`, `dpdv` and `dpdu`'s length ([`Hit::parametrise_sphere`];
    /// `dpdu`'s direction, which orients the shading frame, is always there).
    Sphere { radius: f32 },
    /// A triangle's `uv`, `dpdu` and `dpdv`, from the vertex data the accelerator keeps:
    /// its primitive and, for an instance, the instance, as the accelerator numbers them.
    Triangle { prim: u32, instance: u32 },
}

/// Distance by which spawned rays are pushed off a surface, relative to the magnitude of the
/// hit position (to stay above float rounding at any scene scale).
pub(crate) const RELATIVE_OFFSET: f32 = 2e-5;
pub(crate) const ABSOLUTE_OFFSET: f32 = 1e-5;

impl Hit {
    /// The hit of `ray` on a sphere at distance `t`: the point re-projected onto the surface
    /// (the ray's point carries the rounding of `t`), the outward normal.
    #[inline]
    pub fn on_sphere(
        ray: &Ray,
        t: f32,
        center: Vec3A,
        radius: f32,
        material: u32,
        light: Option<u32>,
    ) -> Hit {
        let n = (ray.at(t) - center).normalize();
        // The first tangent of Mitsuba 3's parametrisation (around the z axis), which orients
        // the shading frame; the texture coordinates and the second tangent only when a
        // material asks for them.
        Hit {
            // Its direction only, until `parametrise_sphere` gives it its length.
            dpdu: Vec3A::new(-n.y, n.x, 0.0),
            pending: Pending::Sphere { radius },
            ..Hit::new(t, center + n * radius, n, material, light)
        }
    }

    /// [`Hit::on_sphere`] for a sphere whose own axes in the world are `frame` (a rotation,
    /// perhaps with a mirror): its texture coordinates and tangents are those of its own
    /// space (Mitsuba 3's parametrisation of the object), computed at once. The identity is
    /// [`Hit::on_sphere`] exactly.
    #[inline]
    pub fn on_oriented_sphere(
        ray: &Ray,
        t: f32,
        center: Vec3A,
        radius: f32,
        frame: glam::Mat3A,
        material: u32,
        light: Option<u32>,
    ) -> Hit {
        let hit = Hit::on_sphere(ray, t, center, radius, material, light);
        if frame == glam::Mat3A::IDENTITY {
            return hit;
        }
        let n = frame.transpose() * hit.ng;
        let mut local = Hit {
            ng: n,
            dpdu: Vec3A::new(-n.y, n.x, 0.0),
            ..hit
        };
        local.parametrise_sphere();
        Hit {
            uv: local.uv,
            dpdu: frame * local.dpdu,
            dpdv: frame * local.dpdv,
            pending: Pending::None,
            ..hit
        }
    }

    /// A hit whose shading normal is its geometric normal `n`.
    #[inline]
    pub fn new(t: f32, p: Vec3A, n: Vec3A, material: u32, light: Option<u32>) -> Hit {
        Hit {
            t,
            p,
            ng: n,
            ns: n,
            material,
            light,
            dpdu: Vec3A::ZERO,
            dpdv: Vec3A::ZERO,
            uv: Vec2::ZERO,
            attribute: Vec3A::ZERO,
            pending: Pending::None,
            media: MediumInterface::VACUUM,
            spawn_offset: 0.0,
        }
    }

    /// Completes a sphere hit's parametrisation, Mitsuba 3's: `u` the angle around the `z`
    /// axis from `+x` over 2 pi, `v` the angle from `+z` over pi, and `dpdv` the position's
    /// derivative along `v`.
    #[inline]
    pub fn parametrise_sphere(&mut self) {
        let Pending::Sphere { radius } = self.pending else {
            return;
        };
        let n = self.ng;
        let mut phi = n.y.atan2(n.x);
        if phi < 0.0 {
            phi += TAU;
        }
        let theta = n.z.clamp(-1.0, 1.0).acos();
        let (sin_phi, cos_phi) = phi.sin_cos();
        let ring = (n.x * n.x + n.y * n.y).sqrt();
        self.dpdu = Vec3A::new(-n.y, n.x, 0.0) * (TAU * radius);
        self.dpdv = Vec3A::new(n.z * cos_phi, n.z * sin_phi, -ring) * (PI * radius);
        self.uv = Vec2::new(phi / TAU, theta / PI);
        self.pending = Pending::None;
    }

    /// The hit position pushed off the surface along the geometric normal, on the side of `dir`.
    /// This is the cure for the report's "shadow acne" (section 2.7), scaled to the scene.
    #[inline]
    pub fn offset_origin(&self, dir: Vec3A) -> Vec3A {
        let eps = self.spawn_epsilon();
        let side = if self.ng.dot(dir) >= 0.0 { 1.0 } else { -1.0 };
        self.p + self.ng * (eps * side)
    }

    /// How far [`Hit::offset_origin`] pushes a ray's origin off the surface.
    #[inline]
    pub fn spawn_epsilon(&self) -> f32 {
        (ABSOLUTE_OFFSET + RELATIVE_OFFSET * self.p.abs().max_element()).max(self.spawn_offset)
    }

    /// A ray leaving the surface in direction `dir` (unit length).
    #[inline]
    pub fn spawn_ray(&self, dir: Vec3A) -> Ray {
        Ray {
            medium: self.media.towards(self.ng, dir),
            ..Ray::new(self.offset_origin(dir), dir)
        }
    }

    /// A shadow ray from this surface towards `target` (a point on a light), stopping short
    /// of it by the same margin spawned rays keep from surfaces, so that it cannot hit the
    /// light's own surface at any scene scale.
    #[inline]
    pub fn spawn_ray_to(&self, target: Vec3A) -> Ray {
        let d = target - self.p;
        let origin = self.offset_origin(d);
        let to = target - origin;
        let dist = to.length();
        let margin = (2.0 * (ABSOLUTE_OFFSET + RELATIVE_OFFSET * target.abs().max_element()))
            .max(1e-4 * dist);
        Ray {
            origin,
            dir: to / dist,
            tmax: (dist - margin).max(0.0),
            medium: self.media.towards(self.ng, d),
        }
    }

    /// A connection from this surface to the surface point of `other` (two path vertices): a
    /// shadow ray as [`Hit::spawn_ray_to`] towards `other.p`, or, where `other` keeps spawned
    /// rays a width away (a curve's hit, inside the fibre it models), towards that point pushed
    /// off `other` as far towards this one, so that the fibre around `other` does not block
    /// the connection to it (pbrt-v4's `SpawnRayTo` between two interactions).
    #[inline]
    pub fn spawn_ray_between(&self, other: &Hit) -> Ray {
        if other.spawn_offset > 0.0 {
            self.spawn_ray_to(other.offset_origin(self.p - other.p))
        } else {
            self.spawn_ray_to(other.p)
        }
    }

    /// The shading frame at the hit: `z` the shading normal, `x` the tangent `dpdu` made
    /// orthogonal to it where the shape has one (anisotropic materials follow it).
    #[inline]
    pub fn frame(&self) -> Frame {
        Frame::from_normal_and_tangent(self.ns, self.dpdu)
    }
}

/// An orthonormal basis with `n` as its `z` axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3A,
    pub t: Vec3A,
    pub n: Vec3A,
}

impl Frame {
    /// Builds a frame around a unit normal (Duff et al. 2017, branchless).
    #[inline]
    pub fn from_normal(n: Vec3A) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3A::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3A::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame around a unit normal whose `s` axis is `tangent` made orthogonal to it
    /// (Gram-Schmidt, as Mitsuba 3's shading frames); [`Frame::from_normal`] where the tangent
    /// vanishes or is parallel to the normal.
    #[inline]
    pub fn from_normal_and_tangent(n: Vec3A, tangent: Vec3A) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len2 = s.length_squared();
        let threshold = 1e-12 * tangent.length_squared().max(f32::MIN_POSITIVE);
        if !len2.is_finite() || len2 <= threshold {
            return Frame::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3A) -> Vec3A {
        Vec3A::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3A) -> Vec3A {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// The regular icosahedron inscribed in the unit sphere: its 12 vertices and 20 faces
/// (counter-clockwise seen from outside). The base of every icosphere: subdivided and
/// projected onto the sphere by the scene's procedural mesh and by the test scenes.
pub fn icosahedron() -> ([Vec3A; 12], [[u32; 3]; 20]) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let vertices = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .map(|(x, y, z)| Vec3A::new(x, y, z).normalize());
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (vertices, faces)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A connection to a curve's hit ends a width off it, towards the other end; to any
    /// other surface, exactly as a shadow ray to its point.
    #[test]
    fn connections_end_outside_a_curves_fibre() {
        let here = Hit::new(1.0, Vec3A::new(0.0, 0.0, 5.0), Vec3A::Z, 0, None);
        let plain = Hit::new(1.0, Vec3A::new(0.3, 0.0, 0.0), -Vec3A::Z, 0, None);
        let (a, b) = (here.spawn_ray_between(&plain), here.spawn_ray_to(plain.p));
        assert_eq!((a.origin, a.dir, a.tmax), (b.origin, b.dir, b.tmax));
        let fibre = Hit {
            spawn_offset: 0.1,
            ..plain
        };
        let r = here.spawn_ray_between(&fibre);
        let end = r.origin + r.dir * r.tmax;
        // Pushed off along the normal towards `here` (-z faces away: +z side).
        assert!(end.z > 0.099 && end.z < 0.1 + 1e-3, "{end}");
        assert!((end.x - 0.3).abs() < 1e-3, "{end}");
    }

    #[test]
    fn a_ray_carries_its_medium_in_the_padding() {
        assert_eq!(std::mem::size_of::<Ray>(), 48);
        // A spawned ray enters the medium on the side it leaves towards.
        let hit = Hit {
            media: MediumInterface {
                inside: MediumId(0),
                outside: MediumId::VACUUM,
            },
            ..Hit::new(1.0, Vec3A::ZERO, Vec3A::Z, 0, None)
        };
        assert_eq!(hit.spawn_ray(Vec3A::Z).medium, MediumId::VACUUM);
        assert_eq!(hit.spawn_ray(-Vec3A::Z).medium, MediumId(0));
        assert_eq!(
            hit.spawn_ray_to(Vec3A::new(0.0, 0.0, -2.0)).medium,
            MediumId(0)
        );
        assert!(Ray::new(Vec3A::ZERO, Vec3A::X).medium.is_vacuum());
    }

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        for n in [
            Vec3A::Z,
            -Vec3A::Z,
            Vec3A::X,
            Vec3A::new(0.3, -0.5, 0.8).normalize(),
            Vec3A::new(-0.01, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.cross(f.t).dot(n) > 0.999, "frame must be right-handed");
            let v = Vec3A::new(0.2, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn sphere_frames_follow_the_parametrisation_around_z() {
        // Mitsuba 3's sphere: the first tangent runs around the z axis (dp/du), made
        // orthogonal to the shading normal; at the poles, where dp/du vanishes, the frame of
        // the normal alone.
        let ray = Ray::new(
            Vec3A::new(3.0, 1.0, 0.5),
            Vec3A::new(-1.0, -0.3, -0.1).normalize(),
        );
        let hit = Hit::on_sphere(&ray, 2.0, Vec3A::ZERO, 1.0, 0, None);
        let f = hit.frame();
        let n = hit.ns;
        let expected = Vec3A::new(-n.y, n.x, 0.0).normalize();
        assert!(
            (f.s - expected).length() < 1e-5,
            "{:?} vs {expected:?}",
            f.s
        );
        assert!(f.s.cross(f.t).dot(n) > 0.9999 && f.s.dot(f.t).abs() < 1e-6);
        let pole = Hit::on_sphere(
            &Ray::new(Vec3A::Z * 3.0, -Vec3A::Z),
            2.0,
            Vec3A::ZERO,
            1.0,
            0,
            None,
        );
        let g = pole.frame();
        let h = Frame::from_normal(pole.ns);
        assert!((g.s - h.s).length() < 1e-6 && (g.t - h.t).length() < 1e-6);
        // Triangles have no parametrisation here: the normal's frame, as before.
        let flat = Hit::new(
            1.0,
            Vec3A::ZERO,
            Vec3A::new(0.3, 0.1, 0.9).normalize(),
            0,
            None,
        );
        let (a, b) = (flat.frame(), Frame::from_normal(flat.ns));
        assert_eq!((a.s, a.t, a.n), (b.s, b.t, b.n));
    }

    #[test]
    fn shadow_rays_stop_short_of_the_target() {
        let hit = Hit::new(1.0, Vec3A::ZERO, Vec3A::Z, 0, None);
        let r = hit.spawn_ray_to(Vec3A::new(0.0, 0.0, 2.0));
        assert!(r.origin.z > 0.0 && r.tmax < 2.0 && r.tmax > 1.99);
        let below = hit.spawn_ray(-Vec3A::Z);
        assert!(
            below.origin.z < 0.0,
            "transmitted rays leave from the far side"
        );
    }
}
