//! `raylab._native`: the engine bound to Python with PyO3. The Python package `raylab`
//! (python/raylab) wraps it with keyword arguments, docstrings and pandas; everything it does
//! is the engine's own code, as the command line runs it: scenes load through the same
//! importers, renders run the same [`raylab::render::job::Job`], edits go through the same
//! incremental [`raylab::scene::edit::SceneState`] `render --watch` uses, and images are read
//! and written by the same functions.

mod images;
mod registry;
mod scene;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _native,
    RaylabError,
    PyException,
    "An error of raylab's, with the message the command line prints (file, line and column, or the entity)."
);

/// The message of an engine error, as the command line prints it after `error: `.
pub(crate) fn error(e: impl Into<anyhow::Error>) -> PyErr {
    RaylabError::new_err(format!("{:#}", e.into()))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("RaylabError", m.py().get_type::<RaylabError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(registry::integrators, m)?)?;
    m.add_function(wrap_pyfunction!(images::read, m)?)?;
    m.add_function(wrap_pyfunction!(images::write, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load, m)?)?;
    m.add_class::<scene::Scene>()?;
    Ok(())
}
