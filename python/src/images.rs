//! Images between numpy and the engine: `raylab.read` and `raylab.write` by the functions
//! the command line reads and writes images with, and films as arrays.

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use raylab::output::{self, DisplaySettings, Film, Tonemap};
use std::path::PathBuf;

/// `(H, W, 3)` float32 of one value per pixel and channel, row-major from the top-left corner.
pub fn array<'py>(
    py: Python<'py>,
    width: u32,
    height: u32,
    values: &[glam::Vec3],
) -> Bound<'py, PyArray3<f32>> {
    let flat: Vec<f32> = values.iter().flat_map(|v| v.to_array()).collect();
    Array3::from_shape_vec((height as usize, width as usize, 3), flat)
        .expect("a film holds width x height pixels")
        .into_pyarray(py)
}

/// A film's mean radiance, and its per-pixel variance of the mean when it was measured.
pub type Arrays<'py> = (Bound<'py, PyArray3<f32>>, Option<Bound<'py, PyArray3<f32>>>);

/// The arrays of `film`.
pub fn arrays_of<'py>(py: Python<'py>, film: &Film) -> Arrays<'py> {
    let image = array(py, film.width, film.height, &film.pixels);
    let variance = film
        .has_variance
        .then(|| array(py, film.width, film.height, &film.variance));
    (image, variance)
}

/// The image of an EXR (or PNG, HDR) file, as `raylab diff` reads it, and its variance
/// layer if it has one.
#[pyfunction]
pub fn read(py: Python<'_>, path: PathBuf) -> PyResult<Arrays<'_>> {
    let film = py
        .detach(|| output::read_image(&path))
        .map_err(crate::error)?;
    Ok(arrays_of(py, &film))
}

/// Writes `image` (`(H, W, 3)` float32 linear radiance) to `path`, EXR or PNG by its
/// extension, as `raylab render` writes its output: a PNG through `exposure` (stops) and
/// `tonemap` (`clamp`, `aces`, `reinhard`), an EXR linear (with `variance` as its variance
/// layer, when given).
#[pyfunction]
#[pyo3(signature = (path, image, variance=None, exposure=0.0, tonemap="clamp"))]
pub fn write(
    py: Python<'_>,
    path: PathBuf,
    image: PyReadonlyArray3<'_, f32>,
    variance: Option<PyReadonlyArray3<'_, f32>>,
    exposure: f32,
    tonemap: &str,
) -> PyResult<()> {
    let tonemap = match tonemap {
        "clamp" => Tonemap::Clamp,
        "aces" => Tonemap::Aces,
        "reinhard" => Tonemap::Reinhard,
        other => {
            return Err(PyValueError::new_err(format!(
                "tonemap `{other}`: expected clamp, aces or reinhard"
            )))
        }
    };
    if !exposure.is_finite() {
        return Err(PyValueError::new_err("exposure must be finite"));
    }
    let (height, width) = shape_of(&image, "image")?;
    let mut film = Film::new(width, height);
    film.pixels = pixels(&image)?;
    if let Some(v) = variance {
        if shape_of(&v, "variance")? != (height, width) {
            return Err(PyValueError::new_err(
                "variance must have the image's shape",
            ));
        }
        film.variance = pixels(&v)?;
        film.has_variance = true;
    }
    let display = DisplaySettings { exposure, tonemap };
    py.detach(|| output::write_image(&path, &film, display))
        .map_err(crate::error)
}

/// `(height, width)` of an `(H, W, 3)` array.
fn shape_of(a: &PyReadonlyArray3<'_, f32>, what: &str) -> PyResult<(u32, u32)> {
    let shape = a.shape();
    let fits = |n: usize| u32::try_from(n).ok().filter(|n| *n > 0);
    match (shape[2], fits(shape[0]), fits(shape[1])) {
        (3, Some(h), Some(w)) => Ok((h, w)),
        _ => Err(PyValueError::new_err(format!(
            "{what} must have shape (height, width, 3), not {shape:?}"
        ))),
    }
}

/// The pixels of an `(H, W, 3)` array, row-major.
fn pixels(a: &PyReadonlyArray3<'_, f32>) -> PyResult<Vec<glam::Vec3>> {
    let view = a.as_array();
    Ok(view
        .rows()
        .into_iter()
        .map(|rgb| glam::Vec3::new(rgb[0], rgb[1], rgb[2]))
        .collect())
}
