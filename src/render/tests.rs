//! The render loop's tests: sample placement, determinism, filters, splats, dropped samples.

use super::*;
use crate::scene::parse_scene;
use crate::scene::RenderScene;
use raylab_integrators::spectrum::Wavelengths;
use raylab_integrators::{Ray, RayIntegrator, Spectrum};

/// Returns 1 everywhere.
struct One;

impl RayIntegrator for One {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        sampler: &mut Sampler,
        _lambda: &mut Wavelengths,
    ) -> Spectrum {
        let _ = (tracer.camera(ray), sampler.next_1d());
        Spectrum::ONE
    }
}

/// Returns NaN for rays well right of the image centre, 1 elsewhere.
struct Poisoned;

impl RayIntegrator for Poisoned {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        _sampler: &mut Sampler,
        _lambda: &mut Wavelengths,
    ) -> Spectrum {
        tracer.camera(ray);
        if ray.dir.x > 0.2 {
            Spectrum::splat(f32::NAN)
        } else {
            Spectrum::ONE
        }
    }
}

/// Radiance 1e17 (finite, but beyond what a block's exact sums hold) right of the
/// image centre, 1 elsewhere: a lamp too bright to sum.
struct Blinding;

impl RayIntegrator for Blinding {
    fn radiance(
        &self,
        ray: &Ray,
        tracer: &mut Tracer,
        _sampler: &mut Sampler,
        _lambda: &mut Wavelengths,
    ) -> Spectrum {
        tracer.camera(ray);
        if ray.dir.x > 0.2 {
            Spectrum::splat(1e17)
        } else {
            Spectrum::ONE
        }
    }
}

/// Samples too bright to sum are dropped and counted at every sample count, also when
/// the render ends inside its first block of passes (1 to 7 spp), where no block closed.
#[test]
fn samples_beyond_the_exact_sums_are_counted_in_an_unfinished_block_too() {
    let (s, cam) = scene();
    let mut counts = Vec::new();
    for spp in [1, 3, 7, 8, 9] {
        let (film, stats) = render(&s, &cam, &mut Blinding, &settings(spp, 2)).unwrap();
        assert!(stats.dropped.count > 0, "{spp} spp: nothing counted");
        let first = stats.dropped.first.unwrap();
        assert!(first.x > 10, "{spp} spp: {first:?}");
        assert!(film.pixels.iter().all(|p| p.is_finite()));
        assert_eq!(film.pixels[19], glam::Vec3::ZERO, "{spp} spp");
        counts.push(stats.dropped.count);
    }
    // One per pixel and block: more pixels reached as samples spread over their pixels,
    // and at 9 spp a second block begun beside the closed one.
    assert!(
        counts[0] <= counts[1] && counts[1] <= counts[2],
        "{counts:?}"
    );
    assert!(counts[4] > counts[3] + counts[3] / 2, "{counts:?}");
}

fn scene() -> (RenderScene, Camera) {
    let text = r#"(camera: LookAt(eye: (0, 0, 5), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40, resolution: (20, 10)),
        materials: {"w": Lambert(albedo: (0.5, 0.5, 0.5))},
        environment: (1, 0.5, 0.25),
        entities: [(shape: Sphere(radius: 1), material: "w")])"#;
    let loaded = parse_scene(text, std::path::Path::new("t.ron")).unwrap();
    (RenderScene::build(&loaded), loaded.camera)
}

fn settings(spp: u32, threads: usize) -> RenderSettings {
    RenderSettings::fixed(spp, 3, Some(threads))
}

#[test]
fn counts_every_camera_ray_and_averages_samples() {
    let (s, cam) = scene();
    let (film, stats) = render(&s, &cam, &mut One, &settings(5, 2)).unwrap();
    assert_eq!(stats.samples, 20 * 10 * 5);
    assert_eq!(stats.rays.camera, 1000);
    assert_eq!(stats.dropped.count, 0);
    assert!(film.pixels.iter().all(|p| *p == glam::Vec3::ONE));
    assert!(film.variance.iter().all(|v| *v == glam::Vec3::ZERO));
}

#[test]
fn non_finite_samples_are_dropped_counted_and_located() {
    let (s, cam) = scene();
    let (film, stats) = render(&s, &cam, &mut Poisoned, &settings(4, 2)).unwrap();
    assert!(
        stats.dropped.count > 0 && stats.dropped.count < 800,
        "{}",
        stats.dropped.count
    );
    let first = stats.dropped.first.unwrap();
    // The first in raster order is on the top row, right of centre.
    assert_eq!(first.y, 0);
    assert!(first.x > 10);
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    // Dropped samples count as zero in the average: the far right column is black.
    assert_eq!(film.pixels[19], glam::Vec3::ZERO);
}

fn path_tracer() -> Box<dyn Integrator> {
    raylab_integrators::find("path")
        .unwrap()
        .instantiate(&[])
        .unwrap()
}

#[test]
fn image_does_not_depend_on_thread_count() {
    let (s, cam) = scene();
    let mut path = path_tracer();
    let (a, _) = render(&s, &cam, path.as_mut(), &settings(3, 1)).unwrap();
    let (b, _) = render(&s, &cam, path.as_mut(), &settings(3, 2)).unwrap();
    let (c, _) = render(&s, &cam, path.as_mut(), &settings(3, 5)).unwrap();
    assert!(
        a.pixels.iter().any(|p| p.x > 0.0),
        "the scene must be lit for the test to mean anything"
    );
    assert_eq!(a, b);
    assert_eq!(a, c);
}

/// Every sampler, and `restir` (whose pass builds reservoirs for the whole image in
/// parallel), renders the same image at any thread count.
#[test]
fn every_sampler_and_restir_are_independent_of_the_thread_count() {
    let (s, cam) = scene();
    for (name, kind) in raylab_integrators::sampler::SamplerKind::ALL {
        let with = |threads| RenderSettings {
            sampler: kind,
            ..settings(4, threads)
        };
        let mut path = path_tracer();
        let (a, _) = render(&s, &cam, path.as_mut(), &with(1)).unwrap();
        let (b, _) = render(&s, &cam, path.as_mut(), &with(3)).unwrap();
        assert_eq!(a, b, "{name}");
    }
    let mut restir = raylab_integrators::find("restir")
        .unwrap()
        .instantiate(&[])
        .unwrap();
    let (a, _) = render(&s, &cam, restir.as_mut(), &settings(3, 1)).unwrap();
    let (b, _) = render(&s, &cam, restir.as_mut(), &settings(3, 3)).unwrap();
    assert!(a.pixels.iter().any(|p| p.x > 0.0));
    assert_eq!(a, b);
}

/// A light-path stand-in: returns nothing for its own sample and splats radiance at
/// film positions of its own choosing (a random one, and always the image's centre).
struct Splatter;

impl Integrator for Splatter {
    fn sample(&self, cx: SampleContext) -> Spectrum {
        let SampleContext {
            pixel,
            camera,
            tracer,
            sampler,
            splats,
            ..
        } = cx;
        tracer.camera(&camera.ray(pixel.film.x, pixel.film.y));
        let anywhere = sampler.next_2d() * Vec2::new(camera.width as f32, camera.height as f32);
        splats.add(
            anywhere,
            Spectrum::splat(sampler.next_1d()),
            &Wavelengths::Rgb,
        );
        let centre = Vec2::new(camera.width as f32, camera.height as f32) * 0.5;
        splats.add(centre, Spectrum::splat(0.001), &Wavelengths::Rgb);
        Spectrum::ZERO
    }
}

fn with_filter(spp: u32, threads: usize, filter: &str) -> RenderSettings {
    RenderSettings {
        filter: filter.parse().unwrap(),
        ..settings(spp, threads)
    }
}

#[test]
fn every_filter_averages_a_constant_to_itself() {
    // Weights are normalised per pixel: a constant image stays constant at the borders too.
    let (s, cam) = scene();
    for filter in ["box", "tent", "gaussian"] {
        let (film, stats) = render(&s, &cam, &mut One, &with_filter(3, 2, filter)).unwrap();
        assert_eq!(stats.rays.camera, 600);
        assert!(
            film.pixels
                .iter()
                .all(|p| (*p - glam::Vec3::ONE).abs().max_element() < 1e-6),
            "{filter}"
        );
    }
}

#[test]
fn wider_filters_blur_and_stay_independent_of_the_thread_count() {
    let (s, cam) = scene();
    let mut path = path_tracer();
    let (boxed, _) = render(&s, &cam, path.as_mut(), &with_filter(4, 2, "box")).unwrap();
    for filter in ["tent", "gaussian"] {
        let (a, _) = render(&s, &cam, path.as_mut(), &with_filter(4, 1, filter)).unwrap();
        let (b, _) = render(&s, &cam, path.as_mut(), &with_filter(4, 2, filter)).unwrap();
        let (c, _) = render(&s, &cam, path.as_mut(), &with_filter(4, 7, filter)).unwrap();
        assert_eq!(a, b, "{filter}");
        assert_eq!(a, c, "{filter}");
        // Blurring lowers the pixel-to-pixel differences of the noisy image.
        let roughness = |f: &Film| -> f32 {
            f.pixels
                .windows(2)
                .map(|w| (w[0] - w[1]).abs().element_sum())
                .sum()
        };
        assert!(roughness(&a) < roughness(&boxed), "{filter}");
    }
}

#[test]
fn splats_are_averaged_over_passes_deterministically_and_survive_resume() {
    let (s, cam) = scene();
    let total = |f: &Film| f.pixels.iter().map(|p| p.x as f64).sum::<f64>();
    for filter in ["box", "gaussian"] {
        let (a, _) = render(&s, &cam, &mut Splatter, &with_filter(6, 1, filter)).unwrap();
        let (b, _) = render(&s, &cam, &mut Splatter, &with_filter(6, 3, filter)).unwrap();
        assert_eq!(a, b, "{filter}");
        // Each pass splats 200 values of mean 1/2 (and 200 x 0.001 at the centre): the
        // image's sum estimates 100.2 per pass, averaged over passes (standard error
        // 1.7). The Gaussian loses the part of its footprint that leaves the image (a
        // few percent on a 20 x 10 image).
        let sum = total(&a);
        if filter == "box" {
            assert!((sum - 100.2).abs() < 6.0, "{filter}: {sum}");
            // The centre pixel holds its 0.2 per pass on top of the random splats.
            let centre = a.pixels[(5 * 20 + 10) as usize].x;
            assert!(centre > 0.15, "{filter}: {centre}");
        } else {
            assert!(sum > 85.0 && sum < 100.2 + 6.0, "{filter}: {sum}");
        }
        // Batch means give splatted pixels an error estimate.
        assert!(a.variance.iter().any(|v| v.x > 0.0), "{filter}");

        // Three passes, a checkpoint, three more: the same bits.
        let run_to = |spp: u32, acc: &mut Accumulation| {
            let settings = with_filter(spp, 2, filter);
            render_passes(
                &s,
                &cam,
                &mut Splatter,
                &settings,
                acc,
                &|| false,
                &mut |_, _| Ok(()),
            )
            .unwrap();
        };
        let mut acc = Accumulation::new(cam.width, cam.height);
        run_to(3, &mut acc);
        let bytes = checkpoint::encode(&acc, 9);
        let mut acc = checkpoint::decode(&bytes, 9, cam.width, cam.height).unwrap();
        run_to(6, &mut acc);
        assert_eq!(acc.film(), a, "{filter}");
    }
}

#[test]
fn strata_are_visited_in_a_scrambled_order_that_covers_the_pixel_early() {
    // With 10000 spp (100 x 100 strata), the first 16 samples must already spread over
    // the pixel's height, not sit in its top row of strata.
    for (x, y) in [(0, 0), (5, 9), (1000, 3)] {
        let ys: Vec<f32> = (0..16)
            .map(|s| {
                let mut sampler = Sampler::new(1, 0, s as u64);
                sample_position(x, y, s, Some(10_000), 1, &mut sampler).y - y as f32
            })
            .collect();
        assert!(
            ys.iter().any(|v| *v > 0.5) && ys.iter().any(|v| *v < 0.5),
            "{ys:?}"
        );
    }
    // And the order is a permutation: every stratum exactly once.
    let mut seen = vec![false; 10_000];
    for s in 0..10_000 {
        let c = permute(s, 10_000, 77) as usize;
        assert!(!seen[c]);
        seen[c] = true;
    }
}

#[test]
fn samples_are_stratified_within_the_pixel() {
    let mut positions = Vec::new();
    for s in 0..16 {
        let mut sampler = Sampler::new(0, 0, s);
        positions.push(sample_position(0, 0, s as u32, Some(16), 0, &mut sampler));
    }
    // 16 spp: one sample in each cell of a 4x4 grid.
    for j in 0..4 {
        for i in 0..4 {
            let n = positions
                .iter()
                .filter(|p| (p.x * 4.0) as u32 == i && (p.y * 4.0) as u32 == j)
                .count();
            assert_eq!(n, 1, "cell ({i}, {j})");
        }
    }
}

/// A tile holds each pixel's exact sums in two limbs; sums beyond them (2^31 in magnitude,
/// of either sign) keep their top limbs beside, and lose them again when they come back in
/// range: every value comes back exactly.
#[test]
fn sums_beyond_the_narrow_limbs_are_kept_exactly() {
    use super::exact::{Exact, Exact3};
    let totals = |v: f64| {
        let e = Exact::from_f64(v).unwrap();
        let small = Exact::from_f64(v * 1e-12).unwrap();
        PixelTotals {
            sum: Exact3([e, small, e]),
            weight: e,
            splat: Exact3([small; 3]),
            batch: Exact3([e; 3]),
            batch_sq: Exact3([small, e, small]),
        }
    };
    let mut tile = TileAccumulator::new(0, 0, 4, 4);
    let values = [
        (3, 1e12),
        (1, -5e9),
        (2, 1.5),
        (0, -2.0),
        (5, 2_147_483_647.5),
    ];
    for (k, v) in values {
        tile.set_totals(k, &totals(v));
    }
    for (k, v) in values {
        assert_eq!(tile.totals(k), totals(v), "pixel {k}");
    }
    assert_eq!(
        tile.wide.len(),
        2,
        "only 1e12 and -5e9 need their top limbs"
    );
    tile.set_totals(3, &totals(7.0));
    assert_eq!(tile.totals(3), totals(7.0));
    assert_eq!(tile.wide.len(), 1);
    // Exact additions that cross the boundary.
    let mut t = tile.totals(2);
    t.add(&totals(2e9));
    t.add(&totals(2e9));
    tile.set_totals(2, &t);
    assert_eq!(tile.totals(2).weight.to_f64(), 4e9 + 1.5);
    assert_eq!(tile.wide.len(), 2);
    assert_eq!(tile.totals(0), totals(-2.0));
    assert_eq!(tile.totals(4), PixelTotals::default());
}
