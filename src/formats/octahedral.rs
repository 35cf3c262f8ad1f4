//! pbrt-v4's environment maps: square images in Clarberg's equal-area octahedral mapping
//! (`EqualAreaSquareToSphere`), light-space `+z` up, looked up at the nearest pixel; raylab
//! resamples one into a latitude-longitude map (its own `+y` up) at the nearest pixel too.

use raylab_integrators::Rgb;

/// The largest latitude-longitude map made (its width; its height is half, plus one row).
const MAX_WIDTH: usize = 8192;

/// The unit direction's point in the unit square (pbrt-v4's `EqualAreaSphereToSquare`,
/// written from its inverse: `|u| + |v| = r` on the upper hemisphere with
/// `r = sqrt(1 - |z|)`, the angle around `z` shared between them in proportion, the lower
/// hemisphere folded out over the diagonals).
pub fn sphere_to_square(d: [f64; 3]) -> [f64; 2] {
    let (x, y, z) = (d[0].abs(), d[1].abs(), d[2].abs());
    let r = (1.0 - z).max(0.0).sqrt();
    let phi = if x == 0.0 && y == 0.0 {
        0.0
    } else {
        y.atan2(x) * std::f64::consts::FRAC_2_PI
    };
    let (mut up, mut vp) = (r - phi * r, phi * r);
    if d[2] < 0.0 {
        (up, vp) = (1.0 - vp, 1.0 - up);
    }
    let u = up.copysign(d[0]);
    let v = vp.copysign(d[1]);
    [0.5 * (u + 1.0), 0.5 * (v + 1.0)]
}

/// The point of the unit square's direction (pbrt-v4's `EqualAreaSquareToSphere`).
pub fn square_to_sphere(p: [f64; 2]) -> [f64; 3] {
    let (u, v) = (2.0 * p[0] - 1.0, 2.0 * p[1] - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    let signed = 1.0 - (up + vp);
    let r = 1.0 - signed.abs();
    let phi = if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 } * std::f64::consts::FRAC_PI_4;
    let z = (1.0 - r * r).copysign(signed);
    let s = r * (2.0 - r * r).max(0.0).sqrt();
    [phi.cos().copysign(u) * s, phi.sin().copysign(v) * s, z]
}

/// A square octahedral map of `size x size` texels (row by row from the top) as a
/// latitude-longitude map in raylab's frame (`+y` up, read as pbrt's `+z`): (width, height,
/// texels). Each latitude-longitude texel takes the octahedral pixel its direction falls in.
pub fn to_lat_long(size: usize, texels: &[Rgb]) -> (usize, usize, Vec<Rgb>) {
    let width = (4 * size).clamp(4, MAX_WIDTH);
    let height = width / 2 + 1;
    let mut out = Vec::with_capacity(width * height);
    for row in 0..height {
        let theta = std::f64::consts::PI * row as f64 / (height - 1) as f64;
        for col in 0..width {
            let phi = 2.0 * std::f64::consts::PI * (col as f64 + 0.5) / width as f64;
            // raylab's map direction, then pbrt's light space: (x, y, z) -> (x, -z, y).
            let local = [
                theta.sin() * phi.sin(),
                theta.cos(),
                -theta.sin() * phi.cos(),
            ];
            let [u, v] = sphere_to_square([local[0], -local[2], local[1]]);
            let px = ((u * size as f64) as usize).min(size - 1);
            let py = ((v * size as f64) as usize).min(size - 1);
            out.push(texels[py * size + px]);
        }
    }
    (width, height, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_two_mappings_invert_each_other_and_keep_areas() {
        let mut sampler = raylab_integrators::Sampler::new(91, 0, 0);
        for _ in 0..10_000 {
            let u = sampler.next_2d();
            let p = [u.x as f64, u.y as f64];
            let d = square_to_sphere(p);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((len - 1.0).abs() < 1e-9, "{d:?}");
            let q = sphere_to_square(d);
            assert!(
                (q[0] - p[0]).abs() < 1e-9 && (q[1] - p[1]).abs() < 1e-9,
                "{p:?} -> {d:?} -> {q:?}"
            );
        }
        // Equal area: the upper hemisphere is the inner diamond, half the square.
        let n = 400;
        let upper = (0..n * n)
            .filter(|i| {
                square_to_sphere([
                    (i % n) as f64 / n as f64 + 0.5 / n as f64,
                    (i / n) as f64 / n as f64 + 0.5 / n as f64,
                ])[2]
                    > 0.0
            })
            .count();
        assert!((upper as f64 / (n * n) as f64 - 0.5).abs() < 0.01);
        assert_eq!(sphere_to_square([0.0, 0.0, 1.0]), [0.5, 0.5]);
    }
}
