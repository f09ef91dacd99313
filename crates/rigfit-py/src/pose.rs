//! `rigfit.solve_pose` (posing from strokes, Cannavò et al. 2020) and `rigfit.draw_strokes`
//! (ground-truth strokes drawn through a posed skeleton, for tests and demos).

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use rand::SeedableRng;
use rigfit_core::pose::sketch::{CaseOptions, make_case};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose as core_solve_pose};
use rigfit_core::{Point3, Stroke};

use crate::arrays::{Rows, rows, to_ints, to_rows};
use crate::error;
use crate::skeleton::PySkeleton;

/// What ``solve_pose`` found. Arrays are in the skeleton's joint order.
#[pyclass(module = "rigfit", name = "PoseResult", frozen, get_all)]
#[derive(Debug)]
pub struct PyPoseResult {
    /// Local rotations (n, 4) ``[x, y, z, w]``.
    pub rotations: Py<PyArray2<f64>>,
    /// Local translations (n, 3) (only the root's may differ from the start).
    pub translations: Py<PyArray2<f64>>,
    /// World positions (n, 3) of every joint after posing.
    pub positions: Py<PyArray2<f64>>,
    /// For each stroke, the names of the joints (bones) it was matched to, in order along
    /// the stroke; empty for a stroke set aside as a stray.
    pub stroke_bones: Vec<Vec<String>>,
    /// Match-and-align iterations run.
    pub iterations: usize,
    /// Final energy (mean squared distances, in the skeleton's units squared).
    pub energy: f64,
    /// Wall time of the solve.
    pub seconds: f64,
}

#[pymethods]
impl PyPoseResult {
    fn __repr__(&self) -> String {
        let matched = self.stroke_bones.iter().filter(|b| !b.is_empty()).count();
        format!(
            "rigfit.PoseResult({} strokes, {matched} matched, {} iterations, energy {:.3e})",
            self.stroke_bones.len(),
            self.iterations,
            self.energy
        )
    }
}

/// Reads the strokes argument: a sequence of (m, 3) arrays.
fn read_strokes(
    strokes: &Bound<'_, PyAny>,
    stroke_bones: Option<Vec<Option<Vec<String>>>>,
) -> PyResult<Vec<Stroke>> {
    let mut out = Vec::new();
    let items = strokes
        .try_iter()
        .map_err(|_| error("strokes: expected a sequence of (m, 3) arrays"))?;
    for (s, item) in items.enumerate() {
        let points = rows::<3>(&item?, &format!("strokes[{s}]"), None)?;
        out.push(Stroke {
            points: points.into_iter().map(Point3::from).collect(),
            bones: None,
        });
    }
    if let Some(pins) = stroke_bones {
        if pins.len() != out.len() {
            return Err(error(format!(
                "stroke_bones: expected {} entries (one per stroke, None for free), got {}",
                out.len(),
                pins.len()
            )));
        }
        for (stroke, pin) in out.iter_mut().zip(pins) {
            stroke.bones = pin;
        }
    }
    Ok(out)
}

/// Poses ``skeleton`` so its bones lie along 3D ``strokes``.
///
/// ``strokes``: a sequence of (m, 3) arrays (polylines in the skeleton's world space, any
/// order and direction; one per bone, per limb, or a stray). The solve starts from local
/// ``rotations`` (n, 4) / ``translations`` (n, 3) (the rest pose when omitted). ``bones``
/// lists the joints that may move (all by default); ``stroke_bones[i]`` pins stroke i to
/// those bones (None: free). ``height`` sets the character's size the solver's tolerances
/// scale with (default: the joints' vertical extent; rigfit assumes y is up).
/// ``method``: ``"rigfit"`` (default) or ``"paper"`` (the published softassign method).
/// Raises ``RigfitError`` on bad input (no strokes, a stroke of one point, NaN, unknown bone).
#[pyfunction]
#[pyo3(signature = (skeleton, strokes, rotations=None, translations=None, *, bones=None, stroke_bones=None, height=None, method="rigfit"))]
pub fn solve_pose(
    py: Python<'_>,
    skeleton: &PySkeleton,
    strokes: &Bound<'_, PyAny>,
    rotations: Option<&Bound<'_, PyAny>>,
    translations: Option<&Bound<'_, PyAny>>,
    bones: Option<Vec<String>>,
    stroke_bones: Option<Vec<Option<Vec<String>>>>,
    height: Option<f64>,
    method: &str,
) -> PyResult<PyPoseResult> {
    let options = match method {
        "rigfit" => PoseOptions::default(),
        "paper" => PoseOptions::paper(),
        other => {
            return Err(error(format!(
                "method: expected 'rigfit' or 'paper', got '{other}'"
            )));
        }
    };
    let start = skeleton.pose(rotations, translations)?;
    let strokes = read_strokes(strokes, stroke_bones)?;
    let height = match height {
        Some(h) if h.is_finite() && h > 0.0 => h,
        Some(h) => {
            return Err(error(format!(
                "height: expected a positive number, got {h}"
            )));
        }
        None => skeleton.pose_height(&start),
    };
    let core = &skeleton.skeleton;
    let t0 = std::time::Instant::now();
    let result = py
        .detach(|| {
            core_solve_pose(
                &PoseProblem {
                    skeleton: core,
                    start: &start,
                    strokes: &strokes,
                    movable: bones.as_deref(),
                    height,
                },
                &options,
            )
        })
        .map_err(|e| error(format!("solve_pose: {e}")))?;
    let seconds = t0.elapsed().as_secs_f64();
    let stroke_bones = result
        .stroke_bones
        .iter()
        .map(|b| b.iter().map(|&j| core.joint(j).name.clone()).collect())
        .collect();
    Ok(PyPoseResult {
        rotations: to_rows(py, &skeleton.rotations(&result.pose))?.unbind(),
        translations: to_rows(py, &skeleton.translations(&result.pose))?.unbind(),
        positions: to_rows(py, &skeleton.positions(&result.pose))?.unbind(),
        stroke_bones,
        iterations: result.iterations,
        energy: result.energy,
        seconds,
    })
}

/// Draws ground-truth strokes through ``skeleton`` posed by ``rotations`` / ``translations``:
/// one stroke per limb chain at least ``min_chain_length`` long, sampled densely with Gaussian
/// noise (``noise`` and lengths are fractions of the height), ``drop_limbs`` limbs left
/// undrawn and ``stray_strokes`` strays added; seeded.
/// Returns ``(strokes, drawn_joints)``: a list of (m, 3) arrays and the indices of the joints
/// on drawn chains (the ones to measure a solve's error on).
#[pyfunction]
#[pyo3(signature = (skeleton, rotations=None, translations=None, *, height=None, noise=0.01, min_chain_length=0.1, drop_limbs=0, stray_strokes=0, seed=0))]
pub fn draw_strokes<'py>(
    py: Python<'py>,
    skeleton: &PySkeleton,
    rotations: Option<&Bound<'py, PyAny>>,
    translations: Option<&Bound<'py, PyAny>>,
    height: Option<f64>,
    noise: f64,
    min_chain_length: f64,
    drop_limbs: usize,
    stray_strokes: usize,
    seed: u64,
) -> PyResult<(Vec<Rows<'py>>, Bound<'py, PyArray1<i64>>)> {
    for (name, v) in [("noise", noise), ("min_chain_length", min_chain_length)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(error(format!(
                "{name}: expected a fraction of the height >= 0, got {v}"
            )));
        }
    }
    let truth = skeleton.pose(rotations, translations)?;
    let height = height.unwrap_or_else(|| skeleton.pose_height(&truth));
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let case = make_case(
        &skeleton.skeleton,
        &truth,
        height,
        &CaseOptions {
            noise,
            min_chain_length,
            drop_limbs,
            stray_strokes,
            ..CaseOptions::default()
        },
        &mut rng,
    );
    let strokes = case
        .strokes
        .iter()
        .map(|s| {
            let points: Vec<[f64; 3]> = s.points.iter().map(|p| p.coords.into()).collect();
            to_rows(py, &points)
        })
        .collect::<PyResult<Vec<_>>>()?;
    let drawn = case
        .drawn_joints
        .iter()
        .map(|&j| skeleton.caller_index(j) as i64)
        .collect();
    Ok((strokes, to_ints(py, drawn)))
}
