//! glTF / GLB reader (no external files), then skinning every mesh in the stored pose and
//! sampling every animation of whatever it accepts.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut no_files = |_uri: &str| -> Result<Vec<u8>, String> { Err("no files".into()) };
    if let Ok(doc) = rigfit_formats::gltf::parse_gltf(data, &mut no_files, None) {
        if let Some(rig) = &doc.rig {
            let w = rig.skeleton.world_matrices(&rig.pose);
            for m in &rig.meshes {
                let _ = m.skin(&w);
            }
            for a in &rig.animations {
                let _ = a.sample(&rig.pose, 0.5);
            }
        }
    }
});
