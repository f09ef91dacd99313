//! `rigfit.load_rig`: a `.glb` / `.gltf` / `.bvh` rig read by rigfit-formats, with its stored
//! pose and its animations, as numpy arrays; posed and animated rigs written back (as
//! `rigfit pose -o` and `rigfit track -o` write them) and the skinned mesh in a pose.

use std::path::{Path, PathBuf};

use numpy::PyArray2;
use pyo3::prelude::*;
use rigfit_core::joint_model::with_clip_ranges;
use rigfit_core::{Pose, Rig};
use rigfit_formats::FormatError;
use rigfit_formats::files::{check_outputs, write_atomic};
use rigfit_formats::rig_file::{RigFile, RigOptions, RigSource, StartFrame, read_rig};

use crate::arrays::{Rows, frames, number, point_rows, to_rows, to_triangles};
use crate::error;
use crate::skeleton::PySkeleton;

/// A rigged character read from a file: its skeleton, stored pose and animations.
#[pyclass(module = "rigfit", name = "Rig", frozen)]
#[derive(Debug)]
pub struct PyRig {
    /// The rig and the document it was read from (kept to write it back).
    pub file: RigFile,
    pub skeleton: Py<PySkeleton>,
}

impl PyRig {
    pub fn rig(&self) -> &Rig {
        &self.file.rig
    }

    fn path(&self) -> &Path {
        &self.file.path
    }

    fn animation(&self, animation: usize) -> PyResult<&rigfit_core::Animation> {
        self.rig().animations.get(animation).ok_or_else(|| {
            error(format!(
                "animation: {}: has {} animations, no index {animation}",
                self.path().display(),
                self.rig().animations.len()
            ))
        })
    }

    /// The stored pose with the given local rotations / translations (caller's order) put in.
    fn posed(
        &self,
        rotations: Option<&Bound<'_, PyAny>>,
        translations: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Pose> {
        self.skeleton
            .get()
            .pose_from(self.rig().pose.clone(), rotations, translations)
    }

    /// Checks `out` as the command line checks a rig output before any work: a format this
    /// rig can be written in, and not one of the files it was read from.
    fn check_output(&self, out: &Path) -> PyResult<()> {
        let mut inputs = vec![self.file.path.as_path()];
        if let RigSource::Gltf(doc) = &self.file.source {
            inputs.extend(doc.external_files.iter().map(PathBuf::as_path));
        }
        check_outputs(&inputs, &[out])
            .and_then(|()| self.file.check_output_format(out))
            .map_err(|e| error(e.to_string()))
    }
}

/// Writes the bytes `make` returns to `out`: to a temporary file renamed into place.
fn write(
    py: Python<'_>,
    out: &Path,
    make: impl FnOnce() -> Result<Vec<u8>, FormatError> + Send,
) -> PyResult<()> {
    py.detach(|| write_atomic(out, &make()?))
        .map_err(|e| error(e.to_string()))
}

fn fps(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    number(obj, "fps")
}

#[pymethods]
impl PyRig {
    fn __repr__(&self) -> String {
        format!(
            "rigfit.Rig('{}', {} joints, {} animations)",
            self.path().display(),
            self.rig().skeleton.len(),
            self.rig().animations.len()
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
        to_rows(py, &self.skeleton.get().rotations(&self.rig().pose))
    }

    /// Local translations (n, 3) of the stored pose.
    #[getter]
    fn translations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &self.skeleton.get().translations(&self.rig().pose))
    }

    /// The character's height (vertical extent of its skinned mesh, or of its joints).
    #[getter]
    fn height(&self) -> f64 {
        self.rig().height()
    }

    /// Names of the animations in the file.
    #[getter]
    fn animations(&self) -> Vec<String> {
        self.rig()
            .animations
            .iter()
            .map(|a| a.name.clone())
            .collect()
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
        let pose = self.animation(animation)?.sample(&self.rig().pose, time);
        let skeleton = self.skeleton.get();
        Ok((
            to_rows(py, &skeleton.rotations(&pose))?,
            to_rows(py, &skeleton.translations(&pose))?,
        ))
    }

    /// The skinned mesh in a pose: ``(vertices (n, 3), faces (k, 3) int64)``, every mesh of
    /// the skin concatenated (as ``load_mesh`` reads a ``.glb`` reference). The pose is the
    /// stored one with the local ``rotations`` (n, 4) / ``translations`` (n, 3) given put in.
    #[pyo3(signature = (rotations=None, translations=None))]
    fn mesh<'py>(
        &self,
        py: Python<'py>,
        rotations: Option<&Bound<'py, PyAny>>,
        translations: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Rows<'py>, Bound<'py, PyArray2<i64>>)> {
        if self.rig().meshes.iter().all(|m| m.positions.is_empty()) {
            return Err(error(format!(
                "mesh: {}: the rig has no skinned mesh",
                self.path().display()
            )));
        }
        let pose = self.posed(rotations, translations)?;
        let mesh = py.detach(|| self.rig().skinned_surface(&pose));
        Ok((
            to_rows(py, &point_rows(&mesh.vertices))?,
            to_triangles(py, &mesh.triangles)?,
        ))
    }

    /// Writes the rig in one pose to ``path``, as ``rigfit pose -o`` does: the pose is the
    /// stored one with the local ``rotations`` (n, 4) (and ``translations`` (n, 3), when
    /// given) put in. ``.glb`` / ``.gltf`` from a glTF rig: the file with the pose as its
    /// node transforms and as the only key of its ``rigfit`` animation; ``.bvh``: the pose as
    /// the only frame; a ``.glb`` from a BVH: the rig written anew. The file is written to a
    /// temporary beside it and renamed into place; a file the rig was read from is never
    /// overwritten. Raises ``RigfitError`` naming the argument or the file.
    #[pyo3(signature = (path, rotations, translations=None))]
    fn save(
        &self,
        py: Python<'_>,
        path: PathBuf,
        rotations: &Bound<'_, PyAny>,
        translations: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        self.check_output(&path)?;
        let pose = self.posed(Some(rotations), translations)?;
        write(py, &path, || self.file.pose_bytes(&path, &pose, None))
    }

    /// Writes the rig animated through a sequence of poses to ``path``, as ``rigfit track -o``
    /// does: ``rotations`` (frames, n, 4) and ``translations`` (frames, n, 3) or None (the
    /// stored pose's), one frame every ``1 / fps`` seconds. ``.glb`` / ``.gltf`` from a glTF
    /// rig: the file with every pose as a key of its ``rigfit`` animation (replacing it) and
    /// the last as its node transforms; ``.bvh``: one frame per pose. Written atomically, as
    /// ``save``. Raises ``RigfitError`` naming the argument or the file.
    #[pyo3(signature = (path, rotations, translations=None, fps=30.0))]
    fn save_animation(
        &self,
        py: Python<'_>,
        path: PathBuf,
        rotations: &Bound<'_, PyAny>,
        translations: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = fps)] fps: f64,
    ) -> PyResult<()> {
        self.check_output(&path)?;
        if let Some(problem) = rigfit_formats::rig_file::fps_problem(fps) {
            return Err(error(format!("fps: {problem}")));
        }
        let skeleton = self.skeleton.get();
        let n = skeleton.len();
        let r = frames::<4>(rotations, "rotations", n)?;
        let t = match translations {
            Some(t) => {
                let t = frames::<3>(t, "translations", n)?;
                if t.len() != r.len() {
                    return Err(error(format!(
                        "translations: {} frames, rotations has {}",
                        t.len(),
                        r.len()
                    )));
                }
                Some(t)
            }
            None => None,
        };
        let poses = r
            .iter()
            .enumerate()
            .map(|(f, rot)| {
                skeleton.set_pose(
                    self.rig().pose.clone(),
                    Some(rot),
                    t.as_ref().map(|t| t[f].as_slice()),
                    &format!("rotations[{f}]"),
                )
            })
            .collect::<PyResult<Vec<Pose>>>()?;
        write(py, &path, || self.file.poses_bytes(&path, &poses, fps))
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
    // As `rigfit pose` does: the ranges the rig's clips show choose among the ways strokes
    // can be explained (they only score; nothing else reads them).
    let posing = with_clip_ranges(&file.rig.skeleton, &file.rig.animations);
    let skeleton = Py::new(py, PySkeleton::from_core(posing))?;
    Ok(PyRig { file, skeleton })
}
