//! The `rigfit` Python package: a thin shell over rigfit-core (and rigfit-formats for
//! reading and writing rigs, meshes and point clouds). Arrays go in and come out as numpy arrays of float64; joints are
//! given in the caller's order (parents may come after children) and returned in it.
//! Every error is a `rigfit.RigfitError` (a `ValueError`) with one line of text.

mod arrays;
mod batch;
mod mesh;
mod pose;
mod rig;
mod skeleton;
mod surface;
mod track;

use pyo3::prelude::*;

pyo3::create_exception!(
    rigfit,
    RigfitError,
    pyo3::exceptions::PyValueError,
    "Bad input or a problem rigfit cannot solve; the message names the argument and the problem."
);

/// A `RigfitError` with `message`.
pub(crate) fn error(message: impl Into<String>) -> PyErr {
    RigfitError::new_err(message.into())
}

/// Pose rigged characters from 3D strokes, track articulated bodies and deformable surfaces
/// in point clouds.
#[pymodule]
fn _rigfit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("RigfitError", m.py().get_type::<RigfitError>())?;
    m.add_class::<skeleton::PySkeleton>()?;
    m.add_class::<pose::PyPoseResult>()?;
    m.add_class::<rig::PyRig>()?;
    m.add_class::<track::PyTracker>()?;
    m.add_class::<track::PyFrameFit>()?;
    m.add_function(wrap_pyfunction!(pose::solve_pose, m)?)?;
    m.add_function(wrap_pyfunction!(pose::draw_strokes, m)?)?;
    m.add_function(wrap_pyfunction!(rig::load_rig, m)?)?;
    m.add_function(wrap_pyfunction!(batch::run_take, m)?)?;
    m.add_function(wrap_pyfunction!(batch::read_jobs, m)?)?;
    m.add_function(wrap_pyfunction!(batch::run_batch, m)?)?;
    m.add_class::<surface::PySurfaceTracker>()?;
    m.add_class::<surface::PySurfaceFit>()?;
    m.add_function(wrap_pyfunction!(mesh::load_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::load_cloud, m)?)?;
    m.add_function(wrap_pyfunction!(mesh::save_mesh, m)?)?;
    Ok(())
}
