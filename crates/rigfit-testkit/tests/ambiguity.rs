//! The judge of an ambiguous answer: how well a pose's own chains (those a solver matched
//! the strokes to) explain the drawn strokes, on the built-in humanoid.

use rand::SeedableRng;
use rand::rngs::StdRng;
use rigfit_core::humanoid::humanoid;
use rigfit_core::pose::sketch::{CaseOptions, make_case};
use rigfit_testkit::sweep::{own_chains_misfit, stroke_misfit};

/// The bones of a drawn chain as a solver names them (by the joint that turns each), in
/// the order along its stroke: every joint but the chain's tip.
fn bones_of(skeleton: &rigfit_core::Skeleton, chain: &[usize]) -> Vec<usize> {
    match chain {
        [] => Vec::new(),
        [first, second, ..] if skeleton.joint(*first).parent == Some(*second) => {
            chain[1..].to_vec()
        }
        _ => chain[..chain.len() - 1].to_vec(),
    }
}

#[test]
fn own_chains_judge_as_the_drawn_ones_and_a_stroke_set_aside_costs() {
    let rig = humanoid();
    let truth = rig.animations[0].sample(&rig.pose, 1.0);
    let height = rig.height();
    let mut rng = StdRng::seed_from_u64(3);
    let case = make_case(
        &rig.skeleton,
        &truth,
        height,
        &CaseOptions::default(),
        &mut rng,
    );
    let bones: Vec<Vec<usize>> = case
        .stroke_chains
        .iter()
        .map(|c| bones_of(&rig.skeleton, c))
        .collect();
    assert!(
        bones.iter().filter(|b| !b.is_empty()).count() >= 4,
        "{bones:?}"
    );
    let drawn = stroke_misfit(&rig.skeleton, &truth, &case, height);
    let own = own_chains_misfit(&rig.skeleton, &truth, &case, &bones, height);
    assert!(drawn < 0.03, "{drawn}");
    assert!((own - drawn).abs() < 1e-9, "{own} against {drawn}");
    // The longest stroke set aside: its points lie off every chain still matched.
    let longest = (0..bones.len())
        .max_by_key(|&s| case.stroke_chains[s].len())
        .expect("strokes");
    let mut aside = bones.clone();
    aside[longest].clear();
    let without = own_chains_misfit(&rig.skeleton, &truth, &case, &aside, height);
    assert!(without > drawn + 0.005, "{without} against {drawn}");
}
