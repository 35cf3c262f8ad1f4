//! The camera model: a pinhole at `eye` looking through a film, the parallelogram that the
//! image is stretched over (pbrt-v4's `Camera` interface, for a pinhole).
//!
//! * Camera paths: [`Camera::ray`] turns a film position (pixels, `(0, 0)` the top-left
//!   corner) into a primary ray.
//! * Light paths: [`Camera::sample_wi`] connects a point of the scene to the lens and says
//!   where on the film it lands and with what importance; [`Camera::importance`] and
//!   [`Camera::pdf_we`] give the importance `We` and the densities of a given camera ray.
//!
//! Both cameras of the scene format are a film parallelogram seen from the eye: the LookAt
//! camera's film is the rectangle at unit distance along the view direction, the report's
//! ImagePlane camera's an arbitrary parallelogram in world space (not necessarily square to
//! the line of sight, nor a rectangle).
//!
//! # Importance
//!
//! Let `n` be the unit normal of the film plane (pointing away from the eye), `h` the distance
//! from the eye to that plane and `A` the film's area. A direction `w` at angle `cos = w.n` to
//! the normal meets the plane at distance `h / cos`; uniform sampling of the film therefore has
//! the solid-angle density `pdf_dir(w) = (h / cos)^2 / (A cos) = h^2 / (A cos^3)`. The pinhole
//! is a point: its positional density is 1 (a delta, as in pbrt-v4, whose unit "lens area"
//! this follows). The importance is normalised so that a camera ray's Monte Carlo weight
//! `We cos / (pdf_pos pdf_dir)` is exactly 1, i.e. `We(w) = h^2 / (A cos^4)` inside the film and
//! 0 outside: `integral We(w) cos dw = 1` over the whole image. The measurement of one pixel is
//! the image's importance restricted to the pixel and multiplied by the pixel count; a light
//! path's contribution, splatted without further weights, is averaged by dividing the splats by
//! the number of passes, as pbrt-v4's film does.

use crate::{Ray, Spectrum};
use glam::{Vec2, Vec3A};

/// A pinhole camera and its image size. Plain data, like a material: cheap to copy and share.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3A,
    pub width: u32,
    pub height: u32,
    view: View,
    film: FilmPlane,
}

#[derive(Clone, Debug, PartialEq)]
enum View {
    LookAt(LookAt),
    /// Parallel rays along `forward` from a rectangle centred on the eye, spanned by the
    /// half extents `right` and `up` (Mitsuba's `orthographic` sensor).
    Orthographic {
        forward: Vec3A,
        right: Vec3A,
        up: Vec3A,
    },
    /// A fixed parallelogram in world space (the report's camera).
    Plane {
        top_left: Vec3A,
        right_edge: Vec3A,
        down_edge: Vec3A,
    },
}

/// Image plane at unit distance along `forward`; `tan_half_fov` fixes its height and the
/// aspect ratio of the resolution its width.
#[derive(Clone, Debug, PartialEq)]
struct LookAt {
    forward: Vec3A,
    right: Vec3A,
    up: Vec3A,
    tan_half_fov: f32,
}

impl LookAt {
    /// Half the film's width and height as vectors, for an image of aspect ratio `aspect`.
    fn half_extent(&self, aspect: f32) -> (Vec3A, Vec3A) {
        (
            self.right * (self.tan_half_fov * aspect),
            self.up * self.tan_half_fov,
        )
    }

    /// Direction (not normalised) towards the film position `(u, v)` in `[0, 1]^2`.
    #[inline]
    fn dir(&self, u: f32, v: f32, aspect: f32) -> Vec3A {
        self.forward
            + self.right * ((2.0 * u - 1.0) * self.tan_half_fov * aspect)
            + self.up * ((1.0 - 2.0 * v) * self.tan_half_fov)
    }
}

/// The film parallelogram both views share, with what importance needs precomputed.
#[derive(Clone, Debug, PartialEq)]
struct FilmPlane {
    top_left: Vec3A,
    /// Unit normal of the film plane, pointing away from the eye.
    normal: Vec3A,
    /// Distance from the eye to the film plane along `normal`.
    distance: f32,
    /// Area of the film in world units.
    area: f32,
    /// Dual vectors of the film's edges in its plane: `(q - top_left) . to_u` is the fraction
    /// across (0 left, 1 right) of a point `q` of the plane, `. to_v` the fraction down.
    to_u: Vec3A,
    to_v: Vec3A,
}

impl FilmPlane {
    fn new(eye: Vec3A, top_left: Vec3A, right_edge: Vec3A, down_edge: Vec3A) -> FilmPlane {
        let cross = right_edge.cross(down_edge);
        let area = cross.length();
        let mut normal = cross / area;
        if normal.dot(top_left - eye) < 0.0 {
            normal = -normal;
        }
        // Dual basis of (right, down) in their plane: to_u . right = 1, to_u . down = 0, ...
        let (rr, rd, dd) = (
            right_edge.dot(right_edge),
            right_edge.dot(down_edge),
            down_edge.dot(down_edge),
        );
        let det = rr * dd - rd * rd;
        FilmPlane {
            top_left,
            normal,
            distance: normal.dot(top_left - eye),
            area,
            to_u: (right_edge * dd - down_edge * rd) / det,
            to_v: (down_edge * rr - right_edge * rd) / det,
        }
    }
}

/// A connection from a point of the scene to the camera, for light paths
/// ([`Camera::sample_wi`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraWiSample {
    /// Unit direction from the reference point towards the eye.
    pub wi: Vec3A,
    /// The eye (the point the connection ends at).
    pub point: Vec3A,
    /// Distance from the reference point to the eye.
    pub dist: f32,
    /// Film position (pixels, `(0, 0)` the top-left corner) the connection lands at.
    pub raster: Vec2,
    /// Importance `We` of the ray from the eye towards the reference point.
    pub we: Spectrum,
    /// Solid-angle density of the connection at the reference point (the lens is a point:
    /// `dist^2 / |cos|` at the lens, with pbrt-v4's unit lens area).
    pub pdf: f32,
}

impl Camera {
    /// A camera at `eye` looking at `look_at`, with `fov_degrees` vertical field of view.
    /// The caller has checked that the vectors are finite, distinct and not parallel.
    pub fn look_at(
        eye: Vec3A,
        look_at: Vec3A,
        up: Vec3A,
        fov_degrees: f32,
        size: (u32, u32),
    ) -> Self {
        let forward = (look_at - eye).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let tan_half_fov = (0.5 * fov_degrees).to_radians().tan();
        let view = View::LookAt(LookAt {
            forward,
            right,
            up,
            tan_half_fov,
        });
        Camera::new(eye, view, size)
    }

    /// A camera at `eye` looking through the parallelogram `top_left, top_right, bottom_left`.
    pub fn image_plane(
        eye: Vec3A,
        top_left: Vec3A,
        top_right: Vec3A,
        bottom_left: Vec3A,
        size: (u32, u32),
    ) -> Self {
        let view = View::Plane {
            top_left,
            right_edge: top_right - top_left,
            down_edge: bottom_left - top_left,
        };
        Camera::new(eye, view, size)
    }

    /// An orthographic camera: rays parallel to `look_at - eye` from the `width` x `height`
    /// rectangle (world units) centred on `eye`, its top edge towards `up`. The caller has
    /// checked that the vectors are finite, distinct and not parallel, and the sizes positive.
    pub fn orthographic(
        eye: Vec3A,
        look_at: Vec3A,
        up: Vec3A,
        (width, height): (f32, f32),
        size: (u32, u32),
    ) -> Self {
        let forward = (look_at - eye).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let view = View::Orthographic {
            forward,
            right: right * (0.5 * width),
            up: up * (0.5 * height),
        };
        Camera::new(eye, view, size)
    }

    /// True for a pinhole camera (a point lens): only it can be connected to a point of the
    /// scene ([`Camera::sample_wi`]); an orthographic camera's directions are a delta.
    pub fn is_pinhole(&self) -> bool {
        !matches!(self.view, View::Orthographic { .. })
    }

    fn new(eye: Vec3A, view: View, size: (u32, u32)) -> Self {
        Camera {
            eye,
            width: size.0,
            height: size.1,
            film: Self::film_of(eye, &view, size),
            view,
        }
    }

    fn film_of(eye: Vec3A, view: &View, (width, height): (u32, u32)) -> FilmPlane {
        match *view {
            View::LookAt(ref look) => {
                let (half_w, half_h) = look.half_extent(width as f32 / height as f32);
                FilmPlane::new(
                    eye,
                    eye + look.forward - half_w + half_h,
                    half_w * 2.0,
                    -half_h * 2.0,
                )
            }
            View::Plane {
                top_left,
                right_edge,
                down_edge,
            } => FilmPlane::new(eye, top_left, right_edge, down_edge),
            // No film a point connects to: the plane at unit distance only keeps the fields
            // defined (`raster` refuses every direction).
            View::Orthographic { forward, right, up } => {
                FilmPlane::new(eye, eye + forward - right + up, right * 2.0, -up * 2.0)
            }
        }
    }

    /// The same view at another resolution (a look-at camera keeps its vertical field of view,
    /// an orthographic one its height).
    pub fn with_resolution(&self, width: u32, height: u32) -> Self {
        let mut view = self.view.clone();
        // An orthographic view keeps its height and its pixels' shape, as a look-at camera.
        if let View::Orthographic { right, .. } = &mut view {
            let aspect = |w: u32, h: u32| w as f32 / h as f32;
            *right *= aspect(width, height) / aspect(self.width, self.height);
        }
        Camera::new(self.eye, view, (width, height))
    }

    /// The primary ray through film position `(x, y)` in pixels, `(0, 0)` the top-left corner.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let u = x / self.width as f32;
        let v = y / self.height as f32;
        if let View::Orthographic { forward, right, up } = &self.view {
            let origin = self.eye + *right * (2.0 * u - 1.0) + *up * (1.0 - 2.0 * v);
            return Ray::new(origin, *forward);
        }
        let dir = match &self.view {
            View::LookAt(look) => look.dir(u, v, self.width as f32 / self.height as f32),
            View::Orthographic { forward, .. } => *forward,
            View::Plane {
                top_left,
                right_edge,
                down_edge,
            } => *top_left + *right_edge * u + *down_edge * v - self.eye,
        };
        Ray::new(self.eye, dir.normalize())
    }

    /// Unit normal of the film plane, pointing away from the eye: the camera's "normal" in
    /// the geometry term of connections to the lens.
    pub fn normal(&self) -> Vec3A {
        self.film.normal
    }

    /// Film position (pixels) at which the direction `w` from the eye meets the film, and the
    /// cosine between `w` and the film's normal; `None` outside the film or behind the eye,
    /// and always for an orthographic camera (whose rays leave no single eye).
    pub fn raster(&self, w: Vec3A) -> Option<(Vec2, f32)> {
        if !self.is_pinhole() {
            return None;
        }
        let cos = w.dot(self.film.normal);
        if cos.is_nan() || cos <= 0.0 {
            return None;
        }
        let q = self.eye + w * (self.film.distance / cos) - self.film.top_left;
        let (u, v) = (q.dot(self.film.to_u), q.dot(self.film.to_v));
        if !((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)) {
            return None;
        }
        Some((
            Vec2::new(u * self.width as f32, v * self.height as f32),
            cos,
        ))
    }

    /// Importance `We` of the ray leaving the eye in unit direction `w`, and the film position
    /// it passes through; `None` (zero importance) outside the film.
    pub fn importance(&self, w: Vec3A) -> Option<(Spectrum, Vec2)> {
        let (raster, cos) = self.raster(w)?;
        let cos2 = cos * cos;
        let h = self.film.distance;
        let we = h * h / (self.film.area * cos2 * cos2);
        we.is_finite().then(|| (Spectrum::splat(we), raster))
    }

    /// Positional and directional densities of the camera ray leaving the eye in direction
    /// `w` when rays are generated uniformly over the film: `(1, h^2 / (A cos^3))` inside the
    /// film, `(0, 0)` outside (the positional density of a pinhole is a delta: 1).
    pub fn pdf_we(&self, w: Vec3A) -> (f32, f32) {
        match self.raster(w) {
            Some((_, cos)) => {
                let h = self.film.distance;
                (1.0, h * h / (self.film.area * cos * cos * cos))
            }
            None => (0.0, 0.0),
        }
    }

    /// Connects the point `p` to the eye: the direction, the film position it lands at, the
    /// importance arriving along it and the density of the connection (pbrt-v4's
    /// `Camera::SampleWi` for a pinhole; there is nothing to sample, so it takes no random
    /// numbers). `None` when `p` is outside the view.
    pub fn sample_wi(&self, p: Vec3A) -> Option<CameraWiSample> {
        let d = self.eye - p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let (we, raster) = self.importance(-wi)?;
        let cos = (-wi).dot(self.film.normal);
        let pdf = dist2 / cos;
        pdf.is_finite().then_some(CameraWiSample {
            wi,
            point: self.eye,
            dist,
            raster,
            we,
            pdf,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{uniform_sphere, UNIFORM_SPHERE_PDF};

    fn look_at() -> Camera {
        Camera::look_at(
            Vec3A::new(0.0, 0.0, 3.9),
            Vec3A::ZERO,
            Vec3A::Y,
            90.0,
            (100, 50),
        )
    }

    /// The report's camera, and a skewed, tilted parallelogram whose plane is not square to
    /// the line of sight (where importance is easiest to get wrong).
    fn planes() -> [Camera; 2] {
        [
            Camera::image_plane(
                Vec3A::new(-1.0, 0.0, 0.0),
                Vec3A::new(0.0, 1.0, 1.0),
                Vec3A::new(0.0, -1.0, 1.0),
                Vec3A::new(0.0, 1.0, -1.0),
                (400, 400),
            ),
            Camera::image_plane(
                Vec3A::new(0.2, -0.3, 0.1),
                Vec3A::new(1.0, 0.9, 1.3),
                Vec3A::new(1.6, -0.7, 1.0),
                Vec3A::new(0.4, 0.5, -0.8),
                (64, 48),
            ),
        ]
    }

    fn cameras() -> Vec<Camera> {
        let mut v = vec![look_at(), look_at().with_resolution(30, 70)];
        v.extend(planes());
        v
    }

    #[test]
    fn look_at_centre_ray_points_at_target_and_corners_span_the_fov() {
        let cam = look_at();
        let r = cam.ray(50.0, 25.0);
        assert!((r.dir - Vec3A::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Top edge centre is 45 degrees up; right edge centre 63.4 degrees (aspect 2) to +x.
        let top = cam.ray(50.0, 0.0);
        assert!((top.dir.y - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-5);
        let right = cam.ray(100.0, 25.0);
        assert!(right.dir.x > 0.0 && (right.dir.x / -right.dir.z - 2.0).abs() < 1e-5);
    }

    #[test]
    fn image_plane_matches_the_reports_camera() {
        // Eye (-1,0,0), plane x = 0 with corners (0, +-1, +-1); +y is the image's left.
        let cam = &planes()[0];
        let centre = cam.ray(200.0, 200.0);
        assert!((centre.dir - Vec3A::X).length() < 1e-6);
        let top_left = cam.ray(0.0, 0.0);
        assert!(top_left.dir.y > 0.0 && top_left.dir.z > 0.0);
    }

    #[test]
    fn camera_rays_land_where_they_were_generated() {
        for cam in cameras() {
            for (fx, fy) in [(0.5, 0.5), (0.01, 0.02), (0.99, 0.3), (0.25, 0.97)] {
                let (x, y) = (fx * cam.width as f32, fy * cam.height as f32);
                let ray = cam.ray(x, y);
                let (raster, _) = cam.raster(ray.dir).unwrap();
                assert!(
                    (raster - Vec2::new(x, y)).length() < 2e-3 * cam.width.max(cam.height) as f32,
                    "{cam:?}: {raster} vs ({x}, {y})"
                );
                // A point along the ray connects back to the same film position.
                let cs = cam.sample_wi(ray.at(3.0)).unwrap();
                assert!((cs.raster - raster).length() < 1e-2, "{cs:?}");
                assert!((cs.wi + ray.dir).length() < 1e-5 && (cs.dist - 3.0).abs() < 1e-4);
            }
            // Behind the eye and beside the film: no importance.
            let back = cam.ray(1.0, 1.0).dir;
            assert!(cam.importance(-back).is_none() && cam.pdf_we(-back) == (0.0, 0.0));
            assert!(cam.sample_wi(cam.eye - back).is_none());
        }
    }

    #[test]
    fn orthographic_rays_are_parallel_and_span_the_rectangle() {
        let eye = Vec3A::new(1.0, 2.0, 3.0);
        let cam = Camera::orthographic(eye, eye - Vec3A::Z, Vec3A::Y, (4.0, 2.0), (200, 100));
        let centre = cam.ray(100.0, 50.0);
        assert!((centre.origin - eye).length() < 1e-6 && centre.dir == -Vec3A::Z);
        // Top-left corner: 2 to the left (-x, looking down -z with y up), 1 up.
        let corner = cam.ray(0.0, 0.0);
        assert!((corner.origin - (eye + Vec3A::new(-2.0, 1.0, 0.0))).length() < 1e-6);
        assert_eq!(corner.dir, centre.dir);
        let right = cam.ray(200.0, 100.0);
        assert!((right.origin - (eye + Vec3A::new(2.0, -1.0, 0.0))).length() < 1e-6);
        // No point connects to it, and a wider image keeps the height and the pixels' shape.
        assert!(!cam.is_pinhole() && cam.sample_wi(eye - Vec3A::Z).is_none());
        let wide = cam.with_resolution(400, 100);
        assert!((wide.ray(0.0, 0.0).origin - (eye + Vec3A::new(-4.0, 1.0, 0.0))).length() < 1e-5);
    }

    #[test]
    fn a_camera_rays_weight_is_one() {
        // We cos / (pdf_pos pdf_dir) = 1: the path tracer's camera rays need no weight.
        for cam in cameras() {
            for (x, y) in [(0.3, 0.2), (0.5, 0.5), (0.9, 0.8)] {
                let ray = cam.ray(x * cam.width as f32, y * cam.height as f32);
                let (we, _) = cam.importance(ray.dir).unwrap();
                let (pos, dir) = cam.pdf_we(ray.dir);
                let cos = ray.dir.dot(cam.normal());
                assert!((we.x * cos / (pos * dir) - 1.0).abs() < 1e-4, "{cam:?}");
            }
        }
    }

    /// Integrates `f` over the sphere of directions with `n` stratified uniform samples.
    fn over_sphere(n: u32, f: impl Fn(Vec3A) -> f64) -> f64 {
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                sum += f(uniform_sphere(u)) / UNIFORM_SPHERE_PDF as f64;
            }
        }
        sum / (n * n) as f64
    }

    #[test]
    fn the_directional_density_and_the_importance_integrate_to_one() {
        for cam in cameras() {
            let pdf = over_sphere(1500, |w| cam.pdf_we(w).1 as f64);
            let we_cos = over_sphere(1500, |w| {
                cam.importance(w)
                    .map_or(0.0, |(we, _)| (we.x * w.dot(cam.normal())) as f64)
            });
            assert!((pdf - 1.0).abs() < 5e-3, "{cam:?}: {pdf}");
            assert!((we_cos - 1.0).abs() < 5e-3, "{cam:?}: {we_cos}");
        }
    }

    #[test]
    fn light_tracing_through_sample_wi_sees_what_camera_rays_see() {
        // A one-sided emitting square of radiance 1 in front of each camera. Camera rays see
        // it over a fraction of the image (counted on a fine grid of film positions); light
        // tracing estimates the same mean pixel value as the integral over the square of
        // We cos_light cos_lens / d^2, by uniform area samples through `sample_wi`.
        for cam in cameras() {
            let centre = cam
                .ray(0.45 * cam.width as f32, 0.55 * cam.height as f32)
                .at(2.0);
            let n = -cam
                .ray(0.45 * cam.width as f32, 0.55 * cam.height as f32)
                .dir;
            let frame = crate::Frame::from_normal(n);
            let (e1, e2) = (frame.s * 1.0, frame.t * 0.6);
            let corner = centre - e1 * 0.5 - e2 * 0.5;
            let area = e1.cross(e2).length();
            // Fraction of film positions whose ray meets the square.
            let grid = 1000;
            let mut covered = 0u32;
            for i in 0..grid {
                for j in 0..grid {
                    let x = (i as f32 + 0.5) / grid as f32 * cam.width as f32;
                    let y = (j as f32 + 0.5) / grid as f32 * cam.height as f32;
                    let r = cam.ray(x, y);
                    let t = (centre - r.origin).dot(n) / r.dir.dot(n);
                    let q = r.at(t) - corner;
                    let (a, b) = (q.dot(e1) / e1.dot(e1), q.dot(e2) / e2.dot(e2));
                    if t > 0.0 && (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b) {
                        covered += 1;
                    }
                }
            }
            let camera_mean = covered as f64 / (grid * grid) as f64;
            let m = 400;
            let mut sum = 0.0f64;
            for i in 0..m {
                for j in 0..m {
                    let p = corner
                        + e1 * ((i as f32 + 0.5) / m as f32)
                        + e2 * ((j as f32 + 0.5) / m as f32);
                    if let Some(cs) = cam.sample_wi(p) {
                        let cos_light = n.dot(cs.wi).max(0.0);
                        sum += (cs.we.x * cos_light / cs.pdf) as f64;
                    }
                }
            }
            let light_mean = sum / (m * m) as f64 * area as f64;
            assert!(camera_mean > 0.005, "{cam:?}: the square must be in view");
            assert!(
                (light_mean / camera_mean - 1.0).abs() < 1e-2,
                "{cam:?}: light tracing {light_mean} vs camera rays {camera_mean}"
            );
        }
    }
}
