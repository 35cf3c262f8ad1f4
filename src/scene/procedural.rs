//! Procedural meshes: a subdivided icosahedron projected onto the unit sphere, optionally
//! displaced along its normals by smooth pseudo-random bumps. Subdivision level `n` gives
//! `20 * 4^n` triangles (level 8: 1,310,720, the size of the Embree anchor mesh).

use glam::Vec3A;
use std::collections::HashMap;

/// Positions and triangles of an icosphere of radius 1 with `subdivisions` levels, each vertex
/// moved along its normal by `displacement * bump(p)` with `bump` in [-1, 1].
pub fn icosphere(subdivisions: u32, displacement: f32) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let (vertices, faces) = raylab_integrators::geometry::icosahedron();
    let mut positions: Vec<Vec3A> = vertices.to_vec();
    let mut triangles: Vec<[u32; 3]> = faces.to_vec();
    for _ in 0..subdivisions {
        let mut midpoint: HashMap<(u32, u32), u32> =
            HashMap::with_capacity(triangles.len() * 3 / 2);
        let mut split = |a: u32, b: u32, positions: &mut Vec<Vec3A>| -> u32 {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = split(a, b, &mut positions);
            let bc = split(b, c, &mut positions);
            let ca = split(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    if displacement != 0.0 {
        for p in &mut positions {
            *p *= 1.0 + displacement * bump(*p);
        }
    }
    (positions, triangles)
}

/// A smooth function on the sphere with values in [-1, 1]: a few sine waves.
fn bump(p: Vec3A) -> f32 {
    let a = (7.0 * p.x + 3.0).sin() * (5.0 * p.y + 1.0).sin();
    let b = (11.0 * p.z + 2.0 * p.x).sin();
    let c = (23.0 * p.y - 13.0 * p.z).sin() * 0.5;
    (a * 0.5 + b * 0.3 + c * 0.4).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_closedness() {
        for n in 0..4 {
            let (p, t) = icosphere(n, 0.0);
            assert_eq!(t.len(), 20 * 4usize.pow(n));
            // A closed genus-0 mesh: V - E + F = 2, with E = 3F/2.
            assert_eq!(
                p.len() as i64 - (3 * t.len() / 2) as i64 + t.len() as i64,
                2
            );
            assert!(p.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
        }
        // Faces wind counter-clockwise seen from outside: normals point away from the centre.
        let (p, t) = icosphere(2, 0.0);
        for [a, b, c] in t {
            let (a, b, c) = (p[a as usize], p[b as usize], p[c as usize]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
        let (p, _) = icosphere(3, 0.1);
        assert!(p
            .iter()
            .all(|v| v.length() >= 0.9 - 1e-5 && v.length() <= 1.1 + 1e-5));
        assert!(
            p.iter().any(|v| (v.length() - 1.0).abs() > 0.01),
            "displacement moves vertices"
        );
    }
}
