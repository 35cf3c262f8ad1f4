//! The pinhole camera resource: turns film positions into primary rays.

use glam::Vec3A;
use raylab_integrators::Ray;

/// A pinhole camera and its image size.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3A,
    pub width: u32,
    pub height: u32,
    view: View,
}

#[derive(Clone, Debug, PartialEq)]
enum View {
    /// Image plane at unit distance along `forward`; `tan_half_fov` fixes its height and the
    /// aspect ratio of the resolution its width.
    LookAt {
        forward: Vec3A,
        right: Vec3A,
        up: Vec3A,
        tan_half_fov: f32,
    },
    /// A fixed parallelogram in world space (the report's camera).
    Plane {
        top_left: Vec3A,
        right_edge: Vec3A,
        down_edge: Vec3A,
    },
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
        Camera {
            eye,
            width: size.0,
            height: size.1,
            view: View::LookAt {
                forward,
                right,
                up,
                tan_half_fov: (0.5 * fov_degrees).to_radians().tan(),
            },
        }
    }

    /// A camera at `eye` looking through the parallelogram `top_left, top_right, bottom_left`.
    pub fn image_plane(
        eye: Vec3A,
        top_left: Vec3A,
        top_right: Vec3A,
        bottom_left: Vec3A,
        size: (u32, u32),
    ) -> Self {
        Camera {
            eye,
            width: size.0,
            height: size.1,
            view: View::Plane {
                top_left,
                right_edge: top_right - top_left,
                down_edge: bottom_left - top_left,
            },
        }
    }

    /// The same view at another resolution (a look-at camera keeps its vertical field of view).
    pub fn with_resolution(&self, width: u32, height: u32) -> Self {
        Camera {
            width,
            height,
            ..self.clone()
        }
    }

    /// The primary ray through film position `(x, y)` in pixels, `(0, 0)` the top-left corner.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let u = x / self.width as f32;
        let v = y / self.height as f32;
        let dir = match &self.view {
            View::LookAt {
                forward,
                right,
                up,
                tan_half_fov,
            } => {
                let aspect = self.width as f32 / self.height as f32;
                *forward
                    + *right * ((2.0 * u - 1.0) * tan_half_fov * aspect)
                    + *up * ((1.0 - 2.0 * v) * tan_half_fov)
            }
            View::Plane {
                top_left,
                right_edge,
                down_edge,
            } => *top_left + *right_edge * u + *down_edge * v - self.eye,
        };
        Ray::new(self.eye, dir.normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_centre_ray_points_at_target_and_corners_span_the_fov() {
        let cam = Camera::look_at(
            Vec3A::new(0.0, 0.0, 3.9),
            Vec3A::ZERO,
            Vec3A::Y,
            90.0,
            (100, 50),
        );
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
        let cam = Camera::image_plane(
            Vec3A::new(-1.0, 0.0, 0.0),
            Vec3A::new(0.0, 1.0, 1.0),
            Vec3A::new(0.0, -1.0, 1.0),
            Vec3A::new(0.0, 1.0, -1.0),
            (400, 400),
        );
        let centre = cam.ray(200.0, 200.0);
        assert!((centre.dir - Vec3A::X).length() < 1e-6);
        let top_left = cam.ray(0.0, 0.0);
        assert!(top_left.dir.y > 0.0 && top_left.dir.z > 0.0);
    }
}
