use super::*;
use crate::accel::primitives::{intersect_triangle, occludes_triangle};
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
            ray(o, d, 0.0, tmax)
        })
        .collect()
}

fn build<L: Leaves>(tris: &[[Vec3A; 3]]) -> (Bvh, Vec<[Vec3A; 3]>) {
    let (bvh, order) = Bvh::build::<L>(tris.len(), |i| Aabb::from_points(&tris[i]));
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

/// The nearest of a leaf's triangles before `r.tmax`, as (position in the order, distance).
fn leaf_closest(tris: &[[Vec3A; 3]]) -> impl FnMut(&Ray, u32, u32) -> Option<(u32, f32)> + '_ {
    move |r, first, count| {
        let mut best = None;
        let mut tmax = r.tmax;
        for k in first..first + count {
            let t = intersect_triangle(&tris[k as usize], r);
            if t < tmax {
                (best, tmax) = (Some((k, t)), t);
            }
        }
        best
    }
}

fn leaf_any(tris: &[[Vec3A; 3]]) -> impl FnMut(&Ray, u32, u32) -> bool + '_ {
    move |r, first, count| {
        (first..first + count).any(|k| occludes_triangle(&tris[k as usize], r).is_finite())
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn closest_avx2(avx2: isa::Avx2, bvh: &Bvh, ray: &Ray, tris: &[[Vec3A; 3]]) -> Option<(u32, f32)> {
    bvh.closest(avx2, ray, leaf_closest(tris))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn any_avx2(avx2: isa::Avx2, bvh: &Bvh, ray: &Ray, tris: &[[Vec3A; 3]]) -> bool {
    bvh.any(avx2, ray, leaf_any(tris))
}

/// The closest hit by the portable node test; where the processor has AVX2, the AVX2 node
/// test must find exactly the same.
fn closest(bvh: &Bvh, ray: &Ray, tris: &[[Vec3A; 3]]) -> Option<(u32, f32)> {
    let portable = bvh.closest(isa::Portable, ray, leaf_closest(tris));
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = isa::Avx2::detect() {
        // SAFETY: the token exists only where the processor has AVX2.
        let found = unsafe { closest_avx2(avx2, bvh, ray, tris) };
        assert_eq!(found, portable, "{ray:?}");
    }
    portable
}

/// Any hit, likewise under both node tests.
fn any(bvh: &Bvh, ray: &Ray, tris: &[[Vec3A; 3]]) -> bool {
    let portable = bvh.any(isa::Portable, ray, leaf_any(tris));
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = isa::Avx2::detect() {
        // SAFETY: as in `closest`.
        let found = unsafe { any_avx2(avx2, bvh, ray, tris) };
        assert_eq!(found, portable, "{ray:?}");
    }
    portable
}

/// Leaves of up to eight primitives tested one at a time.
struct Runs;

impl Leaves for Runs {
    const BLOCK: usize = 1;
    const MAX: usize = MAX_LEAF;
}

/// Closest and any hit agree with testing every triangle, on every ray, for leaves of every
/// kind: runs tested one triangle at a time, packets of four, single primitives.
fn check_against_brute_force<L: Leaves>(tris: &[[Vec3A; 3]], rays: &[Ray]) {
    let (bvh, ordered) = build::<L>(tris);
    assert!(bvh.depth() <= builder::MAX_DEPTH, "depth {}", bvh.depth());
    let mut hits = 0;
    for ray in rays {
        let brute = ordered
            .iter()
            .map(|t| intersect_triangle(t, ray))
            .fold(f32::INFINITY, f32::min);
        match closest(&bvh, ray, &ordered) {
            Some((k, t)) => {
                assert_eq!(t, brute, "closest distance for {ray:?}");
                assert_eq!(intersect_triangle(&ordered[k as usize], ray), t);
                hits += 1;
            }
            None => assert!(brute.is_infinite(), "missed a hit at {brute} for {ray:?}"),
        }
        let any_brute = ordered
            .iter()
            .any(|t| occludes_triangle(t, ray).is_finite());
        assert_eq!(any(&bvh, ray, &ordered), any_brute, "any hit for {ray:?}");
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
        let (tris, rays) = (random_triangles(n, seed), random_rays(2000, seed + 100));
        check_against_brute_force::<Runs>(&tris, &rays);
        check_against_brute_force::<Packets>(&tris, &rays);
        check_against_brute_force::<Singles>(&tris, &rays);
    }
}

#[test]
fn empty_bvh_has_no_hits() {
    let (bvh, order) = Bvh::build::<Runs>(0, |_| unreachable!());
    assert!(order.is_empty());
    let ray = Ray::new_inf(Vec3A::ZERO, Vec3A::X);
    assert_eq!(closest(&bvh, &ray, &[]), None);
    assert!(!any(&bvh, &ray, &[]));
}

/// Inputs that defeat the SAH: every triangle the same, and triangles at exponentially
/// shrinking offsets (each split peels off one). The depth stays within the stack's bound.
#[test]
fn degenerate_inputs_stay_shallow_and_correct() {
    let same = vec![[Vec3A::ZERO, Vec3A::X, Vec3A::Y]; 10_000];
    let (bvh, ordered) = build::<Runs>(&same);
    assert!(bvh.depth() <= 10, "equal boxes: depth {}", bvh.depth());
    let ray = Ray::new_inf(Vec3A::new(0.2, 0.2, -1.0), Vec3A::Z);
    assert_eq!(closest(&bvh, &ray, &ordered).map(|h| h.1), Some(1.0));

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
    check_against_brute_force::<Runs>(&peeled, &random_rays(2000, 9));
    check_against_brute_force::<Packets>(&peeled, &random_rays(2000, 9));
}

/// Leaves renumbered for packets: each leaf's rank indexes its run of the order, the runs
/// cover the order once, in order, and traversal through the renumbered leaves finds what
/// it found before.
#[test]
fn numbered_leaves_index_their_runs_of_the_order() {
    let tris = random_triangles(3000, 21);
    let (mut bvh, ordered) = build::<Packets>(&tris);
    let before = bvh.clone();
    let leaves = bvh.number_leaves(|_| 1);
    let mut next = 0;
    for &(first, count) in &leaves {
        assert_eq!(first, next, "leaves out of order");
        assert!((1..=MAX_LEAF as u32).contains(&count));
        next += count;
    }
    assert_eq!(next as usize, tris.len());
    for ray in &random_rays(1000, 22) {
        let numbered = bvh.closest(isa::Portable, ray, |r, leaf, count| {
            let (first, n) = leaves[leaf as usize];
            assert_eq!(n, count);
            leaf_closest(&ordered)(r, first, n)
        });
        assert_eq!(numbered, closest(&before, ray, &ordered));
    }
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
            .install(|| Bvh::build::<Packets>(tris.len(), |i| Aabb::from_points(&tris[i])))
    };
    let ((a, order_a), (b, order_b)) = (on(1), on(3));
    assert_eq!(order_a, order_b);
    assert_eq!(a.nodes.len(), b.nodes.len());
    let bits = |n: &Node| {
        let planes = n.planes.map(|p| p.map(|g| g.map(f32::to_bits)));
        (planes, n.child, n.count)
    };
    assert!(a
        .nodes
        .iter()
        .zip(&b.nodes)
        .all(|(x, y)| bits(x) == bits(y)));
}

#[test]
fn a_ray_along_an_axis_reaches_a_box_whose_face_is_just_beside_it() {
    // The box ends 1e-6 beside the ray's x. obvhs's inverse of a small direction component
    // (1 / EPSILON) put the box's x exit at t = 8.5, and the triangle at t = 20 was lost.
    let tris = vec![[
        Vec3A::new(0.0, -1.0, 20.0),
        Vec3A::new(0.500001, -1.0, 20.0),
        Vec3A::new(0.500001, 1.0, 20.0),
    ]];
    let (bvh, ordered) = build::<Runs>(&tris);
    for dx in [0.0, -0.0, 1e-9, -1e-9] {
        let r = ray(
            Vec3A::new(0.5, 0.0, 0.0),
            Vec3A::new(dx, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        let hit = closest(&bvh, &r, &ordered);
        assert!(
            hit.is_some_and(|(_, t)| (t - 20.0).abs() < 1e-4),
            "dx {dx}: {hit:?}"
        );
        assert!(any(&bvh, &r, &ordered), "dx {dx}");
    }
}
