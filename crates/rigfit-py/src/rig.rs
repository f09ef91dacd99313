//! `rigfit.load_rig`: a `.glb` / `.gltf` / `.bvh` rig read by rigfit-formats, with its stored
//! pose and its animations, as numpy arrays.

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::prelude::*;
use rigfit_core::Rig;
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};

use crate::arrays::{Rows, to_rows};
use crate::error;
use crate::skeleton::PySkeleton;

/// A rigged character read from a file: its skeleton, stored pose and animations.
#[pyclass(module = "rigfit", name = "Rig", frozen)]
#[derive(Debug)]
pub struct PyRig {
    pub rig: Rig,
    pub skeleton: Py<PySkeleton>,
    pub path: PathBuf,
}

impl PyRig {
    fn animation(&self, animation: usize) -> PyResult<&rigfit_core::Animation> {
        self.rig.animations.get(animation).ok_or_else(|| {
            error(format!(
                "animation: {}: has {} animations, no index {animation}",
                self.path.display(),
                self.rig.animations.len()
            ))
        })
    }
}

#[pymethods]
impl PyRig {
    fn __repr__(&self) -> String {
        format!(
            "rigfit.Rig('{}', {} joints, {} animations)",
            self.path.display(),
            self.rig.skeleton.len(),
            self.rig.animations.len()
        )
    }

    /// The joint tree (its order is the file's, parents first).
    #[getter]
    fn skeleton(&self, py: Python<'_>) -> Py<PySkeleton> {
        self.skeleton.clone_ref(py)
    }

    /// Local rotations (n, 4) ``[x, y, z, w]`` of the stored pose (BVH: the start frame).
    #[getter]
    fn rotations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &self.skeleton.get().rotations(&self.rig.pose))
    }

    /// Local translations (n, 3) of the stored pose.
    #[getter]
    fn translations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &self.skeleton.get().translations(&self.rig.pose))
    }

    /// The character's height (vertical extent of its skinned mesh, or of its joints).
    #[getter]
    fn height(&self) -> f64 {
        self.rig.height()
    }

    /// Names of the animations in the file.
    #[getter]
    fn animations(&self) -> Vec<String> {
        self.rig.animations.iter().map(|a| a.name.clone()).collect()
    }

    /// ``(start, end)`` times in seconds of an animation.
    #[pyo3(signature = (animation=0))]
    fn animation_range(&self, animation: usize) -> PyResult<(f64, f64)> {
        let a = self.animation(animation)?;
        Ok((a.start(), a.end()))
    }

    /// The sampling period of a frame-based animation (BVH), or None.
    #[pyo3(signature = (animation=0))]
    fn frame_time(&self, animation: usize) -> PyResult<Option<f64>> {
        Ok(self.animation(animation)?.frame_time)
    }

    /// The pose of an animation at ``time`` seconds: ``(rotations (n, 4), translations (n, 3))``.
    #[pyo3(signature = (time, animation=0))]
    fn sample<'py>(
        &self,
        py: Python<'py>,
        time: f64,
        animation: usize,
    ) -> PyResult<(Rows<'py>, Rows<'py>)> {
        if !time.is_finite() {
            return Err(error(format!("time: expected a finite number, got {time}")));
        }
        let pose = self.animation(animation)?.sample(&self.rig.pose, time);
        let skeleton = self.skeleton.get();
        Ok((
            to_rows(py, &skeleton.rotations(&pose))?,
            to_rows(py, &skeleton.translations(&pose))?,
        ))
    }
}

/// Reads a rig: ``.glb`` / ``.gltf`` with a skin (``skin`` picks one by name) or ``.bvh``
/// (``start_frame``: a frame number, ``"rest"`` for all channels zero, default frame 0).
/// Raises ``RigfitError`` with one line naming the file and the problem.
#[pyfunction]
#[pyo3(signature = (path, *, skin=None, start_frame=None))]
pub fn load_rig(
    py: Python<'_>,
    path: PathBuf,
    skin: Option<String>,
    start_frame: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyRig> {
    let start_frame = match start_frame {
        None => StartFrame::First,
        Some(v) => {
            if let Ok(k) = v.extract::<usize>() {
                StartFrame::Frame(k)
            } else if v.extract::<String>().is_ok_and(|s| s == "rest") {
                StartFrame::Rest
            } else {
                return Err(error(
                    "start_frame: expected a frame number or 'rest'".to_string(),
                ));
            }
        }
    };
    let options = RigOptions { skin, start_frame };
    let file = py
        .detach(|| read_rig(&path, &options))
        .map_err(|e| error(e.to_string()))?;
    let skeleton = Py::new(py, PySkeleton::from_core(file.rig.skeleton.clone()))?;
    Ok(PyRig {
        rig: file.rig,
        skeleton,
        path,
    })
}
