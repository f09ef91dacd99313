//! The rigs' own symmetries found from their geometry (`rigfit_testkit::symmetry`): the box
//! character's half turn about the vertical and the quadruped's about its up axis (four
//! like legs), and none for an ordinary human. Read as `track_corpus::corpus_sequence` reads
//! them (the manifest's start pose, the corpus's height). Skipped, with a message, when
//! `RIGFIT_CORPUS` is unset or the corpus's files are missing.

use rigfit_testkit::Corpus;
use rigfit_testkit::symmetry::rig_symmetries;

/// The corpus, or `None` (with why) when it is not there.
fn corpus() -> Option<Corpus> {
    if std::env::var_os(rigfit_testkit::corpus::CORPUS_ENV).is_none() {
        eprintln!("skipped: RIGFIT_CORPUS is not set");
        return None;
    }
    match Corpus::load() {
        Ok(corpus) => Some(corpus),
        Err(e) => {
            eprintln!("skipped: {e}");
            None
        }
    }
}

/// The symmetries of corpus rig `id` at its start pose.
fn symmetries(corpus: &Corpus, id: &str) -> Vec<Vec<usize>> {
    let entry = corpus
        .entry(id)
        .unwrap_or_else(|| panic!("{id} is not in the corpus"));
    let read = corpus
        .read_rig(entry)
        .unwrap_or_else(|e| panic!("{id}: {e}"));
    let mut rig = read.rig.clone();
    rig.pose = read.start.clone();
    let found = rig_symmetries(&rig, &rig.pose, read.height);
    let identity: Vec<usize> = (0..rig.skeleton.len()).collect();
    assert_eq!(found.first(), Some(&identity), "{id}: the identity first");
    for p in &found[1..] {
        let swapped: Vec<String> = (0..p.len())
            .filter(|&i| p[i] != i && rig.reported_joints().any(|j| j == i))
            .map(|i| {
                let name = |j: usize| rig.skeleton.joint(j).name.as_str();
                format!("{}->{}", name(i), name(p[i]))
            })
            .collect();
        eprintln!("{id}: {}", swapped.join(" "));
    }
    found
}

#[test]
fn symmetric_bodies_have_a_twin_and_an_asymmetric_human_does_not() {
    let Some(corpus) = corpus() else {
        return;
    };
    for id in ["minetest-character", "dmc-quadruped"] {
        let found = symmetries(&corpus, id);
        assert!(found.len() > 1, "{id}: no symmetry besides the identity");
    }
    let found = symmetries(&corpus, "assimp-bcn_epileptic");
    assert_eq!(
        found.len(),
        1,
        "assimp-bcn_epileptic: {} symmetries",
        found.len()
    );
}
