//! BVH reader, then the skeleton and the rig (pose of frame 0, the motion as an animation)
//! of whatever it accepts.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(doc) = rigfit_formats::bvh::parse_bvh(data) {
        // The parser promises a valid tree, so the skeleton must build.
        let skeleton = doc.try_skeleton();
        assert!(
            skeleton.is_ok(),
            "parse_bvh accepted a document whose skeleton fails: {skeleton:?}"
        );
        let rig = doc.to_rig(Some(0));
        let world = rig.skeleton.world_matrices(&rig.pose);
        assert_eq!(world.len(), rig.skeleton.len());
        for a in &rig.animations {
            let _ = a.sample(&rig.pose, 0.5);
        }
    }
});
