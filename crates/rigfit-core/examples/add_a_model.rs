//! Adding a model to the engine, worked through (ARCHITECTURE.md, "How do I add a model").
//!
//! The model: one rigid body (a rotation and a translation) carrying a set of points, fitted
//! to a cloud with 20% clutter. Its E-step is the engine's EM with the uniform outlier class
//! (Dewaele eq. 17); its M-step is one Gauss-Newton step on the engine's dense normal
//! equations, each model point pulled to the weighted mean of its data (eq. 20); the
//! engine's fitting loop anneals `sigma` geometrically and stops when the body stops moving.
//!
//! `cargo run --release -p rigfit-core --example add_a_model`

use rigfit_core::engine::fitting_loop::{
    EmModel, Expectation, Maximisation, Schedule, Stage, Widths, run_em,
};
use rigfit_core::engine::{
    DEWAELE_OUTLIER_CONSTANT, EmStep, NormalEquations, PointGrid, WeightedPoints, em_step,
};
use rigfit_core::math::{Point3, Quat, Vector3};

/// The model: its points in its own frame, where it is, and the engine's buffers.
struct RigidBody<'d> {
    body: Vec<Point3>,
    rotation: Quat,
    translation: Vector3,
    data: &'d [Point3],
    em: EmStep,
    grid: PointGrid,
}

impl RigidBody<'_> {
    fn world(&self) -> Vec<Point3> {
        self.body
            .iter()
            .map(|p| self.rotation * p + self.translation)
            .collect()
    }
}

impl EmModel for RigidBody<'_> {
    type Error = std::convert::Infallible;

    // The E-step: posteriors of every datum over the model points and the outlier class.
    fn e_step(&mut self, stage: &Stage) -> Result<Expectation, Self::Error> {
        let world = self.world();
        em_step(
            WeightedPoints::unit(self.data),
            WeightedPoints::unit(&world),
            stage.sigma,
            DEWAELE_OUTLIER_CONSTANT,
            &mut self.grid,
            &mut self.em,
        );
        Ok(Expectation::Ready)
    }

    // The M-step: one Gauss-Newton step; parameters 0..3 turn the body about the world axes
    // (R <- exp([w]x) R), 3..6 move it.
    fn m_step(&mut self, _stage: &Stage) -> Result<Maximisation, Self::Error> {
        let mut normal = NormalEquations::new(6);
        for (k, x) in self.world().iter().enumerate() {
            let weight = self.em.lambda[k];
            if weight <= 1e-9 {
                continue;
            }
            let arm = x.coords - self.translation;
            let residual = x - self.em.target[k];
            let columns: Vec<(usize, Vector3)> = (0..3)
                .map(|a| (a, Vector3::ith(a, 1.0).cross(&arm)))
                .chain((0..3).map(|a| (3 + a, Vector3::ith(a, 1.0))))
                .collect();
            normal.add_point(&residual, weight, &columns);
        }
        let Some(step) = normal.solve(1e-6) else {
            return Ok(Maximisation::moved(0.0));
        };
        let turn = Vector3::new(step[0], step[1], step[2]);
        let shift = Vector3::new(step[3], step[4], step[5]);
        // The turn is about the body's position, then the body moves.
        let pivot = self.translation;
        self.rotation = Quat::from_scaled_axis(turn) * self.rotation;
        self.translation = pivot + shift;
        Ok(Maximisation::moved(shift.norm() + turn.norm()))
    }
}

fn main() {
    // A unit sphere's points, and the cloud: the sphere turned and moved, plus clutter.
    let body: Vec<Point3> = (0..400)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 400.0;
            let a = i as f64 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            Point3::new(r * a.cos(), z * 0.6, r * a.sin() * 0.3)
        })
        .collect();
    let truth = (
        Quat::from_axis_angle(&Vector3::z_axis(), 0.3),
        Vector3::new(0.2, -0.1, 0.15),
    );
    let mut data: Vec<Point3> = body.iter().map(|p| truth.0 * p + truth.1).collect();
    data.extend((0..80).map(|i| {
        let t = i as f64;
        Point3::new(
            (t * 0.37).sin() * 2.0,
            (t * 0.71).cos() * 2.0,
            (t * 0.13).sin(),
        )
    }));
    let mut model = RigidBody {
        body,
        rotation: Quat::identity(),
        translation: Vector3::zeros(),
        data: &data,
        em: EmStep::default(),
        grid: PointGrid::default(),
    };
    // Geometric annealing from 0.5 to 0.02 in four steps, three EM iterations per width, and
    // up to twenty at the last until the body moves less than 1e-6.
    let schedule = Schedule {
        widths: Widths::Geometric {
            start: 0.5,
            ratio: (0.02f64 / 0.5).powf(0.25),
            steps: 4,
        },
        rounds: 3,
        final_rounds: 20,
        tolerance: Some(1e-6),
    };
    let Ok(report) = run_em(&mut model, &schedule);
    let turn_error = (truth.0.inverse() * model.rotation).angle();
    let move_error = (model.translation - truth.1).norm();
    println!(
        "{} EM iterations ({:?}); turn off by {turn_error:.2e} rad, position by {move_error:.2e}",
        report.iterations, report.ending
    );
    assert!(turn_error < 1e-2 && move_error < 1e-2);
}
