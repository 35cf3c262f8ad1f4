//! A coarse grid of majorants over a heterogeneous medium's box (pbrt-v4's `MajorantGrid`):
//! the box is cut into 16^3 cells, each holding the largest extinction of the voxels whose
//! interpolation reaches into it, and a ray is walked cell by cell (a 3-D DDA), so that
//! tentative collisions are drawn against the extinction near the ray instead of the
//! largest anywhere. Sparse smoke in a large box then costs collisions where the smoke is.

use super::Segment;
use crate::{Ray, Rgb};
use glam::{Affine3A, Vec3A};

/// Cells along each axis.
pub const RESOLUTION: usize = 16;

/// The majorants of the cells of a box's unit cube, `x` fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct MajorantGrid {
    values: Vec<Rgb>,
}

impl MajorantGrid {
    /// The grid over the box that `to_unit` maps onto the unit cube of `max_in`, a bound on
    /// the extinction in the convex hull of a cell's corners (world); `None` where the box is
    /// degenerate.
    pub fn build(to_unit: &Affine3A, max_in: impl Fn(&[Vec3A; 8]) -> Rgb) -> Option<MajorantGrid> {
        let to_world = to_unit.inverse();
        if !to_world.is_finite() {
            return None;
        }
        let n = RESOLUTION;
        let mut values = Vec::with_capacity(n * n * n);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let corner = |i: usize| {
                        let (dx, dy, dz) = (i & 1, (i >> 1) & 1, (i >> 2) & 1);
                        let unit = Vec3A::new(
                            (x + dx) as f32 / n as f32,
                            (y + dy) as f32 / n as f32,
                            (z + dz) as f32 / n as f32,
                        );
                        to_world.transform_point3a(unit)
                    };
                    let corners: [Vec3A; 8] = std::array::from_fn(corner);
                    values.push(max_in(&corners));
                }
            }
        }
        Some(MajorantGrid { values })
    }

    /// The cells `ray` crosses before `tmax` inside the box (`to_unit`: world to its unit
    /// cube), in order, each with its majorant; nothing where the ray misses the box.
    pub fn segments<'g>(&'g self, to_unit: &Affine3A, ray: &Ray, tmax: f32) -> Segments<'g> {
        let o = to_unit.transform_point3a(ray.origin);
        let d = to_unit.transform_vector3a(ray.dir);
        let Some((t0, t1)) = super::unit_cube_overlap(to_unit, ray, tmax) else {
            return Segments::done(self);
        };
        let n = RESOLUTION as f32;
        let p = o + d * t0;
        let mut cell = [0i32; 3];
        let mut next = [f32::INFINITY; 3];
        let mut delta = [f32::INFINITY; 3];
        let mut step = [0i32; 3];
        for axis in 0..3 {
            let c = ((p[axis] * n).floor() as i32).clamp(0, RESOLUTION as i32 - 1);
            cell[axis] = c;
            let da = d[axis];
            if da > 0.0 {
                next[axis] = t0 + ((c + 1) as f32 / n - p[axis]) / da;
                delta[axis] = 1.0 / (n * da);
                step[axis] = 1;
            } else if da < 0.0 {
                next[axis] = t0 + (c as f32 / n - p[axis]) / da;
                delta[axis] = -1.0 / (n * da);
                step[axis] = -1;
            }
        }
        Segments {
            grid: self,
            t: t0,
            t1,
            cell,
            next,
            delta,
            step,
            done: false,
        }
    }
}

/// The cells a ray crosses: [`MajorantGrid::segments`].
pub struct Segments<'g> {
    grid: &'g MajorantGrid,
    t: f32,
    t1: f32,
    cell: [i32; 3],
    /// Where the ray crosses into the next cell along each axis.
    next: [f32; 3],
    /// The distance between crossings along each axis.
    delta: [f32; 3],
    step: [i32; 3],
    done: bool,
}

impl<'g> Segments<'g> {
    fn done(grid: &'g MajorantGrid) -> Segments<'g> {
        Segments {
            grid,
            t: 0.0,
            t1: 0.0,
            cell: [0; 3],
            next: [f32::INFINITY; 3],
            delta: [f32::INFINITY; 3],
            step: [0; 3],
            done: true,
        }
    }
}

impl Iterator for Segments<'_> {
    type Item = Segment;

    fn next(&mut self) -> Option<Segment> {
        if self.done {
            return None;
        }
        let n = RESOLUTION as i32;
        let [x, y, z] = self.cell;
        let sigma_maj = self.grid.values[((z * n + y) * n + x) as usize];
        // The axis whose crossing comes first ends this cell.
        let axis = if self.next[0] < self.next[1] {
            if self.next[0] < self.next[2] {
                0
            } else {
                2
            }
        } else if self.next[1] < self.next[2] {
            1
        } else {
            2
        };
        let end = self.next[axis].min(self.t1);
        let segment = Segment {
            t0: self.t,
            t1: end.max(self.t),
            sigma_maj: crate::spectrum::of_rgb(sigma_maj),
        };
        self.t = segment.t1;
        // Past the ray's end, or out of the box, or a crossing that did not move (NaN).
        let crossing = self.next[axis];
        if crossing.is_nan() || crossing >= self.t1 {
            self.done = true;
        } else {
            self.cell[axis] += self.step[axis];
            self.next[axis] += self.delta[axis];
            if !(0..n).contains(&self.cell[axis]) {
                self.done = true;
            }
        }
        Some(segment)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::volume::{DensityGrid, Volume};
    use std::sync::Arc;

    /// A 32^3 grid with one dense voxel, in the box [0, 2]^3.
    fn one_dense_voxel() -> (Volume, Affine3A) {
        let n = 32;
        let mut values = vec![0.1f32; n * n * n];
        values[(5 * n + 20) * n + 7] = 9.0;
        let grid = DensityGrid::new([n, n, n], 1, values).unwrap();
        let to_unit = Affine3A::from_scale(glam::Vec3::splat(0.5));
        let volume = Volume::Grid {
            grid: Arc::new(grid),
            to_local: to_unit,
            scale: Rgb::ONE,
        };
        (volume, to_unit)
    }

    #[test]
    fn every_cell_bounds_the_extinction_inside_it_and_most_are_tight() {
        let (volume, to_unit) = one_dense_voxel();
        let grid = MajorantGrid::build(&to_unit, |c| volume.max_in(c)).unwrap();
        let mut s = crate::Sampler::new(9, 0, 0);
        for _ in 0..20000 {
            let p = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0;
            let u = p * 0.5 * RESOLUTION as f32;
            let (x, y, z) = (u.x as usize, u.y as usize, u.z as usize);
            let i = (z.min(15) * RESOLUTION + y.min(15)) * RESOLUTION + x.min(15);
            assert!(
                volume.at(p).x <= grid.values[i].x * (1.0 + 1e-5),
                "at {p:?}"
            );
        }
        // The dense voxel reaches into a few cells only.
        let dense = grid.values.iter().filter(|v| v.x > 1.0).count();
        assert!((1..=8).contains(&dense), "{dense} dense cells");
    }

    #[test]
    fn a_ray_crosses_the_cells_in_order_and_covers_its_stretch_in_the_box() {
        let (volume, to_unit) = one_dense_voxel();
        let grid = MajorantGrid::build(&to_unit, |c| volume.max_in(c)).unwrap();
        let mut s = crate::Sampler::new(4, 0, 0);
        for _ in 0..2000 {
            let origin = Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d()) * 6.0 - 2.0;
            let dir = (Vec3A::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0 - 1.0)
                .normalize_or(Vec3A::X);
            let ray = Ray::new(origin, dir);
            let tmax = 10.0 * s.next_1d();
            let segments: Vec<Segment> = grid.segments(&to_unit, &ray, tmax).collect();
            match crate::medium::unit_cube_overlap(&to_unit, &ray, tmax) {
                None => assert!(segments.is_empty()),
                Some((t0, t1)) => {
                    let first = segments.first().unwrap();
                    let last = segments.last().unwrap();
                    assert!((first.t0 - t0).abs() < 1e-4, "{} {t0}", first.t0);
                    assert!((last.t1 - t1).abs() < 1e-4, "{} {t1}", last.t1);
                    for w in segments.windows(2) {
                        assert_eq!(w[0].t1, w[1].t0);
                    }
                    // Each segment's majorant bounds the extinction along it.
                    for seg in &segments {
                        for k in 1..4 {
                            let t = seg.t0 + (seg.t1 - seg.t0) * k as f32 / 4.0;
                            let v = volume.at(ray.at(t)).x;
                            assert!(v <= seg.sigma_maj.x * (1.0 + 1e-4) + 1e-6, "{v}");
                        }
                    }
                }
            }
        }
    }
}
