//! rigfit-core: the math, skeletons, kinematics, skinning and solvers of rigfit.
//!
//! No file I/O lives here: readers and writers are in `rigfit-formats`, the command line in
//! `rigfit-cli`. Data flows one way: file -> model ([`rig::Rig`], [`geometry::TriMesh`],
//! [`strokes::Stroke`]) -> solver -> result -> file.

pub mod animation;
pub mod engine;
pub mod geometry;
pub mod hierarchy;
pub mod humanoid;
pub mod interrupt;
pub mod joint_model;
pub mod kinematics;
pub mod math;
pub mod mirror;
pub mod pose;
pub mod rig;
pub mod skeleton;
pub mod skinning;
pub mod strokes;
pub mod surface;
pub mod track;

pub use animation::{Animation, AnimationChannel, ChannelTarget, Interpolation};
pub use geometry::{Aabb, TriMesh};
pub use interrupt::Interrupt;
pub use kinematics::{DofLayout, ForwardKinematics};
pub use math::{Matrix3, Matrix4, Point3, Quat, Real, Trs, Vector3};
pub use rig::Rig;
pub use skeleton::{
    Joint, JointDof, JointKind, JointLimits, JointTie, Pose, Skeleton, SkeletonError,
};
pub use skinning::SkinnedMesh;
pub use strokes::Stroke;
