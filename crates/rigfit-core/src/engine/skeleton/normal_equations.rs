//! The normal equations of one skeleton layout, in the cheapest form that holds them
//! exactly: [`ArticulatedNormalEquations`] (O(joints)) when every rotating frame is
//! conformal, else [`TreeNormalEquations`] (no fill-in), else the dense
//! [`NormalEquations`] with its Cholesky factorisation.

use nalgebra::DMatrix;

use crate::engine::linear_algebra::{NormalEquations, NormalSink};
use crate::engine::skeleton::articulated::ArticulatedNormalEquations;
use crate::engine::skeleton::subtree_moments::SubtreeMoments;
use crate::engine::skeleton::tree_solver::TreeNormalEquations;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix3, Vector3};

/// `J^T W J`, `J^T W r` and the cost of a skeleton's parameters under one [`DofLayout`].
#[derive(Clone, Debug)]
pub struct SkeletonNormalEquations {
    layout: DofLayout,
    parents: Vec<Option<usize>>,
    /// Made when first needed.
    explicit: Option<Explicit>,
    articulated: ArticulatedNormalEquations,
    allow_articulated: bool,
    /// Whether the tree form may hold the entries (terms that join two branches, such as
    /// a tie between a hand and its IK goal, need the dense form).
    allow_tree: bool,
    use_articulated: bool,
}

/// `J^T W J` stored entry by entry.
#[derive(Clone, Debug)]
enum Explicit {
    Tree(TreeNormalEquations),
    Dense(NormalEquations, Vec<f64>),
}

impl SkeletonNormalEquations {
    /// Normal equations for `layout` on the joint tree given by `parent`.
    pub fn new(layout: &DofLayout, parent: impl Fn(usize) -> Option<usize>) -> Self {
        Self {
            layout: layout.clone(),
            parents: (0..layout.joint_count()).map(parent).collect(),
            explicit: None,
            articulated: ArticulatedNormalEquations::new(),
            allow_articulated: true,
            allow_tree: true,
            use_articulated: false,
        }
    }

    /// Makes these equations over for `layout` on the joint tree given by `parent`
    /// (keeping their storage).
    pub fn set_layout(&mut self, layout: &DofLayout, parent: impl Fn(usize) -> Option<usize>) {
        self.layout.clone_from(layout);
        self.parents.clear();
        self.parents.extend((0..layout.joint_count()).map(parent));
        self.explicit = None;
        self.use_articulated = false;
    }

    /// Whether these equations were made for `layout`.
    pub fn is_for(&self, layout: &DofLayout) -> bool {
        self.layout == *layout
    }

    /// Whether entries are stored by the tree (else densely) when not articulated.
    pub fn is_tree(&mut self) -> bool {
        matches!(self.explicit(), Explicit::Tree(_))
    }

    /// The entry-by-entry form, made (cleared) when first needed.
    fn explicit(&mut self) -> &mut Explicit {
        let (layout, parents) = (&self.layout, &self.parents);
        let allow_tree = self.allow_tree;
        self.explicit.get_or_insert_with(|| {
            match allow_tree
                .then(|| TreeNormalEquations::new(layout, |j| parents[j]))
                .flatten()
            {
                Some(tree) => Explicit::Tree(tree),
                None => Explicit::Dense(NormalEquations::new(layout.len()), Vec::new()),
            }
        })
    }

    /// Whether the last [`Self::assemble_points`] went to the articulated form.
    pub fn is_articulated(&self) -> bool {
        self.use_articulated
    }

    /// Allows or forbids the articulated form (allowed by default).
    pub fn set_allow_articulated(&mut self, allow: bool) {
        self.allow_articulated = allow;
    }

    /// Allows or forbids the tree form (allowed by default); forbidden, the entries are
    /// stored densely, so that any two parameters may be coupled.
    pub fn set_allow_tree(&mut self, allow: bool) {
        if self.allow_tree != allow {
            self.allow_tree = allow;
            self.explicit = None;
        }
    }

    /// Clears the sums for a new iteration.
    pub fn clear(&mut self) {
        self.use_articulated = false;
        match &mut self.explicit {
            Some(Explicit::Tree(t)) => t.clear(),
            Some(Explicit::Dense(d, _)) => d.clear(),
            None => {}
        }
    }

    /// Adds the points summed in `moments` at `fk` (Jacobian columns scaled by
    /// `column_scale`), choosing the form: the first thing added after [`Self::clear`].
    pub fn assemble_points(
        &mut self,
        moments: &mut SubtreeMoments,
        fk: &ForwardKinematics,
        column_scale: f64,
    ) {
        self.use_articulated = self.allow_articulated
            && moments.assemble_articulated(fk, &self.layout, column_scale, &mut self.articulated);
        if !self.use_articulated {
            self.explicit();
            match &mut self.explicit {
                Some(Explicit::Tree(t)) => moments.assemble(fk, &self.layout, column_scale, t),
                Some(Explicit::Dense(d, _)) => moments.assemble(fk, &self.layout, column_scale, d),
                None => unreachable!("made above"),
            }
        }
    }

    /// `J^T W J` as a full symmetric matrix.
    pub fn jtj(&self) -> DMatrix<f64> {
        let n = self.layout.len();
        match &self.explicit {
            _ if self.use_articulated => self.articulated.jtj(),
            Some(Explicit::Tree(t)) => t.jtj(),
            Some(Explicit::Dense(d, _)) => d.jtj(),
            None => DMatrix::zeros(n, n),
        }
    }

    /// `J^T W r`.
    pub fn jtr(&self) -> Vec<f64> {
        match &self.explicit {
            _ if self.use_articulated => self.articulated.jtr().to_vec(),
            Some(Explicit::Tree(t)) => t.jtr().to_vec(),
            Some(Explicit::Dense(d, _)) => d.jtr.as_slice().to_vec(),
            None => vec![0.0; self.layout.len()],
        }
    }

    /// The Levenberg-Marquardt step (see [`NormalEquations::solve`]).
    pub fn solve(&mut self, lambda: f64) -> Option<&[f64]> {
        if self.use_articulated {
            return self.articulated.solve(lambda);
        }
        match self.explicit() {
            Explicit::Tree(t) => t.solve(lambda),
            Explicit::Dense(d, step) => {
                let s = d.solve(lambda)?;
                step.clear();
                step.extend(s.iter());
                Some(step)
            }
        }
    }

    /// The sink terms go to.
    fn sink(&mut self) -> &mut dyn NormalSink {
        if self.use_articulated {
            return &mut self.articulated;
        }
        match self.explicit() {
            Explicit::Tree(t) => t,
            Explicit::Dense(d, _) => d,
        }
    }
}

impl NormalSink for SkeletonNormalEquations {
    /// In the articulated form, only diagonal entries.
    fn add_jtj(&mut self, i: usize, j: usize, v: f64) {
        self.sink().add_jtj(i, j, v);
    }

    fn add_jtr(&mut self, i: usize, v: f64) {
        self.sink().add_jtr(i, v);
    }

    fn add_cost(&mut self, c: f64) {
        self.sink().add_cost(c);
    }

    fn cost(&self) -> f64 {
        match &self.explicit {
            _ if self.use_articulated => self.articulated.cost(),
            Some(Explicit::Tree(t)) => t.cost(),
            Some(Explicit::Dense(d, _)) => d.cost,
            None => 0.0,
        }
    }

    fn add_scalar(&mut self, r: f64, w: f64, col: usize, d: f64) {
        self.sink().add_scalar(r, w, col, d);
    }

    /// Dispatches once per point, not once per entry.
    fn add_point_columns(&mut self, r: &Vector3, w: f64, cols: &[(usize, Vector3)]) {
        self.sink().add_point_columns(r, w, cols);
    }

    fn add_jtj_block(
        &mut self,
        a: (usize, usize),
        b: (usize, usize),
        m: &Matrix3,
        scale: f64,
        diagonal: bool,
    ) {
        self.sink().add_jtj_block(a, b, m, scale, diagonal);
    }
}
