//! Values over space that media are made of: a constant, or a grid of voxels looked up
//! trilinearly (Mitsuba 3's `constvolume` and `gridvolume`, pbrt-v4's `SampledGrid`).

use crate::Rgb;
use glam::{Affine3A, Vec3A};
use std::sync::Arc;

/// What a grid holds beyond its outermost voxel centres, where a lookup blends towards the
/// voxels past its faces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GridEdge {
    /// The nearest voxels' values hold up to the faces (Mitsuba 3's `clamp`).
    #[default]
    Clamp,
    /// Voxels past the faces are 0, so values fade to half the edge voxels' at the faces
    /// (pbrt-v4's `SampledGrid`).
    Zero,
}

/// Voxel values on a regular grid over the unit cube, one or three channels each.
#[derive(Clone, Debug, PartialEq)]
pub struct DensityGrid {
    /// Voxels along x, y and z (each at least 1).
    resolution: [usize; 3],
    /// 1 (a density) or 3 (an RGB value).
    channels: usize,
    /// `x` fastest, then `y`, then `z`; the channels of a voxel together.
    values: Vec<f32>,
    /// The largest value of each channel (a single channel's in all three).
    max: Rgb,
    /// What lies past the outermost voxel centres.
    edge: GridEdge,
}

impl DensityGrid {
    /// A grid of `resolution` voxels of `channels` (1 or 3) values each, `x` fastest. An
    /// error for a count that does not match, a negative or non-finite value.
    pub fn new(
        resolution: [usize; 3],
        channels: usize,
        values: Vec<f32>,
    ) -> Result<DensityGrid, String> {
        if !matches!(channels, 1 | 3) {
            return Err(format!("a grid has 1 or 3 channels, not {channels}"));
        }
        let voxels = resolution
            .iter()
            .try_fold(1usize, |n, &r| (r > 0).then(|| n.checked_mul(r)).flatten())
            .ok_or_else(|| format!("a grid of {resolution:?} voxels is empty or too large"))?;
        if voxels.checked_mul(channels) != Some(values.len()) {
            return Err(format!(
                "a grid of {}x{}x{} voxels of {channels} channel(s) needs {} values, not {}",
                resolution[0],
                resolution[1],
                resolution[2],
                voxels.saturating_mul(channels),
                values.len()
            ));
        }
        if let Some(bad) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return Err(format!(
                "grid values must be finite and non-negative, not {bad}"
            ));
        }
        let mut max = Rgb::ZERO;
        for voxel in values.chunks_exact(channels) {
            max = max.max(Self::rgb(voxel));
        }
        Ok(DensityGrid {
            resolution,
            channels,
            values,
            max,
            edge: GridEdge::Clamp,
        })
    }

    /// The same grid with `edge` past its outermost voxel centres (its largest value, a
    /// bound on every lookup, does not change).
    pub fn with_edge(self, edge: GridEdge) -> DensityGrid {
        DensityGrid { edge, ..self }
    }

    /// The largest value of each channel.
    pub fn max(&self) -> Rgb {
        self.max
    }

    /// The largest value any lookup in the box `[lo, hi]` of the unit cube can give: the
    /// largest of the voxels whose interpolation reaches into it.
    pub fn max_in(&self, lo: Vec3A, hi: Vec3A) -> Rgb {
        let mut range = [(0usize, 0usize); 3];
        for axis in 0..3 {
            let n = self.resolution[axis];
            let index = |x: f32| {
                let i = (x * n as f32 - 0.5).floor();
                if i.is_nan() {
                    0
                } else {
                    i.clamp(0.0, (n - 1) as f32) as usize
                }
            };
            range[axis] = (index(lo[axis]), (index(hi[axis]) + 1).min(n - 1));
        }
        let mut max = Rgb::ZERO;
        for z in range[2].0..=range[2].1 {
            for y in range[1].0..=range[1].1 {
                for x in range[0].0..=range[0].1 {
                    max = max.max(self.voxel(x, y, z));
                }
            }
        }
        max
    }

    #[inline]
    fn rgb(voxel: &[f32]) -> Rgb {
        match voxel {
            [v] => Rgb::splat(*v),
            [r, g, b] => Rgb::new(*r, *g, *b),
            _ => Rgb::ZERO,
        }
    }

    #[inline]
    fn voxel(&self, x: usize, y: usize, z: usize) -> Rgb {
        let [nx, ny, _] = self.resolution;
        let i = ((z * ny + y) * nx + x) * self.channels;
        Self::rgb(&self.values[i..i + self.channels])
    }

    /// The trilinear interpolation at `p` of the unit cube: voxel `i` is centred on
    /// `(i + 1/2) / n`; outside the centres the grid's [`GridEdge`] holds.
    pub fn lookup(&self, p: Vec3A) -> Rgb {
        match self.edge {
            GridEdge::Clamp => self.lookup_clamped(p),
            GridEdge::Zero => self.lookup_zero_outside(p),
        }
    }

    /// The lookup where the nearest voxels' values hold outside the centres.
    fn lookup_clamped(&self, p: Vec3A) -> Rgb {
        let mut base = [0usize; 3];
        let mut frac = [0.0f32; 3];
        for axis in 0..3 {
            let n = self.resolution[axis];
            let x = (p[axis] * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
            let i = (x.floor() as usize).min(n - 1);
            base[axis] = i;
            frac[axis] = x - i as f32;
        }
        let next = |axis: usize| (base[axis] + 1).min(self.resolution[axis] - 1);
        let (x0, y0, z0) = (base[0], base[1], base[2]);
        let (x1, y1, z1) = (next(0), next(1), next(2));
        let corner = |x: usize, y: usize, z: usize| self.voxel(x, y, z);
        Self::trilinear(
            frac,
            [
                corner(x0, y0, z0),
                corner(x1, y0, z0),
                corner(x0, y1, z0),
                corner(x1, y1, z0),
                corner(x0, y0, z1),
                corner(x1, y0, z1),
                corner(x0, y1, z1),
                corner(x1, y1, z1),
            ],
        )
    }

    /// pbrt-v4's lookup (`SampledGrid::Lookup`): voxels past the faces are 0.
    fn lookup_zero_outside(&self, p: Vec3A) -> Rgb {
        let mut base = [0i64; 3];
        let mut frac = [0.0f32; 3];
        for axis in 0..3 {
            let x = p[axis] * self.resolution[axis] as f32 - 0.5;
            let i = x.floor();
            // Far outside, every neighbour is 0 (and the cast stays in range).
            if !(i >= -2.0 && i <= self.resolution[axis] as f32 + 1.0) {
                return Rgb::ZERO;
            }
            base[axis] = i as i64;
            frac[axis] = x - i;
        }
        let corner = |dx: i64, dy: i64, dz: i64| {
            let at = [base[0] + dx, base[1] + dy, base[2] + dz];
            let inside = (0..3).all(|a| (0..self.resolution[a] as i64).contains(&at[a]));
            if inside {
                self.voxel(at[0] as usize, at[1] as usize, at[2] as usize)
            } else {
                Rgb::ZERO
            }
        };
        Self::trilinear(
            frac,
            [
                corner(0, 0, 0),
                corner(1, 0, 0),
                corner(0, 1, 0),
                corner(1, 1, 0),
                corner(0, 0, 1),
                corner(1, 0, 1),
                corner(0, 1, 1),
                corner(1, 1, 1),
            ],
        )
    }

    /// The trilinear blend of a cell's eight corners (`x` fastest, then `y`, then `z`) at
    /// `frac` across it.
    #[inline]
    fn trilinear(frac: [f32; 3], c: [Rgb; 8]) -> Rgb {
        let [fx, fy, fz] = frac;
        let lerp = |a: Rgb, b: Rgb, t: f32| a + (b - a) * t;
        let c00 = lerp(c[0], c[1], fx);
        let c10 = lerp(c[2], c[3], fx);
        let c01 = lerp(c[4], c[5], fx);
        let c11 = lerp(c[6], c[7], fx);
        lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz)
    }

    /// Bytes the voxels take.
    pub fn memory_bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f32>()
    }
}

/// A value over space.
#[derive(Clone, Debug, PartialEq)]
pub enum Volume {
    /// The same everywhere.
    Constant(Rgb),
    /// A grid placed by `to_local` (world to the grid's unit cube), its values times `scale`.
    Grid {
        grid: Arc<DensityGrid>,
        to_local: Affine3A,
        scale: Rgb,
    },
}

impl Volume {
    /// The value at `p` (world).
    #[inline]
    pub fn at(&self, p: Vec3A) -> Rgb {
        match self {
            Volume::Constant(c) => *c,
            Volume::Grid {
                grid,
                to_local,
                scale,
            } => grid.lookup(to_local.transform_point3a(p)) * *scale,
        }
    }

    /// The largest value of each channel anywhere.
    pub fn max(&self) -> Rgb {
        match self {
            Volume::Constant(c) => *c,
            Volume::Grid { grid, scale, .. } => grid.max() * *scale,
        }
    }

    /// The largest value anywhere in the convex hull of `corners` (world), bounded by their
    /// box in the grid's space.
    pub fn max_in(&self, corners: &[Vec3A; 8]) -> Rgb {
        match self {
            Volume::Constant(c) => *c,
            Volume::Grid {
                grid,
                to_local,
                scale,
            } => {
                let local = corners.map(|c| to_local.transform_point3a(c));
                let lo = local.iter().fold(Vec3A::INFINITY, |a, &b| a.min(b));
                let hi = local.iter().fold(Vec3A::NEG_INFINITY, |a, &b| a.max(b));
                grid.max_in(lo, hi) * *scale
            }
        }
    }

    /// The same volume with every value times `factor`.
    pub fn scaled(self, factor: Rgb) -> Volume {
        match self {
            Volume::Constant(c) => Volume::Constant(c * factor),
            Volume::Grid {
                grid,
                to_local,
                scale,
            } => Volume::Grid {
                grid,
                to_local,
                scale: scale * factor,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookups_interpolate_between_voxel_centres_and_hold_at_the_edges() {
        // 2 x 1 x 1: values 1 and 3 at x = 1/4 and 3/4.
        let g = DensityGrid::new([2, 1, 1], 1, vec![1.0, 3.0]).unwrap();
        let at = |x: f32| g.lookup(Vec3A::new(x, 0.5, 0.5)).x;
        assert_eq!(at(0.25), 1.0);
        assert_eq!(at(0.75), 3.0);
        assert_eq!(at(0.5), 2.0);
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(1.0), 3.0);
        assert_eq!(g.max(), Rgb::splat(3.0));
        // Three channels, z slowest.
        let g = DensityGrid::new([1, 1, 2], 3, vec![0.0, 1.0, 2.0, 4.0, 5.0, 6.0]).unwrap();
        assert_eq!(g.lookup(Vec3A::new(0.5, 0.5, 0.5)), Rgb::new(2.0, 3.0, 4.0));
        assert_eq!(g.max(), Rgb::new(4.0, 5.0, 6.0));
    }

    /// pbrt-v4's grid: its voxels past the faces are 0, so a lookup at a face is half the
    /// edge voxel's value and one beyond half a voxel outside is 0; inside the centres both
    /// edges agree.
    #[test]
    fn the_zero_edge_fades_to_half_at_the_faces_where_clamp_holds() {
        let values = vec![1.0, 3.0];
        let clamp = DensityGrid::new([2, 1, 1], 1, values.clone()).unwrap();
        let zero = DensityGrid::new([2, 1, 1], 1, values)
            .unwrap()
            .with_edge(GridEdge::Zero);
        let at = |g: &DensityGrid, x: f32, y: f32| g.lookup(Vec3A::new(x, y, 0.5)).x;
        for x in [0.25, 0.5, 0.6, 0.75] {
            assert_eq!(at(&zero, x, 0.5), at(&clamp, x, 0.5), "{x}");
        }
        assert_eq!(at(&clamp, 0.0, 0.5), 1.0);
        assert_eq!(at(&clamp, 1.0, 0.5), 3.0);
        assert_eq!(at(&zero, 0.0, 0.5), 0.5);
        assert_eq!(at(&zero, 1.0, 0.5), 1.5);
        assert_eq!(at(&zero, 0.125, 0.5), 0.75);
        // The face of a single-voxel axis: half, and a corner of the cube an eighth.
        assert_eq!(at(&zero, 0.25, 0.0), 0.5);
        assert_eq!(zero.lookup(Vec3A::new(0.0, 0.0, 0.0)).x, 0.125);
        assert_eq!(clamp.lookup(Vec3A::new(0.0, 0.0, 0.0)).x, 1.0);
        for p in [
            Vec3A::new(-0.25, 0.5, 0.5),
            Vec3A::new(0.5, 2.0, 0.5),
            Vec3A::splat(-1e30),
        ] {
            assert_eq!(zero.lookup(p), Rgb::ZERO, "{p}");
        }
        assert_eq!(zero.lookup(Vec3A::splat(f32::NAN)), Rgb::ZERO);
        assert_eq!(zero.max(), clamp.max());
    }

    #[test]
    fn malformed_grids_are_refused() {
        assert!(DensityGrid::new([2, 2, 2], 1, vec![0.0; 7]).is_err());
        assert!(DensityGrid::new([0, 2, 2], 1, vec![]).is_err());
        assert!(DensityGrid::new([1, 1, 1], 2, vec![0.0; 2]).is_err());
        assert!(DensityGrid::new([1, 1, 1], 1, vec![-1.0]).is_err());
        assert!(DensityGrid::new([1, 1, 1], 1, vec![f32::NAN]).is_err());
        assert!(DensityGrid::new([usize::MAX, 2, 2], 1, vec![]).is_err());
    }
}
