//! Micro-benchmarks (criterion): BVH traversal, each BSDF's sample and eval, and one pixel of
//! each integrator on the report's room. Run with `cargo bench`; `raylab bench` measures the
//! whole-program rates.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::{Vec2, Vec3A};
use raylab::bench::{coherent_rays, incoherent_rays};
use raylab::scene::parse_scene;
use raylab::scene::RenderScene;
use raylab_integrators::bsdf::{Conductor, Dielectric, Lambert, OrenNayar, Phong};
use raylab_integrators::{
    Material, PixelSample, SampleContext, Sampler, Scene, Spectrum, Splats, Tracer,
};
use std::path::Path;

fn room() -> (RenderScene, raylab::scene::Camera) {
    let loaded = parse_scene(
        include_str!("../scenes/report_room.ron"),
        Path::new("scenes/report_room.ron"),
    )
    .unwrap();
    (RenderScene::build(&loaded), loaded.camera)
}

fn traversal(c: &mut Criterion) {
    let (scene, camera) = room();
    let coherent = coherent_rays(&camera, 4096);
    let incoherent = incoherent_rays(scene.bounds(), 4096);
    let mut g = c.benchmark_group("traversal (4096 rays, report room)");
    g.bench_function("closest, coherent", |b| {
        b.iter(|| {
            coherent
                .iter()
                .filter(|r| scene.intersect(r).is_some())
                .count()
        })
    });
    g.bench_function("closest, incoherent", |b| {
        b.iter(|| {
            incoherent
                .iter()
                .filter(|r| scene.intersect(r).is_some())
                .count()
        })
    });
    g.bench_function("occlusion, incoherent", |b| {
        b.iter(|| incoherent.iter().filter(|r| scene.occluded(r)).count())
    });
    g.finish();
}

fn bsdfs(c: &mut Criterion) {
    let materials = [
        (
            "lambert",
            Material::Lambert(Lambert {
                albedo: Spectrum::splat(0.5),
            }),
        ),
        (
            "oren-nayar",
            Material::OrenNayar(OrenNayar::new(Spectrum::splat(0.5), 20.0)),
        ),
        (
            "phong",
            Material::Phong(Phong {
                kd: Spectrum::splat(0.4),
                ks: Spectrum::splat(0.4),
                exponent: 50.0,
            }),
        ),
        (
            "mirror",
            Material::Conductor(Conductor::perfect_mirror(Spectrum::ONE)),
        ),
        (
            "glass",
            Material::Dielectric(Dielectric::unchecked(1.5, Spectrum::ONE)),
        ),
    ];
    let wo = Vec3A::new(0.3, 0.2, 0.93).normalize();
    let wi = Vec3A::new(-0.4, 0.1, 0.91).normalize();
    let mut g = c.benchmark_group("bsdf");
    for (name, m) in &materials {
        g.bench_function(format!("{name} sample"), |b| {
            let mut u = 0.0f32;
            b.iter(|| {
                u = (u + 0.618_034) % 1.0;
                black_box(m.sample(black_box(wo), u, Vec2::new(u, 1.0 - u)))
            })
        });
        g.bench_function(format!("{name} eval+pdf"), |b| {
            b.iter(|| (m.eval(black_box(wo), black_box(wi)), m.pdf(wo, wi)))
        });
    }
    g.finish();
}

fn integrators(c: &mut Criterion) {
    let (scene, camera) = room();
    // The centre pixel's camera samples, through the integrators' interface directly (no
    // thread pool, no film).
    let pixel = PixelSample {
        x: camera.width / 2,
        y: camera.height / 2,
        film: Vec2::new(camera.width as f32 / 2.0, camera.height as f32 / 2.0),
        index: 0,
    };
    let mut g = c.benchmark_group("one pixel, report room");
    g.sample_size(20);
    for name in ["whitted", "fixed-depth", "russian-roulette", "path"] {
        let integrator = raylab_integrators::find(name)
            .unwrap()
            .instantiate(&[])
            .unwrap();
        let spp = if name == "fixed-depth" { 1 } else { 16 };
        g.bench_function(format!("{name} ({spp} spp)"), |b| {
            b.iter(|| {
                let mut tracer = Tracer::new(&scene);
                let mut splats = Splats::default();
                let mut sum = Spectrum::ZERO;
                for s in 0..spp {
                    let mut sampler = Sampler::new(0, 0, s);
                    sum += integrator.sample(SampleContext {
                        pixel: &pixel,
                        camera: &camera,
                        tracer: &mut tracer,
                        sampler: &mut sampler,
                        splats: &mut splats,
                        lambda: &mut raylab_integrators::spectrum::Wavelengths::Rgb,
                    });
                }
                black_box(sum)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, traversal, bsdfs, integrators);
criterion_main!(benches);
