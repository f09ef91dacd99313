//! Surface tracking of objects made of pieces (issue 22), on a sample of the surface corpus
//! (`data/surface_corpus.json`; the whole table is `examples/surface_corpus`): the
//! quadruped (tune half) and the humanoid (held-out half), each posed through its joints
//! by a fast motion, 30 scans of 8,000 points with 15% outliers, a part unseen in frames
//! 10-19. When the part comes back, no vertex of it is further than 5% of the diagonal from
//! the truth (the issue's bar); without contact links it is (the test can tell). Bounds on
//! the whole sequence hold today's figures (BENCHMARKS.md), not yet the issue's bar, except
//! on humanoid_CMU, which the pieces' kinematic tree brings within it.

use rigfit_core::surface::{PatchModel, PatchOptions, SurfaceOptions};
use rigfit_testkit::surface_corpus::{PartsOptions, PartsScore, load, parts_case, track_parts};

fn score(id: &str, options: &SurfaceOptions) -> PartsScore {
    let corpus = load().unwrap_or_else(|e| panic!("{e}"));
    let entry = corpus
        .entry(id)
        .unwrap_or_else(|| panic!("{id}: not in the surface corpus"));
    let parts = PartsOptions::default();
    let case = parts_case(&corpus, entry, 0, &parts).unwrap_or_else(|e| panic!("{e}"));
    assert!(case.pieces > 10, "{id}: {} pieces", case.pieces);
    track_parts(&case, options, parts.scan.hole_frames.clone()).unwrap_or_else(|e| panic!("{e}"))
}

/// Object `id`'s seed-0 sequence at the issue's pace (3 far poses), generated once, and a
/// function tracking and scoring it with the options given.
fn at_the_issues_pace(id: &str) -> impl Fn(&SurfaceOptions) -> PartsScore {
    at_the_issues_pace_from_seed(id, 0)
}

/// As [`at_the_issues_pace`], the sequence of `seed`.
fn at_the_issues_pace_from_seed(id: &str, seed: u64) -> impl Fn(&SurfaceOptions) -> PartsScore {
    let corpus = load().unwrap_or_else(|e| panic!("{e}"));
    let entry = corpus
        .entry(id)
        .unwrap_or_else(|| panic!("{id}: not in the surface corpus"));
    let parts = PartsOptions {
        far_poses: 3,
        ..PartsOptions::default()
    };
    let case = parts_case(&corpus, entry, seed, &parts).unwrap_or_else(|e| panic!("{e}"));
    move |options| {
        track_parts(&case, options, parts.scan.hole_frames.clone())
            .unwrap_or_else(|e| panic!("{e}"))
    }
}

fn unlinked() -> SurfaceOptions {
    let mut options = SurfaceOptions::default();
    options.patches.link_parts = false;
    options
}

#[test]
fn a_part_unseen_for_ten_frames_comes_back_within_five_percent() {
    for (id, mean_bound, worst_frame_bound) in [
        ("dmc-quadruped", 0.012, 0.02),
        ("dmc-humanoid", 0.04, 0.065),
    ] {
        let linked = score(id, &SurfaceOptions::default());
        let back = linked.returned_worst.expect("a part was left out");
        assert!(back < 0.05, "{id}: the unseen part comes back {back}");
        assert!(linked.mean < mean_bound, "{id}: mean {}", linked.mean);
        assert!(
            linked.worst_frame() < worst_frame_bound,
            "{id}: worst frame {}",
            linked.worst_frame()
        );
        // Nothing flies away: the worst vertex stays within half a diagonal.
        assert!(
            linked.worst_vertex() < 0.5,
            "{id}: {}",
            linked.worst_vertex()
        );
        // Without contact links the pieces drift apart and the part is lost.
        let alone = score(id, &unlinked());
        let lost = alone.returned_worst.expect("a part was left out");
        assert!(lost > 0.05, "{id}: unlinked, the part comes back {lost}");
    }
}

/// The pieces' kinematic tree (`SurfaceOptions::piece_tree`, on by default) on humanoid_CMU
/// (tune half, 49 pieces, limbs swinging up to a fifth of the diagonal between scans):
/// within the issue's bar on this sequence (0.54% mean, worst frame 0.69%, worst vertex
/// 4.5% measured in session 30, with the tree's model points by the piece; in session 19
/// 0.64%, 0.83% and 5.4%, and without the tree 1.83%, 3.57% and 18.9%: BENCHMARKS.md,
/// issue 22).
#[test]
fn the_pieces_tree_follows_a_fast_many_part_humanoid() {
    let with_tree = score("dmc-humanoid_cmu", &SurfaceOptions::default());
    assert!(with_tree.mean < 0.01, "mean {}", with_tree.mean);
    assert!(
        with_tree.worst_frame() < 0.015,
        "worst frame {}",
        with_tree.worst_frame()
    );
    assert!(
        with_tree.worst_vertex() < 0.1,
        "worst vertex {}",
        with_tree.worst_vertex()
    );
    let without = SurfaceOptions {
        piece_tree: None,
        ..SurfaceOptions::default()
    };
    let alone = score("dmc-humanoid_cmu", &without);
    assert!(
        alone.mean > with_tree.mean,
        "without the tree {}",
        alone.mean
    );
}

/// `SurfaceOptions::fast_motion` on the rodent (held-out half, 100 pieces, its feet moving
/// up to a quarter of the diagonal between scans): under 1.2% of the diagonal on average
/// (0.83% measured; the defaults 2.18%: BENCHMARKS.md, issue 22, session 14), nothing far.
#[test]
fn fast_motion_keeps_up_with_a_fast_many_part_creature() {
    let fast = score("dmc-rodent", &SurfaceOptions::fast_motion());
    assert!(fast.mean < 0.012, "mean {}", fast.mean);
    assert!(
        fast.worst_frame() < 0.03,
        "worst frame {}",
        fast.worst_frame()
    );
    assert!(
        fast.worst_vertex() < 0.5,
        "worst vertex {}",
        fast.worst_vertex()
    );
}

/// The walker (held-out half): seven capsules of one vertex count, its two legs side by
/// side, touching along their length. The contact links join the pieces whose ends meet:
/// both thighs to the torso, each shin to its thigh, each foot to its shin, never the left
/// leg to the right (pieces at one height). Hung from the nearest larger piece, by vertex
/// count and then index, the thighs hung from each other and so did the feet
/// (BENCHMARKS.md, issue 22, session 28).
#[test]
fn the_walkers_legs_are_linked_where_their_ends_meet_not_side_by_side() {
    let corpus = load().unwrap_or_else(|e| panic!("{e}"));
    let entry = corpus.entry("dmc-walker").expect("the walker");
    let up = corpus.read_rig(entry).unwrap_or_else(|e| panic!("{e}")).up;
    let case =
        parts_case(&corpus, entry, 0, &PartsOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(case.pieces, 7);
    let model = PatchModel::new(&case.sequence.reference, &PatchOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    // Each piece's mean height along the walker's up axis.
    let mut height = [(0.0, 0usize); 7];
    for (v, &k) in model.vertex_patch.iter().enumerate() {
        let piece = model.component[k as usize] as usize;
        height[piece].0 += model.rest[v].coords.dot(&up);
        height[piece].1 += 1;
    }
    let height = height.map(|(sum, n)| sum / n as f64);
    let mut pairs: Vec<(usize, usize)> = model
        .contacts
        .iter()
        .map(|link| {
            let (a, b) = (
                model.component[link.k as usize],
                model.component[link.l as usize],
            );
            (a.min(b) as usize, a.max(b) as usize)
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    assert_eq!(pairs.len(), 6, "a tree over the seven pieces: {pairs:?}");
    for (a, b) in pairs {
        let apart = (height[a] - height[b]).abs();
        assert!(
            apart > 0.05 * model.diagonal,
            "pieces {a} and {b} side by side ({apart} apart in height)"
        );
    }
}

/// At the issue's pace (3 far poses: limbs turning up to about 25 degrees a frame), Fetch's
/// gripper (tuning half), unseen in frames 10-19 while it moves, is found again when it
/// comes back: every vertex of it within 5% of the diagonal (1.7% measured; 34% when its
/// pieces hung from the nearest larger piece, which chained the arm's links out of order).
#[test]
fn fetchs_gripper_is_found_again_when_it_comes_back_at_the_issues_pace() {
    let track = at_the_issues_pace("gymr-fetch");
    let score = track(&SurfaceOptions::default());
    let back = score.returned_worst.expect("a part was left out");
    assert!(back < 0.05, "the gripper comes back {back}");
    assert!(score.mean < 0.015, "mean {}", score.mean);
}

/// At the issue's pace, the cheetah's back foot (tuning half, 8 pieces), unseen in frames
/// 10-19 while its joints move on, comes back up to a quarter of the diagonal from where it
/// was left. Looking for returning parts (on by default) turns it about its joint onto the
/// data that comes back. Over the eight seeds, the foot is found (every vertex of it within
/// 5% of the diagonal) and the sequence is within the issue's bar on what the scans show
/// (the foot judged from the frame it is seen again) in 4 seeds with the search, in 1
/// without (seeds 3, 5, 6 and 7 against seed 3; the bounds leave one seed of margin). One
/// seed alone is luck: the draw of the tree's model points decides some of them
/// (BENCHMARKS.md, issue 22, sessions 33-35).
#[test]
fn the_cheetahs_foot_is_found_again_when_it_comes_back_into_view() {
    let options_looking = |find_returning_parts: bool| {
        let mut options = SurfaceOptions::default();
        if let Some(tree) = options.piece_tree.as_mut() {
            tree.find_returning_parts = find_returning_parts;
        }
        options
    };
    let (looking, not_looking) = (options_looking(true), options_looking(false));
    let found = |score: PartsScore| {
        let back = score.returned_worst.expect("a part was left out");
        back < 0.05 && score.seen.passes()
    };
    let (mut with, mut without) = (Vec::new(), Vec::new());
    for seed in 0..8 {
        // Each seed's sequence, generated once, tracked with the search and without.
        let track = at_the_issues_pace_from_seed("dmc-cheetah", seed);
        if found(track(&looking)) {
            with.push(seed);
        }
        if found(track(&not_looking)) {
            without.push(seed);
        }
    }
    assert!(with.len() >= 3, "found in seeds {with:?}");
    assert!(
        without.len() <= 1,
        "not looked for, found in seeds {without:?}"
    );
}
