use super::*;
use crate::build::primitives::{intersect_triangle, occludes_triangle};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

fn random_triangles(n: usize, seed: u64) -> Vec<[Vec3A; 3]> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut p = || Vec3A::new(rng.random(), rng.random(), rng.random());
    (0..n)
        .map(|_| {
            let c = p() * 10.0;
            [c, c + p() - 0.5, c + p() - 0.5]
        })
        .collect()
}

/// Rays from inside and outside the triangles' bounds, some along the axes (zero direction
/// components) and some short.
fn random_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let o = Vec3A::new(rng.random(), rng.random(), rng.random()) * 14.0 - 2.0;
            let d = match i % 5 {
                0 => [Vec3A::X, Vec3A::NEG_Y, Vec3A::Z][i % 3],
                _ => (Vec3A::new(rng.random(), rng.random(), rng.random()) - 0.5)
                    .normalize_or(Vec3A::X),
            };
            let tmax = if i % 7 == 0 { 2.0 } else { f32::INFINITY };
            Ray::new(o, d, 0.0, tmax)
        })
        .collect()
}

fn build(tris: &[[Vec3A; 3]]) -> (Bvh4, Vec<[Vec3A; 3]>) {
    let (bvh, order) = Bvh4::build(tris.len(), |i| Aabb::from_points(&tris[i]));
    let mut seen = vec![false; tris.len()];
    for &i in &order {
        assert!(!seen[i as usize], "primitive {i} twice in the order");
        seen[i as usize] = true;
    }
    assert!(
        seen.iter().all(|&s| s),
        "a primitive is missing from the order"
    );
    let ordered = order.iter().map(|&i| tris[i as usize]).collect();
    (bvh, ordered)
}

/// Closest and any hit agree with testing every triangle, on every ray.
fn check_against_brute_force(tris: &[[Vec3A; 3]], rays: &[Ray]) {
    let (bvh, ordered) = build(tris);
    assert!(bvh.depth() <= builder::MAX_DEPTH, "depth {}", bvh.depth());
    let mut hits = 0;
    for ray in rays {
        let brute = ordered
            .iter()
            .map(|t| intersect_triangle(t, ray))
            .fold(f32::INFINITY, f32::min);
        let found = bvh.closest(ray, |r, k| intersect_triangle(&ordered[k], r));
        match found {
            Some((k, t)) => {
                assert_eq!(t, brute, "closest distance for {ray:?}");
                assert_eq!(intersect_triangle(&ordered[k], ray), t);
                hits += 1;
            }
            None => assert!(brute.is_infinite(), "missed a hit at {brute} for {ray:?}"),
        }
        let any_brute = ordered
            .iter()
            .any(|t| occludes_triangle(t, ray).is_finite());
        let any = bvh.any(ray, |r, k| occludes_triangle(&ordered[k], r).is_finite());
        assert_eq!(any, any_brute, "any hit for {ray:?}");
    }
    // The rays must mostly hit for the comparison to mean something (not for tiny inputs).
    if tris.len() >= 1000 {
        assert!(
            hits * 4 > rays.len(),
            "only {hits} of {} rays hit",
            rays.len()
        );
    }
}

#[test]
fn closest_and_any_hit_match_brute_force() {
    for (n, seed) in [(1, 1), (3, 2), (5, 3), (17, 4), (300, 5), (5000, 6)] {
        check_against_brute_force(&random_triangles(n, seed), &random_rays(2000, seed + 100));
    }
}

#[test]
fn empty_bvh_has_no_hits() {
    let (bvh, order) = Bvh4::build(0, |_| unreachable!());
    assert!(order.is_empty());
    let ray = Ray::new_inf(Vec3A::ZERO, Vec3A::X);
    assert_eq!(bvh.closest(&ray, |_, _| 0.0), None);
    assert!(!bvh.any(&ray, |_, _| true));
}

/// Inputs that defeat the SAH: every triangle the same, and triangles at exponentially
/// shrinking offsets (each split peels off one). The depth stays within the stack's bound.
#[test]
fn degenerate_inputs_stay_shallow_and_correct() {
    let same = vec![[Vec3A::ZERO, Vec3A::X, Vec3A::Y]; 10_000];
    let (bvh, _) = build(&same);
    assert!(bvh.depth() <= 10, "equal boxes: depth {}", bvh.depth());
    let ray = Ray::new_inf(Vec3A::new(0.2, 0.2, -1.0), Vec3A::Z);
    assert_eq!(
        bvh.closest(&ray, |r, _| intersect_triangle(&same[0], r))
            .map(|h| h.1),
        Some(1.0)
    );

    let peeled: Vec<[Vec3A; 3]> = (0..120)
        .map(|k| {
            let x = 0.8f32.powi(k);
            [
                Vec3A::new(x, 0.0, 0.0),
                Vec3A::new(x, 1.0, 0.0),
                Vec3A::new(x, 0.0, 1.0),
            ]
        })
        .collect();
    check_against_brute_force(&peeled, &random_rays(2000, 9));
}

/// The tree and the order are the same on one thread and on several, bit for bit (the
/// inputs are large enough for the parallel scans and builds).
#[test]
fn build_is_independent_of_the_thread_count() {
    let tris = random_triangles(60_000, 11);
    let on = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| Bvh4::build(tris.len(), |i| Aabb::from_points(&tris[i])))
    };
    let ((a, order_a), (b, order_b)) = (on(1), on(3));
    assert_eq!(order_a, order_b);
    assert_eq!(a.nodes.len(), b.nodes.len());
    let bits = |n: &Node| {
        let planes = n
            .planes
            .map(|p| p.map(|g| g.map(|v| v.to_array().map(f32::to_bits))));
        (planes, n.child, n.count)
    };
    assert!(a
        .nodes
        .iter()
        .zip(&b.nodes)
        .all(|(x, y)| bits(x) == bits(y)));
}
