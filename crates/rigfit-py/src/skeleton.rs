//! `rigfit.Skeleton`: a joint tree in the caller's joint order, and the conversion of poses
//! (local rotations and translations per joint) between numpy arrays and core `Pose`s.

use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use rigfit_core::animation::{quat_from_xyzw, quat_to_xyzw};
use rigfit_core::{Joint, JointKind, Pose, Skeleton, Trs, Vector3};

use crate::arrays::{rows, to_ints, to_matrices, to_rows};
use crate::error;

/// A joint tree: names, parents and rest (bind) transforms relative to the parent.
///
/// Joints keep the order they were given in (a parent may come after its child); every
/// array in and out of rigfit uses that order. Quaternions are ``[x, y, z, w]``.
#[pyclass(module = "rigfit", name = "Skeleton", frozen)]
#[derive(Debug, Clone)]
pub struct PySkeleton {
    pub skeleton: Skeleton,
    /// For each joint in the caller's order, its index in `skeleton` (parents first).
    pub order: Vec<usize>,
}

impl PySkeleton {
    /// A skeleton whose own order is the caller's.
    pub fn from_core(skeleton: Skeleton) -> Self {
        let order = (0..skeleton.len()).collect();
        Self { skeleton, order }
    }

    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Core order -> caller's order.
    pub fn in_caller_order<T: Clone>(&self, values: &[T]) -> Vec<T> {
        self.order.iter().map(|&k| values[k].clone()).collect()
    }

    /// A pose from optional local rotations `(n, 4)` and translations `(n, 3)` in the caller's
    /// order; missing ones are the rest transform's.
    pub fn pose(
        &self,
        rotations: Option<&Bound<'_, PyAny>>,
        translations: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Pose> {
        self.pose_from(self.skeleton.rest_pose(), rotations, translations)
    }

    /// `start` with the local rotations `(n, 4)` and translations `(n, 3)` given (caller's
    /// order) put in.
    pub fn pose_from(
        &self,
        start: Pose,
        rotations: Option<&Bound<'_, PyAny>>,
        translations: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Pose> {
        let n = self.len();
        let r = rotations
            .map(|r| rows::<4>(r, "rotations", Some(n)))
            .transpose()?;
        let t = translations
            .map(|t| rows::<3>(t, "translations", Some(n)))
            .transpose()?;
        self.set_pose(start, r.as_deref(), t.as_deref(), "rotations")
    }

    /// `pose` with rows (caller's order, already shape-checked) put in; `label` names the
    /// rotations in the error of a zero quaternion.
    pub fn set_pose(
        &self,
        mut pose: Pose,
        rotations: Option<&[[f64; 4]]>,
        translations: Option<&[[f64; 3]]>,
        label: &str,
    ) -> PyResult<Pose> {
        if let Some(r) = rotations {
            for (i, q) in r.iter().enumerate() {
                if q.iter().map(|v| v * v).sum::<f64>() < 1e-12 {
                    return Err(error(format!("{label}[{i}]: a zero quaternion")));
                }
                pose.local[self.order[i]].rotation = quat_from_xyzw(*q);
            }
        }
        if let Some(t) = translations {
            for (i, v) in t.iter().enumerate() {
                pose.local[self.order[i]].translation = Vector3::from(*v);
            }
        }
        Ok(pose)
    }

    /// Local rotations `(n, 4)` of a pose in the caller's order.
    pub fn rotations(&self, pose: &Pose) -> Vec<[f64; 4]> {
        self.order
            .iter()
            .map(|&k| quat_to_xyzw(&pose.local[k].rotation))
            .collect()
    }

    /// Local translations `(n, 3)` of a pose in the caller's order.
    pub fn translations(&self, pose: &Pose) -> Vec<[f64; 3]> {
        self.order
            .iter()
            .map(|&k| pose.local[k].translation.into())
            .collect()
    }

    /// World positions `(n, 3)` of a pose in the caller's order.
    pub fn positions(&self, pose: &Pose) -> Vec<[f64; 3]> {
        let p = self.skeleton.joint_positions(pose);
        self.order.iter().map(|&k| p[k].coords.into()).collect()
    }

    /// The character's height in `pose`: the vertical (y) extent of its joints, or the largest
    /// extent if that is degenerate.
    pub fn pose_height(&self, pose: &Pose) -> f64 {
        let p = self.skeleton.joint_positions(pose);
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (point, joint) in p.iter().zip(self.skeleton.joints()) {
            if joint.kind == JointKind::Helper {
                continue;
            }
            for a in 0..3 {
                lo[a] = lo[a].min(point[a]);
                hi[a] = hi[a].max(point[a]);
            }
        }
        let e = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
        if !e[1].is_finite() {
            return 1.0;
        }
        if e[1] > 1e-9 {
            e[1]
        } else {
            e.iter().copied().fold(0.0, f64::max).max(1e-9)
        }
    }

    /// Index (caller's order) of a joint in core order.
    pub fn caller_index(&self, core: usize) -> usize {
        self.order.iter().position(|&k| k == core).unwrap_or(core)
    }
}

#[pymethods]
impl PySkeleton {
    /// Builds a skeleton.
    ///
    /// ``parents[i]`` is the index of joint i's parent, or -1 (or None) for a root.
    /// ``rest_translations`` (n, 3), ``rest_rotations`` (n, 4, ``[x, y, z, w]``) and
    /// ``rest_scales`` (n, 3, default ones) are each joint's rest transform relative to its
    /// parent. ``end_sites[i]`` marks a joint as a fixed tip (the end of a bone with no joint
    /// below it, e.g. a Blender bone's tail); ``helpers[i]`` marks a node that carries a
    /// transform but is not part of the character (kept fixed, not measured).
    #[new]
    #[pyo3(signature = (names, parents, rest_translations, rest_rotations, rest_scales=None, end_sites=None, helpers=None))]
    fn new(
        names: Vec<String>,
        parents: Vec<Option<i64>>,
        rest_translations: &Bound<'_, PyAny>,
        rest_rotations: &Bound<'_, PyAny>,
        rest_scales: Option<&Bound<'_, PyAny>>,
        end_sites: Option<Vec<bool>>,
        helpers: Option<Vec<bool>>,
    ) -> PyResult<Self> {
        let n = names.len();
        if n == 0 {
            return Err(error("names: the skeleton has no joints"));
        }
        if parents.len() != n {
            return Err(error(format!(
                "parents: expected {n} entries (one per name), got {}",
                parents.len()
            )));
        }
        let t = rows::<3>(rest_translations, "rest_translations", Some(n))?;
        let r = rows::<4>(rest_rotations, "rest_rotations", Some(n))?;
        let s = match rest_scales {
            Some(s) => rows::<3>(s, "rest_scales", Some(n))?,
            None => vec![[1.0; 3]; n],
        };
        for (label, flags) in [("end_sites", &end_sites), ("helpers", &helpers)] {
            if let Some(f) = flags
                && f.len() != n
            {
                return Err(error(format!(
                    "{label}: expected {n} entries (one per name), got {}",
                    f.len()
                )));
            }
        }
        let mut joints = Vec::with_capacity(n);
        for i in 0..n {
            let parent = match parents[i] {
                None => None,
                Some(p) if p < 0 => None,
                Some(p) if (p as usize) < n && p as usize != i => Some(p as usize),
                Some(p) => {
                    return Err(error(format!(
                        "parents[{i}]: {p} is not the index of another joint (0..{n}) or -1"
                    )));
                }
            };
            if r[i].iter().map(|v| v * v).sum::<f64>() < 1e-12 {
                return Err(error(format!("rest_rotations[{i}]: a zero quaternion")));
            }
            let mut joint = Joint::new(
                names[i].clone(),
                parent,
                Trs {
                    translation: Vector3::from(t[i]),
                    rotation: quat_from_xyzw(r[i]),
                    scale: Vector3::from(s[i]),
                },
            );
            if end_sites.as_ref().is_some_and(|f| f[i]) {
                joint.kind = JointKind::EndSite;
            } else if helpers.as_ref().is_some_and(|f| f[i]) {
                joint.kind = JointKind::Helper;
            }
            joints.push(joint);
        }
        let (mut skeleton, order) = Skeleton::from_unordered(joints)
            .map_err(|e| error(format!("skeleton: {e} (are the parents a tree?)")))?;
        skeleton.set_default_dofs();
        Ok(Self { skeleton, order })
    }

    fn __len__(&self) -> usize {
        self.len()
    }

    fn __repr__(&self) -> String {
        format!("rigfit.Skeleton({} joints)", self.len())
    }

    /// Joint names, in the caller's order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.order
            .iter()
            .map(|&k| self.skeleton.joint(k).name.clone())
            .collect()
    }

    /// Parent index of each joint (caller's order), -1 for a root.
    #[getter]
    fn parents<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let parents = self
            .order
            .iter()
            .map(|&k| match self.skeleton.joint(k).parent {
                Some(p) => self.caller_index(p) as i64,
                None => -1,
            })
            .collect();
        to_ints(py, parents)
    }

    /// Per joint, whether it is a fixed tip (a BVH End Site, a bone's tail).
    #[getter]
    fn end_sites(&self) -> Vec<bool> {
        self.order
            .iter()
            .map(|&k| self.skeleton.joint(k).kind.is_tip())
            .collect()
    }

    /// Per joint, whether it is a helper node above or beside the character (not posed).
    #[getter]
    fn helpers(&self) -> Vec<bool> {
        self.order
            .iter()
            .map(|&k| self.skeleton.joint(k).kind == JointKind::Helper)
            .collect()
    }

    /// Rest rotations (n, 4) ``[x, y, z, w]``, relative to the parent.
    #[getter]
    fn rest_rotations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &self.rotations(&self.skeleton.rest_pose()))
    }

    /// Rest translations (n, 3), relative to the parent.
    #[getter]
    fn rest_translations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        to_rows(py, &self.translations(&self.skeleton.rest_pose()))
    }

    /// Index of the joint called ``name``.
    fn index(&self, name: &str) -> PyResult<usize> {
        self.skeleton
            .find(name)
            .map(|k| self.caller_index(k))
            .ok_or_else(|| error(format!("unknown joint '{name}'")))
    }

    /// World positions (n, 3) of every joint for local ``rotations`` (n, 4) and
    /// ``translations`` (n, 3) (each defaults to the rest pose's).
    #[pyo3(signature = (rotations=None, translations=None))]
    fn joint_positions<'py>(
        &self,
        py: Python<'py>,
        rotations: Option<&Bound<'py, PyAny>>,
        translations: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pose = self.pose(rotations, translations)?;
        to_rows(py, &self.positions(&pose))
    }

    /// World matrices (n, 4, 4) of every joint for a pose (see ``joint_positions``).
    #[pyo3(signature = (rotations=None, translations=None))]
    fn world_matrices<'py>(
        &self,
        py: Python<'py>,
        rotations: Option<&Bound<'py, PyAny>>,
        translations: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let pose = self.pose(rotations, translations)?;
        let world = self.skeleton.world_matrices(&pose);
        to_matrices(py, &self.in_caller_order(&world))
    }

    /// The character's height for a pose: the y extent of its joints (the largest extent
    /// when that is zero). Solver lengths are fractions of it.
    #[pyo3(signature = (rotations=None, translations=None))]
    fn height(
        &self,
        rotations: Option<&Bound<'_, PyAny>>,
        translations: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<f64> {
        let pose = self.pose(rotations, translations)?;
        Ok(self.pose_height(&pose))
    }
}
