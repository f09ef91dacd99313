//! The bounds of the surface options a user sets (the `rigfit surface` flags, the Python
//! `SurfaceTracker`'s keyword arguments): checked in one place, so that every front end
//! refuses the same values with the same words.

use super::SurfaceOptions;

/// The most EM iterations per frame a user may ask for.
pub const MAX_ITERATIONS: usize = 1000;
/// The coarsest stride of a frame's first iterations a user may ask for.
pub const MAX_COARSE: usize = 1024;
/// The smallest and largest patch radius, as fractions of the reference's diagonal.
pub const MIN_PATCH_RADIUS: f64 = 1e-4;
pub const MAX_PATCH_RADIUS: f64 = 10.0;

/// A surface option a user sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceOption {
    PatchRadius,
    Outliers,
    Rigidity,
    Iterations,
    Merge,
    Coarse,
    PointsPerVertex,
}

impl SurfaceOption {
    /// The command line's flag, without its dashes: `patch-radius`.
    pub fn flag(self) -> &'static str {
        match self {
            Self::PatchRadius => "patch-radius",
            Self::Outliers => "outliers",
            Self::Rigidity => "rigidity",
            Self::Iterations => "iterations",
            Self::Merge => "merge",
            Self::Coarse => "coarse",
            Self::PointsPerVertex => "points-per-vertex",
        }
    }

    /// The name as a keyword argument: `patch_radius`.
    pub fn keyword(self) -> &'static str {
        match self {
            Self::PatchRadius => "patch_radius",
            Self::PointsPerVertex => "points_per_vertex",
            other => other.flag(),
        }
    }
}

/// An option out of its bounds: which one, and what is expected of it (the front end names
/// the option in its own spelling).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{problem}")]
pub struct OptionError {
    pub option: SurfaceOption,
    pub problem: String,
}

impl SurfaceOptions {
    /// Checks the options a user sets ([`SurfaceOption`]) against their bounds, in the order
    /// of the list: EM iterations per frame from 1 to [`MAX_ITERATIONS`], a coarse stride
    /// from 1 to [`MAX_COARSE`], a patch radius from [`MIN_PATCH_RADIUS`] to
    /// [`MAX_PATCH_RADIUS`], an outlier ratio in [0, 1), a merge cell and a rigidity that are
    /// finite and not negative.
    pub fn check(&self) -> Result<(), OptionError> {
        let fail = |option, problem: String| Err(OptionError { option, problem });
        if !(1..=MAX_ITERATIONS).contains(&self.max_iterations) {
            return fail(
                SurfaceOption::Iterations,
                format!(
                    "expected 1 to {MAX_ITERATIONS} EM iterations per frame, got {}",
                    self.max_iterations
                ),
            );
        }
        if !(1..=MAX_COARSE).contains(&self.coarse_stride) {
            return fail(
                SurfaceOption::Coarse,
                format!(
                    "expected a stride from 1 to {MAX_COARSE}, got {}",
                    self.coarse_stride
                ),
            );
        }
        if !(MIN_PATCH_RADIUS..=MAX_PATCH_RADIUS).contains(&self.patches.radius) {
            return fail(
                SurfaceOption::PatchRadius,
                format!(
                    "expected a fraction of the diagonal from {MIN_PATCH_RADIUS} to {MAX_PATCH_RADIUS}, got {}",
                    self.patches.radius
                ),
            );
        }
        if !(0.0..1.0).contains(&self.data.outlier_ratio) {
            return fail(
                SurfaceOption::Outliers,
                "expected a fraction in [0, 1)".into(),
            );
        }
        if !(self.merge_cell >= 0.0 && self.merge_cell.is_finite()) {
            return fail(
                SurfaceOption::Merge,
                "expected a non-negative number of point spacings".into(),
            );
        }
        if !(self.points_per_vertex >= 0.0 && self.points_per_vertex.is_finite()) {
            return fail(
                SurfaceOption::PointsPerVertex,
                "expected a non-negative number of points a vertex (0: every point)".into(),
            );
        }
        if !(self.rigidity >= 0.0 && self.rigidity.is_finite()) {
            return fail(
                SurfaceOption::Rigidity,
                "expected a non-negative number".into(),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A change to the defaults, the option it breaks and words of the error.
    type Case = (fn(&mut SurfaceOptions), SurfaceOption, &'static str);

    #[test]
    fn the_defaults_pass_and_each_bound_names_its_option() {
        assert_eq!(SurfaceOptions::default().check(), Ok(()));
        assert_eq!(SurfaceOptions::paper().check(), Ok(()));
        let cases: Vec<Case> = vec![
            (
                |o| o.max_iterations = 0,
                SurfaceOption::Iterations,
                "expected 1 to 1000 EM iterations per frame, got 0",
            ),
            (
                |o| o.max_iterations = 1001,
                SurfaceOption::Iterations,
                "got 1001",
            ),
            (
                |o| o.coarse_stride = 0,
                SurfaceOption::Coarse,
                "expected a stride from 1 to 1024, got 0",
            ),
            (
                |o| o.patches.radius = 1e-5,
                SurfaceOption::PatchRadius,
                "expected a fraction of the diagonal from 0.0001 to 10, got 0.00001",
            ),
            (
                |o| o.patches.radius = f64::NAN,
                SurfaceOption::PatchRadius,
                "got NaN",
            ),
            (
                |o| o.data.outlier_ratio = 1.0,
                SurfaceOption::Outliers,
                "expected a fraction in [0, 1)",
            ),
            (
                |o| o.merge_cell = f64::INFINITY,
                SurfaceOption::Merge,
                "point spacings",
            ),
            (
                |o| o.rigidity = -1.0,
                SurfaceOption::Rigidity,
                "expected a non-negative number",
            ),
        ];
        for (set, option, needle) in cases {
            let mut o = SurfaceOptions::default();
            set(&mut o);
            let e = o.check().expect_err(needle);
            assert_eq!(e.option, option);
            assert!(e.problem.contains(needle), "{} / {needle}", e.problem);
        }
        assert_eq!(SurfaceOption::PatchRadius.flag(), "patch-radius");
        assert_eq!(SurfaceOption::PatchRadius.keyword(), "patch_radius");
    }
}
