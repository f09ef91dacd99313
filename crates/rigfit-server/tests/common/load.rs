//! The load test, shared by the test (small) and `examples/load_test.rs` (full): a server on
//! 127.0.0.1 in-process, concurrent clients sending solve requests drawn from the rigs' own
//! animations, then malformed and oversized requests interleaved with valid ones. Loopback
//! only; bounded in count and time.

use std::net::SocketAddr;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use rigfit_core::Rig;
use rigfit_server::{AppState, ServerConfig};
use serde_json::{Value, json};

use super::http::{HttpAnswer, request, request_declaring};
use super::{case_from_animation, pose_json};

/// A server running on 127.0.0.1 (a free port) on its own thread, holding the humanoid as
/// `c0`; stopped (gracefully) when dropped.
pub struct RunningServer {
    pub addr: SocketAddr,
    /// The server's state (its characters, its busy workers).
    pub state: AppState,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl RunningServer {
    pub fn start() -> Self {
        Self::start_with(ServerConfig::default())
    }

    /// A server with this configuration.
    pub fn start_with(config: ServerConfig) -> Self {
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
        let state = AppState::new(&config);
        state.add_humanoid().expect("humanoid");
        let served = state.clone();
        let thread = std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .enable_all()
                .build()
                .expect("runtime");
            runtime.block_on(async move {
                let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
                    .await
                    .expect("binds a loopback port");
                addr_tx
                    .send(listener.local_addr().expect("address"))
                    .expect("the test waits for the address");
                rigfit_server::serve(listener, served, async {
                    let _ = stop_rx.await;
                })
                .await
                .expect("serves");
            });
            // Blocking jobs still running (cancelled solves) are not waited for.
            runtime.shutdown_timeout(Duration::from_millis(500));
        });
        let addr = addr_rx
            .recv_timeout(Duration::from_secs(30))
            .expect("the server starts");
        Self {
            addr,
            state,
            stop: Some(stop_tx),
            thread: Some(thread),
        }
    }

    /// Stops the server; how long `serve` took to return.
    pub fn stop(mut self) -> Duration {
        let t0 = Instant::now();
        self.shut_down();
        t0.elapsed()
    }

    fn shut_down(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

impl Drop for RunningServer {
    fn drop(&mut self) {
        self.shut_down();
    }
}

/// Uploads a file to a running server; the new character's id.
pub fn upload(addr: SocketAddr, file_name: &str, bytes: &[u8]) -> String {
    let answer = request(
        addr,
        "POST",
        &format!("/api/characters?name={file_name}"),
        bytes,
    )
    .expect("upload answered");
    assert_eq!(answer.status, 201, "{file_name}: {}", answer.text());
    let value: Value = serde_json::from_slice(&answer.body).expect("CHARACTER JSON");
    value["id"].as_str().expect("id").to_string()
}

/// The solve requests of one character.
#[derive(Debug, Clone)]
pub struct Workload {
    pub label: String,
    pub character: String,
    pub bodies: Vec<String>,
}

/// `count` solve request bodies for `rig`: strokes through its animation at evenly spread
/// times (one per limb, 1% noise), starting from the stored pose.
pub fn solve_bodies(rig: &Rig, count: usize, seed: u64) -> Vec<String> {
    let pose = pose_json(rig, &rig.pose);
    (0..count)
        .map(|i| {
            let case = case_from_animation(rig, (i as f64 + 0.5) / count as f64, seed + i as u64);
            json!({ "pose": pose, "strokes": case.strokes, "method": "rigfit" }).to_string()
        })
        .collect()
}

/// What a run measured.
#[derive(Debug, Default)]
pub struct LoadReport {
    /// Latency of every request that got its expected answer.
    pub latencies: Vec<Duration>,
    /// The same latencies, each with the label of its request (the rig, or the kind of bad
    /// request).
    pub labeled: Vec<(String, Duration)>,
    pub wall: Duration,
    /// One line per request that did not get its expected answer.
    pub failures: Vec<String>,
    /// Requests sent.
    pub sent: usize,
}

/// The `q` quantile of `latencies` (nearest rank).
pub fn percentile(latencies: &[Duration], q: f64) -> Duration {
    let mut sorted = latencies.to_vec();
    sorted.sort();
    if sorted.is_empty() {
        return Duration::ZERO;
    }
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

impl LoadReport {
    /// The `q` quantile of the latencies (nearest rank).
    pub fn percentile(&self, q: f64) -> Duration {
        percentile(&self.latencies, q)
    }

    /// Latency percentiles (p50, p95, max) per label, in milliseconds.
    pub fn by_label(&self) -> String {
        let mut labels: Vec<&str> = self.labeled.iter().map(|(l, _)| l.as_str()).collect();
        labels.sort_unstable();
        labels.dedup();
        let ms = |d: Duration| d.as_secs_f64() * 1000.0;
        labels
            .iter()
            .map(|label| {
                let own: Vec<Duration> = self
                    .labeled
                    .iter()
                    .filter(|(l, _)| l == label)
                    .map(|(_, d)| *d)
                    .collect();
                format!(
                    "{label} ({}): p50 {:.1} ms, p95 {:.1} ms, max {:.1} ms",
                    own.len(),
                    ms(percentile(&own, 0.5)),
                    ms(percentile(&own, 0.95)),
                    ms(percentile(&own, 1.0)),
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    /// Answered requests per second of wall time.
    pub fn throughput(&self) -> f64 {
        self.latencies.len() as f64 / self.wall.as_secs_f64().max(1e-9)
    }

    pub fn summary(&self) -> String {
        let ms = |d: Duration| d.as_secs_f64() * 1000.0;
        format!(
            "{} sent, {} ok, {} failed in {:.2} s: {:.1} requests/s; latency p50 {:.1} ms, p95 {:.1} ms, p99 {:.1} ms, max {:.1} ms",
            self.sent,
            self.latencies.len(),
            self.failures.len(),
            self.wall.as_secs_f64(),
            self.throughput(),
            ms(self.percentile(0.50)),
            ms(self.percentile(0.95)),
            ms(self.percentile(0.99)),
            ms(self.percentile(1.0)),
        )
    }
}

/// Runs `requests` jobs on `clients` threads; job `i` is `job(i)`, which answers the label of
/// a request that got what it expected, or a line saying what went wrong. Stops sending after
/// `time_limit`.
fn run_clients(
    clients: usize,
    requests: usize,
    time_limit: Duration,
    job: impl Fn(usize) -> Result<String, String> + Sync,
) -> LoadReport {
    let next = AtomicUsize::new(0);
    let report = Mutex::new(LoadReport::default());
    let start = Instant::now();
    std::thread::scope(|scope| {
        for _ in 0..clients {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= requests {
                        break;
                    }
                    if start.elapsed() > time_limit {
                        let mut r = report.lock().expect("report");
                        r.failures
                            .push(format!("request {i}: not sent, past the time limit"));
                        continue;
                    }
                    let t0 = Instant::now();
                    let outcome = job(i);
                    let latency = t0.elapsed();
                    let mut r = report.lock().expect("report");
                    r.sent += 1;
                    match outcome {
                        Ok(label) => {
                            r.latencies.push(latency);
                            r.labeled.push((label, latency));
                        }
                        Err(line) => r.failures.push(format!("request {i}: {line}")),
                    }
                }
            });
        }
    });
    let mut report = report.into_inner().expect("report");
    report.wall = start.elapsed();
    report
}

/// Checks a solve answer: 200 with a pose report.
fn check_solve(answer: std::io::Result<HttpAnswer>) -> Result<(), String> {
    let answer = answer.map_err(|e| format!("no answer: {e}"))?;
    if answer.status != 200 {
        return Err(format!("status {}: {}", answer.status, answer.text()));
    }
    let value: Value =
        serde_json::from_slice(&answer.body).map_err(|e| format!("not JSON: {e}"))?;
    if value["joints"].as_array().is_none_or(|j| j.is_empty()) {
        return Err(format!("no joints in {value}"));
    }
    Ok(())
}

/// Checks an error answer: `status` with `{"error": "..."}`.
fn check_error(answer: std::io::Result<HttpAnswer>, status: u16) -> Result<(), String> {
    let answer = answer.map_err(|e| format!("no answer: {e}"))?;
    if answer.status != status {
        return Err(format!(
            "status {} (expected {status}): {}",
            answer.status,
            answer.text()
        ));
    }
    let value: Value = serde_json::from_slice(&answer.body)
        .map_err(|e| format!("error body not JSON ({e}): {}", answer.text()))?;
    match value.get("error").and_then(Value::as_str) {
        Some(line) if !line.is_empty() && !line.contains('\n') => Ok(()),
        _ => Err(format!("not an error line: {value}")),
    }
}

/// Solve request `i` of the round-robin over the workloads; answers the workload's label.
fn solve_job(addr: SocketAddr, workloads: &[Workload], i: usize) -> Result<String, String> {
    let w = &workloads[i % workloads.len()];
    let body = &w.bodies[(i / workloads.len()) % w.bodies.len()];
    check_solve(request(
        addr,
        "POST",
        &format!("/api/characters/{}/solve", w.character),
        body.as_bytes(),
    ))
    .map(|()| w.label.clone())
    .map_err(|e| format!("{}: {e}", w.label))
}

/// `requests` valid solves from `clients` concurrent clients; every answer must be 200.
pub fn solve_load(
    addr: SocketAddr,
    workloads: &[Workload],
    clients: usize,
    requests: usize,
    time_limit: Duration,
) -> LoadReport {
    run_clients(clients, requests, time_limit, |i| {
        solve_job(addr, workloads, i)
    })
}

/// The bad requests sent between valid ones, each with the status it must get.
const ABUSE_KINDS: usize = 8;

/// `rounds` requests from `clients` concurrent clients, cycling through a valid solve and
/// seven kinds of bad request (malformed JSON, an oversized solve, a garbage upload, an
/// unknown character, a path traversal, an unknown file type, an oversized upload). Every bad
/// one must get its 4xx with an error line, every valid one 200. The report's latencies are
/// the valid solves'.
pub fn abuse_load(
    addr: SocketAddr,
    workloads: &[Workload],
    clients: usize,
    rounds: usize,
    time_limit: Duration,
) -> (LoadReport, usize) {
    let bad_answered = AtomicUsize::new(0);
    let mut report = run_clients(clients, rounds, time_limit, |i| {
        let character = &workloads[i % workloads.len()].character;
        let kind = i % ABUSE_KINDS;
        let outcome = match kind {
            0 => return solve_job(addr, workloads, i / ABUSE_KINDS),
            1 => check_error(
                request(
                    addr,
                    "POST",
                    &format!("/api/characters/{character}/solve"),
                    b"{\"strokes\": [{\"points\": [[0, 1",
                ),
                400,
            ),
            2 => check_error(
                request_declaring(
                    addr,
                    "POST",
                    &format!("/api/characters/{character}/solve"),
                    (4 << 20) + 1,
                ),
                413,
            ),
            3 => check_error(
                request(
                    addr,
                    "POST",
                    "/api/characters?name=garbage.glb",
                    b"glTF\x02\x00\x00\x00garbage",
                ),
                400,
            ),
            4 => check_error(
                request(addr, "POST", "/api/characters/c999/solve", b"{}"),
                404,
            ),
            5 => check_error(request(addr, "GET", "/app/../../etc/passwd", b""), 404),
            6 => check_error(
                request(addr, "POST", "/api/characters?name=notes.txt", b"hello"),
                415,
            ),
            _ => check_error(
                request_declaring(addr, "POST", "/api/characters?name=big.glb", (64 << 20) + 1),
                413,
            ),
        };
        if outcome.is_ok() {
            bad_answered.fetch_add(1, Ordering::Relaxed);
        }
        outcome.map(|()| format!("bad request {kind}"))
    });
    // The report's latencies are the valid solves'.
    report.latencies = report
        .labeled
        .iter()
        .filter(|(label, _)| !label.starts_with("bad request"))
        .map(|(_, d)| *d)
        .collect();
    (report, bad_answered.into_inner())
}
