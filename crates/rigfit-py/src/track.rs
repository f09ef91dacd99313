//! `rigfit.Tracker`: articulated tracking of a body or hand through point clouds (Dewaele et
//! al. 2006), one frame at a time.

use numpy::PyArray2;
use pyo3::prelude::*;
use rigfit_core::joint_model::with_clip_model;
use rigfit_core::track::{
    ArticulatedModel, FrameStart, StartMode, Take, TakeOptions, TrackOptions,
};
use rigfit_core::{Point3, Rig};

use crate::arrays::{rows, to_rows};
use crate::error;
use crate::rig::PyRig;
use crate::skeleton::PySkeleton;

/// What tracking one frame found. Arrays are in the skeleton's joint order.
#[pyclass(module = "rigfit", name = "FrameFit", frozen, get_all)]
#[derive(Debug)]
pub struct PyFrameFit {
    /// Local rotations (n, 4) ``[x, y, z, w]``.
    pub rotations: Py<PyArray2<f64>>,
    /// Local translations (n, 3).
    pub translations: Py<PyArray2<f64>>,
    /// World positions (n, 3) of every joint.
    pub positions: Py<PyArray2<f64>>,
    /// Per data point, whether it was taken as an inlier.
    pub inlier: Vec<bool>,
    /// How many data points were taken as inliers.
    pub inliers: usize,
    /// EM iterations run.
    pub em_iterations: usize,
    /// How the fit was found: ``"tracked"`` (on from the previous frame), ``"stored"`` /
    /// ``"search"`` (the first frame, from the stored pose or from the search),
    /// ``"recovered"`` (the frame's fit collapsed and the search found the body again) or
    /// ``"collapsed"`` (it collapsed and the search found nothing better).
    pub start: &'static str,
}

/// The name Python sees for how a frame's fit was found.
fn start_name(start: &FrameStart) -> &'static str {
    match start {
        FrameStart::Tracked => "tracked",
        FrameStart::Stored { .. } => "stored",
        FrameStart::Searched { .. } => "search",
        FrameStart::Collapsed {
            recovered: true, ..
        } => "recovered",
        FrameStart::Collapsed { .. } => "collapsed",
    }
}

/// Tracks one articulated model through a sequence of point clouds.
///
/// Build it from a ``Rig`` (its skinned mesh gives the surface) or from a ``Skeleton`` and a
/// start pose (``rotations`` / ``translations``; ellipsoids sized from the bone lengths).
/// ``init`` says where the first frame starts: ``"auto"`` (the start pose when it explains
/// the first frame, else the search for the body wherever it stands and however it is
/// turned), ``"stored"`` or ``"search"``; ``recover``: search again on a frame whose fit
/// collapsed. ``noise`` and ``max_motion`` are fractions of the character's height;
/// ``method`` is ``"rigfit"`` or ``"paper"``.
#[pyclass(module = "rigfit", name = "Tracker")]
#[derive(Debug)]
pub struct PyTracker {
    take: Take,
    skeleton: PySkeleton,
}

#[pymethods]
impl PyTracker {
    #[new]
    #[pyo3(signature = (model, rotations=None, translations=None, *, noise=0.01, max_motion=0.04, method="rigfit", init="auto", recover=true))]
    fn new(
        py: Python<'_>,
        model: &Bound<'_, PyAny>,
        rotations: Option<&Bound<'_, PyAny>>,
        translations: Option<&Bound<'_, PyAny>>,
        noise: f64,
        max_motion: f64,
        method: &str,
        init: &str,
        recover: bool,
    ) -> PyResult<Self> {
        let start = match init {
            "auto" => StartMode::Auto,
            "stored" => StartMode::Stored,
            "search" => StartMode::Search,
            other => {
                return Err(error(format!(
                    "init: expected 'auto', 'stored' or 'search', got '{other}'"
                )));
            }
        };
        let take_options = TakeOptions {
            start,
            recover,
            ..TakeOptions::default()
        };
        let mut options = match method {
            "rigfit" => TrackOptions::default(),
            "paper" => TrackOptions::paper(),
            other => {
                return Err(error(format!(
                    "method: expected 'rigfit' or 'paper', got '{other}'"
                )));
            }
        };
        for (name, v) in [("noise", noise), ("max_motion", max_motion)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(error(format!(
                    "{name}: expected a positive fraction of the height, got {v}"
                )));
            }
        }
        options.noise = noise;
        options.max_motion = max_motion;
        let (rig, skeleton) = if let Ok(rig) = model.cast::<PyRig>() {
            let rig = rig.get();
            let mut r = rig.rig().clone();
            let skeleton = rig.skeleton.get().clone();
            if rotations.is_some() || translations.is_some() {
                r.pose = skeleton.pose(rotations, translations)?;
            }
            // As `rigfit track` does: the clips' hinges, and their ranges as soft limits.
            r.skeleton = with_clip_model(&r.skeleton, &r.animations);
            (r, skeleton)
        } else if let Ok(s) = model.cast::<PySkeleton>() {
            let skeleton = s.get().clone();
            let pose = skeleton.pose(rotations, translations)?;
            let rig = Rig {
                skeleton: skeleton.skeleton.clone(),
                pose,
                meshes: Vec::new(),
                animations: Vec::new(),
            };
            (rig, skeleton)
        } else {
            return Err(error("model: expected a rigfit.Rig or a rigfit.Skeleton"));
        };
        let take = py
            .detach(|| {
                ArticulatedModel::from_rig(&rig, 0)
                    .and_then(|m| Take::new(m, options, take_options))
            })
            .map_err(|e| error(format!("Tracker: {e}")))?;
        Ok(Self { take, skeleton })
    }

    /// Aligns the model to one frame's ``points`` (m, 3), starting from the previous frame's
    /// pose, and returns the fit.
    fn track(&mut self, py: Python<'_>, points: &Bound<'_, PyAny>) -> PyResult<PyFrameFit> {
        let data: Vec<Point3> = rows::<3>(points, "points", None)?
            .into_iter()
            .map(Point3::from)
            .collect();
        let take = &mut self.take;
        let frame = py
            .detach(|| take.track(&data))
            .map_err(|e| error(format!("track: {e}")))?;
        let fit = frame.fit;
        let s = &self.skeleton;
        Ok(PyFrameFit {
            rotations: to_rows(py, &s.rotations(&fit.pose))?.unbind(),
            translations: to_rows(py, &s.translations(&fit.pose))?.unbind(),
            positions: to_rows(py, &s.positions(&fit.pose))?.unbind(),
            inlier: fit.inlier,
            inliers: fit.inliers,
            em_iterations: fit.em_iterations,
            start: start_name(&frame.start),
        })
    }

    /// World positions (n, 3) of the joints in the current pose.
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &self.skeleton.positions(self.take.tracker().pose()))
    }

    /// Model surface points (k, 3) in the current pose (where the tracker expects data).
    fn surface_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let points: Vec<[f64; 3]> = self
            .take
            .tracker()
            .texture_positions()
            .iter()
            .map(|p| p.coords.into())
            .collect();
        to_rows(py, &points)
    }
}
