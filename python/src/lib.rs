//! `synthcam._synthcam`: the Python bindings (pyo3). The Python package `synthcam`
//! (`python/synthcam/`) re-exports these functions and adds the pure-Python `Dataset`.
//!
//! A thin adapter, as the CLI is: it converts Python values (dicts, TOML/JSON text, NumPy arrays)
//! to the library's types, calls the library with the GIL released, and converts back. Truth
//! labels and results cross as JSON text parsed by Python's `json` module, so their keys are the
//! same as in the files the CLI writes.

mod calibrate;
mod convert;
mod detect;
mod render;
mod sim;

use pyo3::prelude::*;

pyo3::create_exception!(
    _synthcam,
    SynthcamError,
    pyo3::exceptions::PyException,
    "An error of the synthcam library (bad input, a render or calibration that failed); the message gives the cause chain."
);

/// The extension module.
#[pymodule]
fn _synthcam(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SynthcamError", m.py().get_type::<SynthcamError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_depth_mask, m)?)?;
    m.add_function(wrap_pyfunction!(render::adapter, m)?)?;
    m.add_function(wrap_pyfunction!(render::load_image, m)?)?;
    m.add_function(wrap_pyfunction!(detect::detect, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate_rig, m)?)?;
    m.add_class::<sim::PySim>()?;
    Ok(())
}
