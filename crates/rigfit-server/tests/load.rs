//! A small load test over real HTTP on 127.0.0.1: concurrent clients solving on the humanoid
//! and BCN_Epileptic, then bad requests interleaved with valid ones. Everything must be
//! answered as expected. (The full run, with figures, is `examples/load_test.rs`.)

mod common;

use std::time::Duration;

use common::asset;
use common::load::{RunningServer, Workload, abuse_load, solve_bodies, solve_load, upload};
use rigfit_formats::rig_file::{RigOptions, read_rig};

#[test]
fn concurrent_clients_are_all_answered_and_bad_requests_do_not_hurt() {
    let server = RunningServer::start();
    let humanoid = rigfit_server::humanoid_rig_file().expect("humanoid").rig;
    let bcn_path = asset("assimp/BCN_Epileptic.glb");
    let bcn = read_rig(&bcn_path, &RigOptions::default())
        .expect("rig")
        .rig;
    let bcn_id = upload(
        server.addr,
        "BCN_Epileptic.glb",
        &std::fs::read(&bcn_path).expect("asset"),
    );
    let workloads = [
        Workload {
            label: "humanoid".into(),
            character: "c0".into(),
            bodies: solve_bodies(&humanoid, 4, 10),
        },
        Workload {
            label: "BCN_Epileptic".into(),
            character: bcn_id,
            bodies: solve_bodies(&bcn, 4, 20),
        },
    ];
    let limit = Duration::from_secs(300);
    let report = solve_load(server.addr, &workloads, 8, 40, limit);
    println!("solve load: {}", report.summary());
    assert!(report.failures.is_empty(), "{:#?}", report.failures);
    assert_eq!(report.latencies.len(), 40);
    let (report, bad) = abuse_load(server.addr, &workloads, 8, 48, limit);
    println!(
        "with bad requests: {} ({bad} bad requests refused as expected)",
        report.summary()
    );
    assert!(report.failures.is_empty(), "{:#?}", report.failures);
    assert_eq!(bad, 42);
    assert_eq!(report.latencies.len(), 6);
}
