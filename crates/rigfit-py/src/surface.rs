//! `rigfit.SurfaceTracker`: deformable surface tracking (Cagniart, Boyer and Ilic 2010) of a
//! reference mesh through a sequence of point clouds or meshes, one frame at a time; the
//! engine of `rigfit surface`, with the same options, bounds and frame handling.

use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rigfit_core::surface::{Observations, SurfaceOptions, SurfaceTracker};

use crate::arrays::{number, point_rows, to_rows, to_triangles, triangles};
use crate::error;
use crate::mesh::tri_mesh;

/// A count argument (a non-negative whole number), or a `RigfitError` naming it; its bounds
/// are checked with the other options.
fn count(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<usize> {
    let whole = if obj.is_instance_of::<pyo3::types::PyBool>() {
        None
    } else {
        obj.extract::<i64>().ok()
    };
    match whole {
        Some(v) if v >= 0 => {
            usize::try_from(v).map_err(|_| error(format!("{name}: {v} is too large")))
        }
        Some(v) => Err(error(format!(
            "{name}: expected a positive whole number, got {v}"
        ))),
        None => {
            let text = obj.repr().map_or_else(|_| "?".into(), |r| r.to_string());
            Err(error(format!(
                "{name}: expected a whole number, got {text}"
            )))
        }
    }
}

fn patch_radius(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    number(obj, "patch_radius")
}

fn outliers(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    number(obj, "outliers")
}

fn rigidity(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    number(obj, "rigidity")
}

fn merge(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    number(obj, "merge")
}

fn iterations(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    count(obj, "iterations")
}

fn coarse(obj: &Bound<'_, PyAny>) -> PyResult<usize> {
    count(obj, "coarse")
}

fn points_per_vertex(obj: &Bound<'_, PyAny>) -> PyResult<f64> {
    number(obj, "points_per_vertex")
}

/// What tracking one frame found.
#[pyclass(module = "rigfit", name = "SurfaceFit", frozen, get_all)]
#[derive(Debug)]
pub struct PySurfaceFit {
    /// The reference's vertices (n, 3), moved onto the frame (vertex for vertex).
    pub vertices: Py<PyArray2<f64>>,
    /// How many of the frame's points were taken as inliers.
    pub inliers: usize,
    /// Root mean square distance of the points to their vertices, weighted by posteriors.
    pub rms: f64,
    /// EM iterations run.
    pub iterations: usize,
    /// The final kernel width ``sigma`` (in the reference's units).
    pub sigma: f64,
    /// Wall time of the frame's fit, in seconds.
    pub seconds: f64,
}

#[pymethods]
impl PySurfaceFit {
    fn __repr__(&self) -> String {
        format!(
            "rigfit.SurfaceFit({} inliers, rms {:.3e}, {} iterations, {:.1} ms)",
            self.inliers,
            self.rms,
            self.iterations,
            self.seconds * 1000.0
        )
    }
}

/// Tracks a reference mesh through a sequence of point clouds (or meshes), each frame
/// starting from the previous one's result: the reference is cut into patches that move
/// rigidly, held together by a rigidity energy, and fitted to each frame by EM with an
/// outlier class (Cagniart et al. 2010; what ``rigfit surface`` runs).
///
/// ``vertices`` (n, 3) and ``faces`` (k, 3) vertex indices are the reference (it needs faces:
/// they give the patches and normals). The options are ``rigfit surface``'s, with the same
/// defaults and bounds: ``patch_radius`` (largest patch radius, a fraction of the reference's
/// bounding-box diagonal, 0.0001 to 10), ``outliers`` (expected fraction of outlier points,
/// in [0, 1)), ``rigidity`` (weight of the rigidity between neighbouring patches, >= 0),
/// ``iterations`` (EM iterations per frame at most, 1 to 1000), ``merge`` (merge each
/// frame's points by cubes of this many point spacings first; 0: every point, >= 0),
/// ``coarse`` (a frame's first iterations, two or four with ``fast_motion``, use one point
/// in this many, 1 to 1024), ``points_per_vertex`` (on an object of rigid pieces, every
/// iteration fits about this many points a reference vertex; 0: every point, >= 0),
/// ``fast_motion`` (``--fast-motion``: for limbs that move a
/// tenth of the object or more between frames, at about twice the time on such frames) and
/// ``piece_tree`` (``False`` is ``--no-piece-tree``: a many-part object's patches start
/// from their own motion continued, not from the pieces' kinematic tree, and its pieces
/// are handed out as the surface fit left them, not laid rigidly).
#[pyclass(module = "rigfit", name = "SurfaceTracker")]
#[derive(Debug)]
pub struct PySurfaceTracker {
    tracker: SurfaceTracker,
    triangles: Vec<[u32; 3]>,
    fast_motion: bool,
}

#[pymethods]
impl PySurfaceTracker {
    // The defaults are the core's; the text signature spells them out for `help()` and
    // `inspect` (python/tests/test_surface.py checks it and the stubs against the core's).
    #[new]
    #[pyo3(signature = (
        vertices,
        faces,
        *,
        patch_radius = SurfaceOptions::default().patches.radius,
        outliers = SurfaceOptions::default().data.outlier_ratio,
        rigidity = SurfaceOptions::default().rigidity,
        iterations = SurfaceOptions::default().max_iterations,
        merge = SurfaceOptions::default().merge_cell,
        coarse = SurfaceOptions::default().coarse_stride,
        points_per_vertex = SurfaceOptions::default().points_per_vertex,
        fast_motion = false,
        piece_tree = true,
    ), text_signature = "(vertices, faces, *, patch_radius=0.06, outliers=0.15, rigidity=4.0, iterations=25, merge=0.0, coarse=4, points_per_vertex=1.0, fast_motion=False, piece_tree=True)")]
    fn new(
        py: Python<'_>,
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = patch_radius)] patch_radius: f64,
        #[pyo3(from_py_with = outliers)] outliers: f64,
        #[pyo3(from_py_with = rigidity)] rigidity: f64,
        #[pyo3(from_py_with = iterations)] iterations: usize,
        #[pyo3(from_py_with = merge)] merge: f64,
        #[pyo3(from_py_with = coarse)] coarse: usize,
        #[pyo3(from_py_with = points_per_vertex)] points_per_vertex: f64,
        fast_motion: bool,
        piece_tree: bool,
    ) -> PyResult<Self> {
        let mut options = if fast_motion {
            SurfaceOptions::fast_motion()
        } else {
            SurfaceOptions::default()
        };
        options.patches.radius = patch_radius;
        options.data.outlier_ratio = outliers;
        options.rigidity = rigidity;
        options.max_iterations = iterations;
        options.merge_cell = merge;
        options.coarse_stride = coarse;
        options.points_per_vertex = points_per_vertex;
        if !piece_tree {
            options.piece_tree = None;
        }
        options
            .check()
            .map_err(|e| error(format!("{}: {}", e.option.keyword(), e.problem)))?;
        let mut reference = tri_mesh(vertices, "vertices", None, None)?;
        if reference.vertices.is_empty() {
            return Err(error("vertices: the reference has no vertices"));
        }
        reference.triangles = triangles(faces, "faces", reference.vertices.len())?;
        if reference.triangles.is_empty() {
            return Err(error(
                "faces: the reference has no triangles (surface tracking needs faces for normals and patches; a point cloud cannot be the reference)",
            ));
        }
        let tracker = py
            .detach(|| SurfaceTracker::new(&reference, &options))
            .map_err(|e| error(format!("SurfaceTracker: {e}")))?;
        Ok(Self {
            tracker,
            triangles: reference.triangles,
            fast_motion,
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "rigfit.SurfaceTracker({} vertices, {} faces, {} patches)",
            self.tracker.model.rest.len(),
            self.triangles.len(),
            self.tracker.model.patch_count()
        )
    }

    /// Aligns the reference to one frame, starting from the previous frame's result, and
    /// returns the fit. ``points`` (m, 3); ``normals`` (m, 3), when the frame has them;
    /// ``faces`` (k, 3) vertex indices into ``points``, when the frame is a mesh. As
    /// ``rigfit surface`` reads a frame file: the given normals when every one is usable,
    /// else the faces' normals, else normals estimated from the points (unsigned).
    #[pyo3(signature = (points, normals=None, faces=None))]
    fn track(
        &mut self,
        py: Python<'_>,
        points: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        faces: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PySurfaceFit> {
        let frame = tri_mesh(points, "points", normals, faces)?;
        let tracker = &mut self.tracker;
        let (fit, seconds) = py
            .detach(|| {
                let observations = Observations::from_mesh(&frame)?;
                let t0 = std::time::Instant::now();
                let fit = tracker.track(&observations)?;
                Ok((fit, t0.elapsed().as_secs_f64()))
            })
            .map_err(|e: rigfit_core::surface::SurfaceError| error(format!("track: {e}")))?;
        Ok(PySurfaceFit {
            vertices: to_rows(py, &point_rows(&fit.positions))?.unbind(),
            inliers: fit.inliers,
            rms: fit.rms,
            iterations: fit.iterations,
            sigma: fit.sigma,
            seconds,
        })
    }

    /// The reference's vertices (n, 3) as tracked so far (the last frame's fit; before any
    /// frame, the reference itself).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &point_rows(&self.tracker.positions()))
    }

    /// The reference's faces (k, 3), vertex indices (int64).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        to_triangles(py, &self.triangles)
    }

    /// How many patches the reference was cut into.
    #[getter]
    fn patch_count(&self) -> usize {
        self.tracker.model.patch_count()
    }

    /// The options in force, by keyword (``patch_radius``, ``outliers``, ``rigidity``,
    /// ``iterations``, ``merge``, ``coarse``, ``points_per_vertex``, ``fast_motion``,
    /// ``piece_tree``).
    #[getter]
    fn options<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let o = &self.tracker.options;
        let d = PyDict::new(py);
        d.set_item("patch_radius", o.patches.radius)?;
        d.set_item("outliers", o.data.outlier_ratio)?;
        d.set_item("rigidity", o.rigidity)?;
        d.set_item("iterations", o.max_iterations)?;
        d.set_item("merge", o.merge_cell)?;
        d.set_item("coarse", o.coarse_stride)?;
        d.set_item("points_per_vertex", o.points_per_vertex)?;
        d.set_item("fast_motion", self.fast_motion)?;
        d.set_item("piece_tree", o.piece_tree.is_some())?;
        Ok(d)
    }
}
