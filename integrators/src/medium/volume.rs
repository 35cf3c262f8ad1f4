//! Values over space that media are made of: a constant, or a grid of voxels looked up
//! trilinearly (Mitsuba 3's `constvolume` and `gridvolume`, pbrt-v4's `SampledGrid`).

use crate::Rgb;
use glam::{Affine3A, Vec3A};
use std::sync::Arc;

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
        })
    }

    /// The largest value of each channel.
    pub fn max(&self) -> Rgb {
        self.max
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
    /// `(i + 1/2) / n`, and outside the centres the nearest voxels' values hold.
    pub fn lookup(&self, p: Vec3A) -> Rgb {
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
        let [fx, fy, fz] = frac;
        let lerp = |a: Rgb, b: Rgb, t: f32| a + (b - a) * t;
        let c00 = lerp(self.voxel(x0, y0, z0), self.voxel(x1, y0, z0), fx);
        let c10 = lerp(self.voxel(x0, y1, z0), self.voxel(x1, y1, z0), fx);
        let c01 = lerp(self.voxel(x0, y0, z1), self.voxel(x1, y0, z1), fx);
        let c11 = lerp(self.voxel(x0, y1, z1), self.voxel(x1, y1, z1), fx);
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
