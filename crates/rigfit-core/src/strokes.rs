//! A stroke drawn by the user: an ordered 3D polyline, optionally pinned to bones.

use crate::math::Point3;

/// One stroke of the strokes file (see `interfaces.md`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stroke {
    pub points: Vec<Point3>,
    /// When set, the stroke may only be matched to these bones (joint names).
    pub bones: Option<Vec<String>>,
}

impl Stroke {
    /// The length of the polyline.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }
}
