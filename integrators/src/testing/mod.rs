//! The testing kit (the `testing` feature, so that the engine's tests and a student's new
//! integrator reuse it): tiny analytic scenes for integrator tests (no BVH: brute-force intersection), and a
//! t-test helper that compares an integrator's mean radiance with an analytic answer.

pub mod chi2;

use crate::bsdf::Lambert;
use crate::integrator::{Integrator, RayIntegrator, Tracer};
use crate::sampler::{SampleSite, SamplerKind};
use crate::sampling::uniform_sphere;
use crate::spectrum::Wavelengths;
use crate::{
    find, Hit, Light, LightTable, Material, MediumId, MediumInterface, Ray, Rgb, Sampler, Scene,
    SurfaceMaterial,
};

pub mod media;
use crate::{PassContext, SampleContext};
use glam::Vec3A;

/// One surface: a triangle or a sphere, with a material and maybe a light.
enum Surface {
    /// A triangle of material 0.
    Triangle { v: [Vec3A; 3], light: Option<u32> },
    /// An emitting triangle of material 1.
    LightTriangle { v: [Vec3A; 3], light: u32 },
    Sphere {
        center: Vec3A,
        radius: f32,
        material: u32,
    },
    /// A sphere that bounds media (`interface`): material `material` (a null one, for a
    /// boundary that does not scatter).
    Boundary {
        center: Vec3A,
        radius: f32,
        material: u32,
        interface: MediumInterface,
    },
    /// An emitting sphere (light `light` of the table), black.
    SphereLight {
        center: Vec3A,
        radius: f32,
        light: u32,
    },
}

/// The unit sphere at the origin, of material 0.
const UNIT_SPHERE: Surface = Surface::Sphere {
    center: Vec3A::ZERO,
    radius: 1.0,
    material: 0,
};

/// Where the probe rays that stand in for camera rays start and where they go.
pub enum Probe {
    /// From a point in uniformly random directions.
    Omni(Vec3A),
    /// From `eye` towards random points of a sphere's silhouette (every ray hits it).
    AtSphere {
        eye: Vec3A,
        center: Vec3A,
        radius: f32,
    },
    /// Always the same ray.
    Fixed(Ray),
}

pub struct TestScene {
    surfaces: Vec<Surface>,
    /// Triangles use material 0; spheres name theirs.
    materials: Vec<SurfaceMaterial>,
    lights: LightTable,
    pub camera: Probe,
    /// Participating media (none in most), and the one the probe rays start in.
    media: Vec<crate::Medium>,
    camera_medium: MediumId,
}

fn intersect_triangle(v: &[Vec3A; 3], ray: &Ray) -> Option<f32> {
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let s = ray.origin - v[0];
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let w = ray.dir.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0 && t < ray.tmax).then_some(t)
}

fn intersect_sphere(c: Vec3A, r: f32, ray: &Ray) -> Option<f32> {
    let oc = ray.origin - c;
    let b = oc.dot(ray.dir);
    let h = r * r - (oc - ray.dir * b).length_squared();
    if h < 0.0 {
        return None;
    }
    let h = h.sqrt();
    [-b - h, -b + h]
        .into_iter()
        .find(|t| *t > 0.0 && *t < ray.tmax)
}

impl Scene for TestScene {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        // A surface that bounds no medium has the ray's on both sides.
        let around = MediumInterface {
            inside: ray.medium,
            outside: ray.medium,
        };
        let mut best: Option<Hit> = None;
        for s in &self.surfaces {
            let tmax = best.map_or(ray.tmax, |h| h.t);
            let r = Ray { tmax, ..*ray };
            let hit = match *s {
                Surface::Triangle { v, light } => intersect_triangle(&v, &r).map(|t| {
                    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                    Hit {
                        media: around,
                        ..Hit::new(t, ray.at(t), n, 0, light)
                    }
                }),
                Surface::LightTriangle { v, light } => intersect_triangle(&v, &r).map(|t| {
                    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                    Hit {
                        media: around,
                        ..Hit::new(t, ray.at(t), n, 1, Some(light))
                    }
                }),
                Surface::Sphere {
                    center,
                    radius,
                    material,
                } => intersect_sphere(center, radius, &r).map(|t| Hit {
                    media: around,
                    ..Hit::on_sphere(&r, t, center, radius, material, None)
                }),
                Surface::SphereLight {
                    center,
                    radius,
                    light,
                } => intersect_sphere(center, radius, &r).map(|t| Hit {
                    media: around,
                    ..Hit::on_sphere(&r, t, center, radius, 1, Some(light))
                }),
                Surface::Boundary {
                    center,
                    radius,
                    material,
                    interface,
                } => intersect_sphere(center, radius, &r).map(|t| Hit {
                    media: interface,
                    ..Hit::on_sphere(&r, t, center, radius, material, None)
                }),
            };
            if hit.is_some() {
                best = hit;
            }
        }
        best
    }

    fn media(&self) -> &[crate::Medium] {
        &self.media
    }

    fn camera_medium(&self) -> MediumId {
        self.camera_medium
    }

    fn occluded(&self, ray: &Ray) -> bool {
        self.intersect(ray).is_some()
    }

    fn material(&self, id: u32) -> &SurfaceMaterial {
        &self.materials[id as usize]
    }

    fn lights(&self) -> &LightTable {
        &self.lights
    }

    fn bounds(&self) -> (Vec3A, Vec3A) {
        (Vec3A::splat(-1.0), Vec3A::splat(1.0))
    }
}

fn lambert(a: f32) -> SurfaceMaterial {
    Material::Lambert(Lambert {
        albedo: crate::Spectrum::splat(a),
    })
    .into()
}

/// A closed furnace seen from inside: a unit icosphere (320 triangles), every face diffuse
/// with albedo `a` and emitting `le` on both sides. Radiance everywhere is `le / (1 - a)`.
///
/// A sphere rather than a box: inside a sphere the geometry term between two surface points
/// is bounded, so light sampling has finite variance. In a box's corners it does not, and
/// sample means converge too slowly for a t-test.
pub fn furnace_sphere(a: f32, le: f32) -> TestScene {
    // Icosahedron, subdivided twice and projected onto the sphere.
    let (v, faces) = crate::geometry::icosahedron();
    let mut tris: Vec<[Vec3A; 3]> = faces.iter().map(|f| f.map(|i| v[i as usize])).collect();
    for _ in 0..2 {
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    (a + b).normalize(),
                    (b + c).normalize(),
                    (c + a).normalize(),
                );
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let mut surfaces = Vec::new();
    let mut lights = Vec::new();
    for v in tris {
        surfaces.push(Surface::Triangle {
            v,
            light: Some(lights.len() as u32),
        });
        lights.push(Light::triangle(v[0], v[1], v[2], Rgb::splat(le), true));
    }
    TestScene {
        surfaces,
        materials: vec![lambert(a)],
        lights: LightTable::new(lights, 1.0),
        camera: Probe::Omni(Vec3A::new(0.1, -0.2, 0.3)),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// pbrt-v4's analytic furnace: the camera inside a diffuse unit sphere of albedo `a` whose
/// inside emits `le` (an analytic sphere light with its normals flipped). Radiance
/// everywhere is `le / (1 - a)`.
pub fn furnace_emitting_sphere(a: f32, le: f32) -> TestScene {
    TestScene {
        surfaces: vec![Surface::SphereLight {
            center: Vec3A::ZERO,
            radius: 1.0,
            light: 0,
        }],
        // Sphere lights of test scenes use material 1.
        materials: vec![lambert(a), lambert(a)],
        lights: LightTable::new(
            vec![Light::sphere_inward(Vec3A::ZERO, 1.0, Rgb::splat(le))],
            1.0,
        ),
        camera: Probe::Omni(Vec3A::new(0.1, -0.2, 0.3)),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// A point light of intensity pi at the centre of the unit sphere, seen from inside; the
/// sphere is diffuse with albedo `a`. Radiance on the sphere: `a / (1 - a)` (1 for a = 0.5).
pub fn point_in_sphere(a: f32) -> TestScene {
    TestScene {
        surfaces: vec![UNIT_SPHERE],
        materials: vec![lambert(a)],
        lights: LightTable::new(
            vec![Light::point(Vec3A::ZERO, Rgb::splat(std::f32::consts::PI))],
            1.0,
        ),
        camera: Probe::Omni(Vec3A::ZERO),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// A convex diffuse unit sphere of albedo `a` under constant environment radiance `sky`:
/// its radiance is `a * sky`.
pub fn sphere_under_sky(a: f32, sky: f32) -> TestScene {
    TestScene {
        surfaces: vec![UNIT_SPHERE],
        materials: vec![lambert(a)],
        lights: LightTable::new(vec![Light::environment(Rgb::splat(sky))], 1.0),
        camera: Probe::AtSphere {
            eye: Vec3A::new(0.0, 0.0, 5.0),
            center: Vec3A::ZERO,
            radius: 1.0,
        },
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// A camera ray of the probe `camera`, placed by `sampler`'s first numbers.
pub fn camera_ray(camera: &Probe, sampler: &mut Sampler) -> Ray {
    match camera {
        Probe::Fixed(r) => *r,
        Probe::Omni(o) => Ray::new(*o, uniform_sphere(sampler.next_2d())),
        Probe::AtSphere {
            eye,
            center,
            radius,
        } => {
            // A point on the silhouette disk (shrunk slightly so every ray hits).
            let to = (*center - *eye).normalize();
            let frame = crate::Frame::from_normal(to);
            let d = crate::sampling::concentric_disk(sampler.next_2d()) * (0.95 * radius);
            let target = *center + frame.s * d.x + frame.t * d.y;
            Ray::new(*eye, (target - *eye).normalize())
        }
    }
}

/// A pinhole camera of `side` x `side` pixels that sees what `probe` probes: from an
/// omnidirectional probe's point a 90 degree view (the analytic scenes are uniform there),
/// within a sphere's silhouette, or a hair's breadth around a fixed ray.
fn probe_camera(probe: &Probe, side: u32) -> crate::Camera {
    let (eye, forward, tan_half) = match *probe {
        Probe::Omni(o) => (o, Vec3A::X, 1.0),
        Probe::Fixed(r) => (r.origin, r.dir, 1e-4),
        Probe::AtSphere {
            eye,
            center,
            radius,
        } => {
            let d = (center - eye).length();
            let silhouette = (radius / d).asin().tan();
            // The image's corners stay inside the silhouette.
            (eye, (center - eye) / d, 0.9 * silhouette / 2f32.sqrt())
        }
    };
    let up = if forward.cross(Vec3A::Z).length() > 1e-3 {
        Vec3A::Z
    } else {
        Vec3A::X
    };
    let fov = 2.0 * f32::atan(tan_half).to_degrees();
    crate::Camera::look_at(eye, eye + forward, up, fov, (side, side))
}

/// One pass's image mean (green): every pixel of `camera` sampled once at a random film
/// position, its estimate plus all the splats of the pass, over the pixel count (the image
/// mean of a box-filtered film).
fn image_pass_mean(
    name: &str,
    integrator: &dyn Integrator,
    camera: &crate::Camera,
    scene: &TestScene,
    (pass, passes): (u32, u32),
    kind: SamplerKind,
    spectral: bool,
) -> f64 {
    let mut tracer = Tracer::new(scene);
    let mut splats = crate::Splats::default();
    let mut sum = 0.0f64;
    for y in 0..camera.height {
        for x in 0..camera.width {
            let site = SampleSite {
                seed: 12345,
                x,
                y,
                width: camera.width,
                height: camera.height,
                sample: pass as u64,
                spp: Some(passes),
            };
            let mut sampler = Sampler::camera(kind, &site);
            let film = glam::Vec2::new(x as f32, y as f32) + sampler.next_2d();
            let mut lambda = wavelengths(spectral, &mut sampler);
            let pixel = crate::PixelSample {
                x,
                y,
                film,
                index: pass,
            };
            let l = integrator.sample(SampleContext {
                pixel: &pixel,
                camera,
                tracer: &mut tracer,
                sampler: &mut sampler,
                splats: &mut splats,
                lambda: &mut lambda,
            });
            let l = lambda.to_rgb(l);
            assert!(l.is_finite(), "{name}: non-finite sample {l:?}");
            sum += l.y as f64;
        }
    }
    // Chains run beside the pixels' (zero) estimates.
    if let crate::Work::Chains { count } = integrator.work(camera) {
        for chain in 0..count {
            integrator.run_chain(
                chain,
                crate::ChainContext {
                    camera,
                    tracer: &mut tracer,
                    splats: &mut splats,
                },
            );
        }
    }
    for (_, l) in splats.entries() {
        assert!(l.is_finite(), "{name}: non-finite splat {l:?}");
        sum += l.y as f64;
    }
    sum / (camera.width * camera.height) as f64
}

/// A camera sample's wavelengths, drawn as the render loop draws them (after the film
/// position).
fn wavelengths(spectral: bool, sampler: &mut Sampler) -> Wavelengths {
    match spectral {
        true => Wavelengths::sample(sampler.next_1d()),
        false => Wavelengths::Rgb,
    }
}

/// A pass's wavelengths, as the render loop gives them.
fn pass_wavelengths(spectral: bool, seed: u64, pass: u32) -> Wavelengths {
    match spectral {
        true => Wavelengths::for_pass(seed, pass),
        false => Wavelengths::Rgb,
    }
}

/// The integrator `name` as an estimator of radiance along probe rays.
fn as_ray_integrator<'a>(name: &str, integrator: &'a dyn Integrator) -> &'a dyn RayIntegrator {
    integrator
        .as_ray_integrator()
        .unwrap_or_else(|| panic!("{name} does not estimate radiance along a ray"))
}

/// Mean and standard error of the green channel over `n` camera samples.
pub fn estimate(name: &str, params: &[(&str, &str)], scene: &TestScene, n: u32) -> (f64, f64) {
    let given: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut integrator = find(name).unwrap().instantiate(&given).unwrap();
    estimate_integrator(integrator.as_mut(), scene, n)
}

/// [`estimate`] for an integrator built by hand (one not in the registry yet, a student's).
pub fn estimate_integrator(
    integrator: &mut dyn Integrator,
    scene: &TestScene,
    n: u32,
) -> (f64, f64) {
    let camera = probe_camera(&scene.camera, 1);
    integrator.prepare_pass(&PassContext {
        scene,
        camera: &camera,
        seed: 12345,
        pass: 0,
        rows: 0..camera.height,
        stop: crate::Stop::NEVER,
        lambda: Wavelengths::Rgb,
    });
    let ray_integrator = integrator
        .as_ray_integrator()
        .expect("the analytic scenes probe integrators with rays: implement RayIntegrator");
    let mut tracer = Tracer::new(scene);
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    // An integrator that walks many paths together is probed in batches of 256, as the
    // render loop hands it a tile's samples.
    let mut batched = Vec::new();
    if let Some(batch) = integrator.as_batch() {
        for first in (0..n).step_by(256) {
            let mut samplers: Vec<Sampler> = (first..n.min(first + 256))
                .map(|i| Sampler::new(12345, i as u64, 0))
                .collect();
            let rays: Vec<Ray> = samplers
                .iter_mut()
                .map(|s| camera_ray(&scene.camera, s))
                .collect();
            let mut lambdas = vec![Wavelengths::Rgb; rays.len()];
            let mut out = vec![crate::Spectrum::ZERO; rays.len()];
            let b = crate::Batch {
                rays: &rays,
                samplers: &mut samplers,
                lambdas: &mut lambdas,
                out: &mut out,
            };
            batch.radiance_batch(b, &mut tracer);
            batched.extend(out);
        }
    }
    for i in 0..n {
        let l = match batched.get(i as usize) {
            Some(l) => *l,
            None => {
                let mut sampler = Sampler::new(12345, i as u64, 0);
                let ray = camera_ray(&scene.camera, &mut sampler);
                ray_integrator.radiance(&ray, &mut tracer, &mut sampler, &mut Wavelengths::Rgb)
            }
        };
        assert!(l.is_finite(), "non-finite sample {l:?}");
        let v = l.y as f64;
        sum += v;
        sum_sq += v * v;
    }
    let mean = sum / n as f64;
    let var = (sum_sq / n as f64 - mean * mean).max(0.0) * n as f64 / (n as f64 - 1.0);
    (mean, (var / n as f64).sqrt())
}

/// Asserts that the integrator's mean radiance matches `expected` by a t-test (|t| < 4, a
/// false alarm rate of 6e-5 per test), and that the test had the power to see a 5% error
/// (standard error below 1/80 of the expected value, so a 5% bias gives t >= 4).
pub fn expect_mean(name: &str, params: &[(&str, &str)], scene: &TestScene, expected: f32, n: u32) {
    let what = format!("{name} {params:?}");
    check_mean(&what, estimate(name, params, scene, n), expected, 4.0);
}

/// [`expect_mean`] for an integrator built by hand.
pub fn expect_mean_of(integrator: &mut dyn Integrator, scene: &TestScene, expected: f32, n: u32) {
    let estimate = estimate_integrator(integrator, scene, n);
    check_mean("the integrator", estimate, expected, 4.0);
}

/// The t-test of [`expect_mean`] on a (mean, standard error) pair, failing at `|t| >= t_max`;
/// a deterministic estimate (no spread) must equal `expected` to 1e-4 (the rounding of the
/// distances it is computed from: Beer's law through a ball is exact once sampled).
fn check_mean(what: &str, (mean, se): (f64, f64), expected: f32, t_max: f64) {
    let expected = expected as f64;
    let t = if se > 1e-6 * expected {
        (mean - expected) / se
    } else if (mean - expected).abs() < 1e-4 * expected {
        0.0
    } else {
        f64::INFINITY
    };
    assert!(
        t.abs() < t_max,
        "{what}: mean {mean:.5} +- {se:.5}, expected {expected:.5} (t = {t:.2})"
    );
    assert!(
        se < expected / 80.0,
        "{what}: standard error {se:.5} too large to detect a 5% bias; use more samples"
    );
}

/// Mean of the green channel over `passes` passes of `per_pass` camera samples, each pass
/// prepared as the render loop prepares it, and the standard error of that mean computed
/// from the spread of the pass means: for integrators whose samples share per-pass state
/// (a photon map), whose errors are correlated within a pass.
pub fn estimate_passes(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    passes: u32,
    per_pass: u32,
) -> (f64, f64) {
    estimate_passes_sampled(
        name,
        params,
        scene,
        passes,
        per_pass,
        SamplerKind::Independent,
    )
}

/// [`estimate_passes`] with camera samples drawn by `sampler`: probe `i`'s sample in pass
/// `k` is sample `k` of pixel `i`, so that over the passes each probe walks its sequence.
/// (Under a low-discrepancy sampler the pass means are negatively correlated, which makes
/// the standard error from their spread an overestimate: the test stays valid.)
pub fn estimate_passes_sampled(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    passes: u32,
    per_pass: u32,
    sampler: SamplerKind,
) -> (f64, f64) {
    estimate_passes_in(name, params, scene, (passes, per_pass), sampler, false)
}

/// [`estimate_passes_sampled`], in spectral mode with `spectral`: every camera sample carries
/// wavelengths drawn as the render loop draws them, every pass its own, and the mean is that
/// of the green channel of the linear sRGB the film makes of them.
pub fn estimate_passes_in(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    (passes, per_pass): (u32, u32),
    sampler: SamplerKind,
    spectral: bool,
) -> (f64, f64) {
    let given: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let mut integrator = find(name).unwrap().instantiate(&given).unwrap();
    let mut means = Vec::with_capacity(passes as usize);
    for pass in 0..passes {
        if integrator.as_ray_integrator().is_none() {
            // Light-path integrators: a camera's whole image, splats and all.
            let side = (per_pass as f64).sqrt().ceil() as u32;
            let camera = probe_camera(&scene.camera, side);
            integrator.prepare_pass(&PassContext {
                scene,
                camera: &camera,
                seed: 12345,
                pass,
                rows: 0..camera.height,
                stop: crate::Stop::NEVER,
                lambda: pass_wavelengths(spectral, 12345, pass),
            });
            means.push(image_pass_mean(
                name,
                integrator.as_ref(),
                &camera,
                scene,
                (pass, passes),
                sampler,
                spectral,
            ));
            continue;
        }
        let camera = probe_camera(&scene.camera, 1);
        integrator.prepare_pass(&PassContext {
            scene,
            camera: &camera,
            seed: 12345,
            pass,
            rows: 0..camera.height,
            stop: crate::Stop::NEVER,
            lambda: pass_wavelengths(spectral, 12345, pass),
        });
        let ray_integrator = as_ray_integrator(name, integrator.as_ref());
        let mut tracer = Tracer::new(scene);
        let mut sum = 0.0f64;
        for i in 0..per_pass {
            let site = SampleSite {
                seed: 12345,
                x: i,
                y: 0,
                width: per_pass,
                height: 1,
                sample: pass as u64,
                spp: Some(passes),
            };
            let mut sampler = Sampler::camera(sampler, &site);
            let ray = camera_ray(&scene.camera, &mut sampler);
            let mut lambda = wavelengths(spectral, &mut sampler);
            let l = ray_integrator.radiance(&ray, &mut tracer, &mut sampler, &mut lambda);
            let l = lambda.to_rgb(l);
            assert!(l.is_finite(), "{name}: non-finite sample {l:?}");
            sum += l.y as f64;
        }
        means.push(sum / per_pass as f64);
    }
    let n = passes as f64;
    let mean = means.iter().sum::<f64>() / n;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

/// [`expect_mean`] for integrators with per-pass state, by [`estimate_passes`]; the t-test
/// has `passes - 1` degrees of freedom, so use 30 passes or more.
pub fn expect_mean_passes(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    expected: f32,
    passes: u32,
    per_pass: u32,
) {
    expect_mean_passes_within(name, params, scene, expected, passes, per_pass, 0.0);
}

/// [`expect_mean_passes`] allowing, besides the noise, a relative bias `bias` (a density
/// estimate's blur, which more passes of the same radius do not shrink).
pub fn expect_mean_passes_within(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    expected: f32,
    passes: u32,
    per_pass: u32,
    bias: f64,
) {
    expect_mean_passes_sampled(
        name,
        params,
        scene,
        expected,
        (passes, per_pass),
        bias,
        SamplerKind::Independent,
    );
}

/// [`expect_mean_passes_within`] with camera samples drawn by `sampler`
/// ([`estimate_passes_sampled`]).
pub fn expect_mean_passes_sampled(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    expected: f32,
    (passes, per_pass): (u32, u32),
    bias: f64,
    sampler: SamplerKind,
) {
    expect_mean_passes_in(
        name,
        params,
        scene,
        expected,
        (passes, per_pass),
        bias,
        (sampler, false),
    );
}

/// [`expect_mean_passes_sampled`], in spectral mode with `spectral`
/// ([`estimate_passes_in`]).
pub fn expect_mean_passes_in(
    name: &str,
    params: &[(&str, &str)],
    scene: &TestScene,
    expected: f32,
    (passes, per_pass): (u32, u32),
    bias: f64,
    (sampler, spectral): (SamplerKind, bool),
) {
    let mode = if spectral { ", spectral" } else { "" };
    let what = format!("{name} {params:?} under {sampler}{mode}");
    let (mean, se) = estimate_passes_in(name, params, scene, (passes, per_pass), sampler, spectral);
    // The mean moved towards `expected` by the allowed bias, at most onto it.
    let e = expected as f64;
    let allowed = bias * e.abs();
    let shifted = if (mean - e).abs() <= allowed {
        e
    } else {
        mean - allowed * (mean - e).signum()
    };
    check_mean(&what, (shifted, se), expected, 4.5);
}

/// The camera inside a closed perfect mirror (a unit sphere) with no light: every path keeps
/// its full throughput forever unless the integrator ends it. Radiance is 0.
pub fn inside_a_mirror() -> TestScene {
    TestScene {
        surfaces: vec![UNIT_SPHERE],
        materials: vec![Material::Conductor(crate::bsdf::Conductor::perfect_mirror(
            crate::Spectrum::ONE,
        ))
        .into()],
        lights: LightTable::new(Vec::new(), 1.0),
        camera: Probe::Omni(Vec3A::new(0.2, 0.1, 0.0)),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// [`furnace_sphere`] with a glass ball (ior 1.5, clear) in the middle: lossless glass in a
/// uniform radiance field is invisible, so radiance everywhere is still `le / (1 - a)`. This
/// checks Fresnel, refraction, total internal reflection and the 1/eta^2 radiance scaling.
pub fn furnace_with_glass(a: f32, le: f32) -> TestScene {
    let mut scene = furnace_sphere(a, le);
    scene.materials.push(
        Material::Dielectric(crate::bsdf::Dielectric::unchecked(
            1.5,
            crate::Spectrum::ONE,
        ))
        .into(),
    );
    scene.surfaces.push(Surface::Sphere {
        center: Vec3A::ZERO,
        radius: 0.3,
        material: 1,
    });
    scene.camera = Probe::AtSphere {
        eye: Vec3A::new(0.0, 0.0, 0.8),
        center: Vec3A::ZERO,
        radius: 0.3,
    };
    scene
}

/// A large diffuse floor (albedo `a`, z = 0) under a black emitting sphere of radius `r` and
/// radiance `l` centred at height `d`, seen at the point right below it. The sphere subtends a
/// cap of projected solid angle `pi (r/d)^2` there, so the floor's radiance is `a l (r/d)^2`;
/// no light comes back (the sphere is black).
pub fn floor_under_sphere_light(a: f32, l: f32, r: f32, d: f32) -> TestScene {
    let s = 100.0;
    let c = |x: f32, y: f32| Vec3A::new(x, y, 0.0);
    TestScene {
        surfaces: vec![
            Surface::Triangle {
                v: [c(-s, -s), c(s, -s), c(s, s)],
                light: None,
            },
            Surface::Triangle {
                v: [c(-s, -s), c(s, s), c(-s, s)],
                light: None,
            },
            Surface::SphereLight {
                center: Vec3A::new(0.0, 0.0, d),
                radius: r,
                light: 0,
            },
        ],
        materials: vec![lambert(a), lambert(0.0)],
        lights: LightTable::new(
            vec![Light::sphere(Vec3A::new(0.0, 0.0, d), r, Rgb::splat(l))],
            s,
        ),
        // From the side, at the point under the sphere.
        camera: Probe::Fixed(Ray::new(
            Vec3A::new(3.0, 0.0, 1.0),
            Vec3A::new(-3.0, 0.0, -1.0).normalize(),
        )),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// The same floor under a one-sided square light at height 1 whose front faces up, away from
/// the floor: nothing reaches the floor, and the camera (above it, looking down at its
/// back... and at the floor) sees black everywhere.
pub fn floor_under_light_facing_away() -> TestScene {
    let s = 100.0;
    let c = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
    // Counter-clockwise seen from above: the front faces +z.
    let (p0, p1, p2, p3) = (
        c(-0.5, -0.5, 1.0),
        c(0.5, -0.5, 1.0),
        c(0.5, 0.5, 1.0),
        c(-0.5, 0.5, 1.0),
    );
    TestScene {
        surfaces: vec![
            Surface::Triangle {
                v: [c(-s, -s, 0.0), c(s, -s, 0.0), c(s, s, 0.0)],
                light: None,
            },
            Surface::Triangle {
                v: [c(-s, -s, 0.0), c(s, s, 0.0), c(-s, s, 0.0)],
                light: None,
            },
            Surface::Triangle {
                v: [p0, p1, p2],
                light: Some(0),
            },
            Surface::Triangle {
                v: [p0, p2, p3],
                light: Some(0),
            },
        ],
        materials: vec![lambert(0.8)],
        lights: LightTable::new(
            vec![Light::parallelogram(
                p0,
                p1 - p0,
                p3 - p0,
                Rgb::splat(10.0),
                false,
            )],
            s,
        ),
        camera: Probe::Omni(Vec3A::new(0.3, 0.2, 0.5)),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    }
}

/// A diffuse floor (albedo `a`, z = 0) under 48 black triangles in the plane z = 1.5, side by
/// side, that emit radiances from 0.05 to 12 (powers over two and a half orders of
/// magnitude): most face the floor, every fifth faces up (away from it), every seventh emits
/// on both sides. The probe looks at the point `X` of the floor. Lights in one plane cannot
/// shadow each other, and light the floor sends back falls on their black undersides: the
/// probe sees `a / pi` times the sum of each light's radiance times its irradiance at `X`,
/// which Lambert's formula gives ([`polygon_irradiance`]). The value is returned beside the
/// scene.
pub fn floor_under_many_lights(a: f32) -> (TestScene, f64) {
    const X: Vec3A = Vec3A::new(0.1, 0.05, 0.0);
    let s = 100.0;
    let c = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
    let mut surfaces = vec![
        Surface::Triangle {
            v: [c(-s, -s, 0.0), c(s, -s, 0.0), c(s, s, 0.0)],
            light: None,
        },
        Surface::Triangle {
            v: [c(-s, -s, 0.0), c(s, s, 0.0), c(-s, s, 0.0)],
            light: None,
        },
    ];
    let mut lights = Vec::new();
    let mut expected = 0.0f64;
    for k in 0..48u32 {
        let (i, j) = ((k % 8) as f32, (k / 8) as f32);
        let centre = c(-1.75 + 0.5 * i, -1.25 + 0.5 * j, 1.5);
        let radiance = 0.05 * 240f32.powf(((k * 29) % 48) as f32 / 47.0);
        let up = k % 5 == 0;
        let two_sided = k % 7 == 0;
        let (p0, p1, p2) = (
            centre + c(-0.2, -0.2, 0.0),
            centre + c(0.2, -0.2, 0.0),
            centre + c(-0.15, 0.2, 0.0),
        );
        // Counter-clockwise from above faces up; swapped, it faces the floor.
        let v = if up { [p0, p1, p2] } else { [p0, p2, p1] };
        surfaces.push(Surface::LightTriangle { v, light: k });
        lights.push(Light::triangle(
            v[0],
            v[1],
            v[2],
            Rgb::splat(radiance),
            two_sided,
        ));
        if !up || two_sided {
            expected += f64::from(radiance) * polygon_irradiance(X, Vec3A::Z, &v);
        }
    }
    let scene = TestScene {
        surfaces,
        materials: vec![lambert(a), lambert(0.0)],
        lights: LightTable::new(lights, s),
        camera: Probe::Fixed(Ray::new(
            c(3.0, 0.05, 0.5),
            (X - c(3.0, 0.05, 0.5)).normalize(),
        )),
        media: Vec::new(),
        camera_medium: MediumId::VACUUM,
    };
    (scene, f64::from(a) / std::f64::consts::PI * expected)
}

/// Lambert's formula: the irradiance at `x` (normal `n`) from a polygon of unit radiance
/// wholly above `x`'s horizon, `1/2 sum_k theta_k (n . g_k)`, over its edges `k`, `theta_k`
/// the angle the edge subtends at `x` and `g_k` the unit normal of the plane through `x` and
/// the edge (the sign taken so that the polygon's two windings agree).
pub fn polygon_irradiance(x: Vec3A, n: Vec3A, polygon: &[Vec3A]) -> f64 {
    let d = |v: Vec3A| glam::DVec3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z));
    let (x, n) = (d(x), d(n));
    let r: Vec<glam::DVec3> = polygon.iter().map(|v| (d(*v) - x).normalize()).collect();
    let mut sum = 0.0;
    for k in 0..r.len() {
        let (a, b) = (r[k], r[(k + 1) % r.len()]);
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * n.dot(a.cross(b).normalize());
    }
    0.5 * sum.abs()
}
