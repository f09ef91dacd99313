//! The serving load test (BENCHMARKS.md, "Serving"): a server on 127.0.0.1 (a free port,
//! in-process), 20 concurrent clients sending 200 solve requests in total on the built-in
//! humanoid and BCN_Epileptic (strokes drawn from each rig's own animation, one per limb),
//! then malformed and oversized requests interleaved with valid ones. Prints latency
//! percentiles and throughput; exits 1 if any request did not get its expected answer.
//!
//! `cargo run --release -p rigfit-server --example load_test [-- CLIENTS REQUESTS]`

#[path = "../tests/common/mod.rs"]
mod common;

use std::process::ExitCode;
use std::time::Duration;

use common::asset;
use common::load::{RunningServer, Workload, abuse_load, solve_bodies, solve_load, upload};
use rigfit_formats::rig_file::{RigOptions, read_rig};

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let clients: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(20);
    let requests: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(200);
    let server = RunningServer::start();
    let humanoid = match rigfit_server::humanoid_rig_file() {
        Ok(r) => r.rig,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let bcn_path = asset("assimp/BCN_Epileptic.glb");
    let (bcn, bcn_bytes) = match (
        read_rig(&bcn_path, &RigOptions::default()),
        std::fs::read(&bcn_path),
    ) {
        (Ok(r), Ok(b)) => (r.rig, b),
        _ => {
            eprintln!("{}: cannot be read", bcn_path.display());
            return ExitCode::FAILURE;
        }
    };
    let bcn_id = upload(server.addr, "BCN_Epileptic.glb", &bcn_bytes);
    let workloads = [
        Workload {
            label: "humanoid".into(),
            character: "c0".into(),
            bodies: solve_bodies(&humanoid, 10, 100),
        },
        Workload {
            label: "BCN_Epileptic".into(),
            character: bcn_id,
            bodies: solve_bodies(&bcn, 10, 200),
        },
    ];
    let strokes: Vec<usize> = workloads
        .iter()
        .map(|w| {
            serde_json::from_str::<serde_json::Value>(&w.bodies[0])
                .ok()
                .and_then(|v| v["strokes"].as_array().map(Vec::len))
                .unwrap_or(0)
        })
        .collect();
    println!(
        "server on {}; {clients} clients, {requests} solve requests (humanoid {} strokes, BCN_Epileptic {} strokes per request), {} cores",
        server.addr,
        strokes[0],
        strokes[1],
        std::thread::available_parallelism().map_or(1, usize::from)
    );
    let limit = Duration::from_secs(600);
    // One client first: the time one solve takes with the server otherwise idle.
    let alone = solve_load(server.addr, &workloads, 1, 20, limit);
    println!("one client:        {}", alone.summary());
    println!("                   {}", alone.by_label());
    let solves = solve_load(server.addr, &workloads, clients, requests, limit);
    println!("solves:            {}", solves.summary());
    println!("                   {}", solves.by_label());
    let rounds = requests;
    let (mixed, bad) = abuse_load(server.addr, &workloads, clients, rounds, limit);
    println!("mixed, valid only: {}", mixed.summary());
    println!(
        "bad requests:      {bad} of {} refused with their 4xx and an error line",
        rounds - rounds.div_ceil(8)
    );
    let failures: Vec<&String> = alone
        .failures
        .iter()
        .chain(&solves.failures)
        .chain(&mixed.failures)
        .collect();
    for f in failures.iter().take(20) {
        eprintln!("FAILED {f}");
    }
    if failures.is_empty() {
        println!("all answered as expected");
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "{} requests did not get their expected answer",
            failures.len()
        );
        ExitCode::FAILURE
    }
}
