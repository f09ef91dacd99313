//! Abuse of a running server over real HTTP on 127.0.0.1 (in-process, a free port; bounded
//! in count and time): cross-site requests, bad hosts and content types, hyper's own error
//! answers, request limits, solves whose client leaves or that run past the deadline,
//! shutdown with solves under way, idle and partial connections past the connection cap,
//! and uploads past the memory budget. After every bad request the server still answers.
//! (The process-level checks, SIGTERM and resident memory, are in rigfit-cli's
//! tests/serve.rs.)

mod common;

use std::io::{self, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

use common::http::{HttpAnswer, connect, raw, request, request_with};
use common::load::RunningServer;
use rigfit_server::ServerConfig;
use serde_json::{Value, json};

const SOLVE: &str = "/api/characters/c0/solve";
const EXPORT: &str = "/api/characters/c0/export";
const JSON: &str = "Content-Type: application/json";

/// The `{"error": "one line"}` of an answer with `status`, checked.
fn error_line(answer: io::Result<HttpAnswer>, status: u16) -> String {
    let answer = answer.expect("answered");
    assert_eq!(
        answer.status,
        status,
        "{}",
        answer.text().chars().take(300).collect::<String>()
    );
    assert!(
        answer
            .header("content-type")
            .is_some_and(|t| t.starts_with("application/json")),
        "{:?}",
        answer.headers
    );
    let value: Value = serde_json::from_slice(&answer.body).expect("JSON error body");
    assert_eq!(value.as_object().map(|o| o.len()), Some(1), "{value}");
    let line = value["error"].as_str().expect("error line").to_string();
    assert!(!line.is_empty() && !line.contains('\n'), "{line}");
    line
}

/// The server still answers a plain request, promptly.
fn assert_serving(addr: SocketAddr) {
    let t0 = Instant::now();
    let answer = request(addr, "GET", "/api/characters", b"").expect("answered");
    assert_eq!(answer.status, 200, "{}", answer.text());
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
}

/// A small solve on the humanoid: one stroke along the left arm.
fn small_solve() -> String {
    json!({ "strokes": [ { "points": [[0.2, 1.45, 0.0], [0.45, 1.45, 0.0], [0.7, 1.45, 0.0]] } ] })
        .to_string()
}

/// Uploads a 1051-joint rig (50 chains of 20 joints) on which the heaviest solve a request
/// may ask takes seconds; its id.
fn upload_big_rig(addr: SocketAddr) -> String {
    common::load::upload(addr, "tree.bvh", common::rigs::tree_bvh(50, 20).as_bytes())
}

/// A solve that runs for seconds on [`upload_big_rig`]'s rig (about 19 s in a debug build):
/// the most strokes a request may hold, of varied lengths, fanning out from the hips. `seed`
/// turns the fan.
fn heavy_solve(seed: u64) -> String {
    let strokes: Vec<Value> = (0..rigfit_server::request::MAX_STROKES)
        .map(|s| {
            let a = s as f64 * 0.61 + seed as f64 * 0.1;
            let length = 0.3 + 0.07 * ((s * 7) % 10) as f64;
            let points: Vec<Value> = (0..250)
                .map(|k| {
                    let t = 1.05 * length * k as f64 / 250.0;
                    json!([0.5 * a.cos() * t, t, 0.5 * a.sin() * t])
                })
                .collect();
            json!({ "points": points })
        })
        .collect();
    json!({ "strokes": strokes }).to_string()
}

/// Sends a request on a connection that is kept open and not read; the stream.
fn send_unread(addr: SocketAddr, path: &str, body: &str) -> TcpStream {
    let mut stream = connect(addr).expect("connects");
    let head = format!(
        "POST {path} HTTP/1.1\r\nHost: {addr}\r\n{JSON}\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes()).expect("head sent");
    stream.write_all(body.as_bytes()).expect("body sent");
    stream
}

/// Waits until `done()` holds (polling every 10 ms) or `limit` passes; how long it took.
fn wait_for(limit: Duration, done: impl Fn() -> bool) -> Option<Duration> {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if done() {
            return Some(t0.elapsed());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    None
}

#[test]
fn cross_site_requests_bad_hosts_and_content_types_are_refused() {
    let server = RunningServer::start();
    let addr = server.addr;
    let body = small_solve();
    let tiny_bvh = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n End Site\n {\n  OFFSET 0 -1 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0\n";
    // Another site's page: a form or text POST, and even a JSON one, is refused.
    for (path, content_type, body) in [
        (SOLVE, "text/plain", body.as_str()),
        (EXPORT, "multipart/form-data; boundary=x", "{}"),
        (
            "/api/characters?name=x.bvh",
            "application/x-www-form-urlencoded",
            tiny_bvh,
        ),
        (SOLVE, "application/json", body.as_str()),
        (
            "/api/characters?name=x.bvh",
            "application/octet-stream",
            tiny_bvh,
        ),
    ] {
        let answer = request_with(
            addr,
            "POST",
            path,
            &[
                "Origin: http://evil.com",
                &format!("Content-Type: {content_type}"),
            ],
            body.as_bytes(),
        );
        assert!(error_line(answer, 403).contains("evil.com"));
        assert_serving(addr);
    }
    let other_port = format!("Origin: http://127.0.0.1:{}", addr.port() + 1);
    for origin in [
        "Origin: null",
        other_port.as_str(),
        "Origin: http://[::1]evil.com",
    ] {
        error_line(
            request_with(addr, "POST", SOLVE, &[origin, JSON], body.as_bytes()),
            403,
        );
        error_line(
            request_with(addr, "DELETE", "/api/characters/c0", &[origin], b""),
            403,
        );
    }
    let answer = request_with(
        addr,
        "GET",
        "/api/characters",
        &["Origin: http://evil.com"],
        b"",
    );
    error_line(answer, 403);
    // The page itself (same origin), and clients that send no Origin, are served.
    let own = format!("Origin: http://{addr}");
    for headers in [
        vec![own.as_str(), JSON],
        vec![JSON],
        vec!["Content-Type: application/json; charset=utf-8"],
    ] {
        let answer = request_with(addr, "POST", SOLVE, &headers, body.as_bytes()).expect("answer");
        assert_eq!(answer.status, 200, "{headers:?}: {}", answer.text());
    }
    // Bodies a browser may send cross-site without asking first: 415, whoever sends them.
    for path in [SOLVE, EXPORT] {
        for content_type in [
            None,
            Some("Content-Type: text/plain"),
            Some("Content-Type: application/x-www-form-urlencoded"),
            Some("Content-Type: multipart/form-data; boundary=x"),
        ] {
            let headers: Vec<&str> = content_type.into_iter().collect();
            let line = error_line(
                request_with(addr, "POST", path, &headers, body.as_bytes()),
                415,
            );
            assert!(line.contains("Content-Type"), "{line}");
        }
    }
    for content_type in [
        "Content-Type: text/plain",
        "Content-Type: multipart/form-data",
    ] {
        error_line(
            request_with(
                addr,
                "POST",
                "/api/characters?name=x.bvh",
                &[content_type],
                tiny_bvh.as_bytes(),
            ),
            415,
        );
    }
    // Hosts that are not loopback names, however they are spelled.
    for host in [
        "[::1]evil.com",
        "[::1]evil.com:8717",
        "evil.com",
        "localhost.evil.com",
        "127.0.0.1.nip.io",
        "localhost@evil.com",
        "localhost:8717:1",
    ] {
        let header = format!("Host: {host}");
        let line = error_line(
            request_with(addr, "GET", "/api/characters", &[&header], b""),
            403,
        );
        assert!(line.contains("localhost"), "{line}");
    }
    // Every answer carries the security headers; the page its policy.
    let page = request(addr, "GET", "/", b"").expect("page");
    assert_eq!(page.status, 200);
    assert_eq!(page.header("x-content-type-options"), Some("nosniff"));
    assert_eq!(page.header("x-frame-options"), Some("DENY"));
    let policy = page.header("content-security-policy").expect("a CSP");
    assert!(policy.contains("frame-ancestors 'none'"), "{policy}");
    assert!(policy.contains("script-src 'self' 'sha256-"), "{policy}");
    let list = request(addr, "GET", "/api/characters", b"").expect("list");
    assert_eq!(list.header("x-content-type-options"), Some("nosniff"));
    // hyper's own answers to requests it cannot parse have the API's shape.
    error_line(raw(addr, b"GARBAGE\r\n\r\n"), 400);
    error_line(
        raw(
            addr,
            b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nno colon here\r\n\r\n",
        ),
        400,
    );
    let mut many = String::from("GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n");
    for i in 0..150 {
        many.push_str(&format!("X-Header-{i}: {i}\r\n"));
    }
    many.push_str("\r\n");
    assert!(error_line(raw(addr, many.as_bytes()), 431).contains("too large"));
    assert_serving(addr);
}

#[test]
fn requests_past_the_limits_get_one_line_each() {
    let server = RunningServer::start();
    let addr = server.addr;
    let point = json!([0.1, 1.0, 0.0]);
    let stroke = json!({ "points": [point, point] });
    let many_strokes = json!({ "strokes": vec![stroke.clone(); 201] });
    let long_stroke = json!({ "strokes": [ { "points": vec![point.clone(); 10_001] } ] });
    let many_points =
        json!({ "strokes": vec![json!({ "points": vec![point.clone(); 9_000] }); 6] });
    let names: Vec<String> = (0..27).map(|i| format!("J{i}")).collect();
    let many_names = json!({ "strokes": [stroke], "bones": names });
    let far = json!({ "strokes": [stroke], "pose": { "joints": [
        { "name": "Hips", "translation": [1e9, 0, 0] } ] } });
    let huge_scale = json!({ "strokes": [stroke], "pose": { "joints": [
        { "name": "Hips", "scale": [1e6, 1, 1] } ] } });
    let joint = json!({ "name": "Hips" });
    let many_joints = json!({ "strokes": [stroke], "pose": { "joints": vec![joint; 27] } });
    for (path, body, expected) in [
        (SOLVE, &many_strokes, "strokes: 201 strokes"),
        (SOLVE, &long_stroke, "strokes[0].points: 10001 points"),
        (SOLVE, &many_points, "more than 50000 points"),
        (SOLVE, &many_names, "bones: 27 names"),
        (SOLVE, &far, "pose.joints[0].translation"),
        (SOLVE, &huge_scale, "pose.joints[0].scale"),
        (SOLVE, &many_joints, "pose.joints: 27 joints"),
        (EXPORT, &far, "pose.joints[0].translation"),
    ] {
        let t0 = Instant::now();
        let line = error_line(
            request(addr, "POST", path, body.to_string().as_bytes()),
            400,
        );
        assert!(line.contains(expected), "{expected}: {line}");
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "{line}: {:?}",
            t0.elapsed()
        );
        assert_serving(addr);
    }
    let keys: Vec<Value> = (0..1001).map(|f| json!({ "frame": f })).collect();
    let line = error_line(
        request(
            addr,
            "POST",
            EXPORT,
            json!({ "keys": keys }).to_string().as_bytes(),
        ),
        400,
    );
    assert!(line.contains("keys: 1001 keys"), "{line}");
    assert_serving(addr);
}

#[test]
fn a_solve_whose_client_leaves_is_cancelled() {
    let server = RunningServer::start_with(ServerConfig {
        workers: 1,
        ..ServerConfig::default()
    });
    let addr = server.addr;
    let state = server.state.clone();
    let rig = upload_big_rig(addr);
    let stream = send_unread(
        addr,
        &format!("/api/characters/{rig}/solve"),
        &heavy_solve(1),
    );
    wait_for(Duration::from_secs(10), || state.busy_workers() == 1).expect("the solve starts");
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(state.busy_workers(), 1, "the heavy solve runs for seconds");
    // The client goes: the solve stops and frees its worker.
    drop(stream);
    let latency =
        wait_for(Duration::from_secs(10), || state.busy_workers() == 0).expect("the solve stops");
    println!("cancel latency (client gone -> worker free): {latency:?}");
    assert!(latency < Duration::from_secs(1), "{latency:?}");
    // The one worker serves the next solve at once.
    let t0 = Instant::now();
    let answer = request(addr, "POST", SOLVE, small_solve().as_bytes()).expect("answer");
    assert_eq!(answer.status, 200, "{}", answer.text());
    println!("next solve answered in {:?}", t0.elapsed());
    assert!(t0.elapsed() < Duration::from_secs(5));
}

#[test]
fn a_solve_past_the_deadline_gets_503() {
    let server = RunningServer::start_with(ServerConfig {
        solve_timeout: Duration::from_millis(300),
        ..ServerConfig::default()
    });
    let rig = upload_big_rig(server.addr);
    let t0 = Instant::now();
    let line = error_line(
        request(
            server.addr,
            "POST",
            &format!("/api/characters/{rig}/solve"),
            heavy_solve(2).as_bytes(),
        ),
        503,
    );
    println!("deadline 0.3 s: answered 503 after {:?}", t0.elapsed());
    assert!(line.contains("longer than 0.3 s"), "{line}");
    assert!(t0.elapsed() < Duration::from_secs(2), "{:?}", t0.elapsed());
    assert_eq!(server.state.busy_workers(), 0);
    assert_serving(server.addr);
}

#[test]
fn shutdown_with_solves_under_way_is_bounded() {
    let grace = Duration::from_millis(500);
    let server = RunningServer::start_with(ServerConfig {
        workers: 2,
        shutdown_grace: grace,
        ..ServerConfig::default()
    });
    let state = server.state.clone();
    let solve = format!("/api/characters/{}/solve", upload_big_rig(server.addr));
    let streams: Vec<TcpStream> = (0..3)
        .map(|i| send_unread(server.addr, &solve, &heavy_solve(10 + i)))
        .collect();
    wait_for(Duration::from_secs(10), || state.busy_workers() == 2).expect("two solves run");
    let took = server.stop();
    println!("serve returned {took:?} after the shutdown signal (grace {grace:?})");
    assert!(took < grace + Duration::from_secs(2), "{took:?}");
    // The solves under way were cancelled, not left running.
    let stopped = wait_for(Duration::from_secs(5), || state.busy_workers() == 0);
    println!("solves stopped {stopped:?} after serve returned");
    assert!(
        stopped.is_some_and(|d| d < Duration::from_secs(1)),
        "{stopped:?}"
    );
    drop(streams);
}

#[test]
fn idle_and_partial_connections_do_not_starve_the_server() {
    let server = RunningServer::start_with(ServerConfig {
        header_timeout: Duration::from_secs(1),
        body_timeout: Duration::from_secs(1),
        max_connections: 64,
        ..ServerConfig::default()
    });
    let addr = server.addr;
    let mut held = Vec::new();
    let opened = Instant::now();
    for i in 0..300 {
        let mut stream = connect(addr).expect("connects");
        match i % 3 {
            0 => {}
            1 => stream
                .write_all(b"GET /api/characters HTTP/1.1\r\nHost: 127.0.0.1\r\n")
                .expect("partial head"),
            _ => {
                let head = format!(
                    "POST {SOLVE} HTTP/1.1\r\nHost: 127.0.0.1\r\n{JSON}\r\nContent-Length: 1000\r\n\r\n{{\"strokes\""
                );
                stream.write_all(head.as_bytes()).expect("partial body");
            }
        }
        held.push((i, stream));
    }
    println!("300 connections opened in {:?}", opened.elapsed());
    // A new client is answered while all 300 are still open.
    let t0 = Instant::now();
    let answer = request(addr, "GET", "/api/characters", b"").expect("answered");
    let waited = t0.elapsed();
    println!("with 300 idle/partial connections open: answered in {waited:?}");
    assert_eq!(answer.status, 200);
    assert!(waited < Duration::from_secs(5), "{waited:?}");
    // The server closes every one of them (a partial body after a 408).
    let t0 = Instant::now();
    let mut timed_out_bodies = 0;
    for (i, stream) in &mut held {
        stream
            .set_read_timeout(Some(Duration::from_secs(10)))
            .expect("timeout");
        let mut answer = Vec::new();
        let closed = stream.read_to_end(&mut answer);
        assert!(
            closed.is_ok()
                || closed
                    .as_ref()
                    .is_err_and(|e| e.kind() == io::ErrorKind::ConnectionReset),
            "connection {i}: {closed:?}"
        );
        if String::from_utf8_lossy(&answer).starts_with("HTTP/1.1 408") {
            timed_out_bodies += 1;
        }
    }
    println!(
        "all 300 closed by the server {:?} later ({timed_out_bodies} partial bodies answered 408)",
        t0.elapsed()
    );
    assert!(timed_out_bodies > 0);
    assert_serving(addr);
}

#[test]
fn uploads_past_the_memory_budget_are_refused_and_delete_frees_it() {
    let budget = 96 << 20;
    let server = RunningServer::start_with(ServerConfig {
        memory_budget: budget,
        ..ServerConfig::default()
    });
    let addr = server.addr;
    let store = &server.state.characters;
    let bvh = common::rigs::long_bvh(60_000);
    let mut ids = Vec::new();
    let refused = loop {
        let answer = request(addr, "POST", "/api/characters?name=long.bvh", &bvh).expect("answer");
        if answer.status != 201 {
            break answer;
        }
        let value: Value = serde_json::from_slice(&answer.body).expect("CHARACTER");
        ids.push(value["id"].as_str().expect("id").to_string());
        assert!(ids.len() < 32, "the budget refuses before the count does");
    };
    let stored = store.stored_bytes();
    println!(
        "{} uploads of {:.1} MiB stored, estimated {:.1} MiB of the {:.0} MiB budget ({:.1} MiB each)",
        ids.len(),
        bvh.len() as f64 / 1048576.0,
        stored as f64 / 1048576.0,
        budget as f64 / 1048576.0,
        stored as f64 / 1048576.0 / ids.len() as f64,
    );
    assert!(ids.len() >= 2, "{}", ids.len());
    assert!(stored <= budget);
    let line = error_line(Ok(refused), 507);
    assert!(line.contains("delete a character first"), "{line}");
    let list: Value = serde_json::from_slice(
        &request(addr, "GET", "/api/characters", b"")
            .expect("list")
            .body,
    )
    .expect("JSON");
    assert_eq!(list["memory"]["budget"], json!(budget));
    assert_eq!(list["memory"]["bytes"], json!(stored));
    // A DELETE gives its share back: the next upload fits.
    let answer =
        request(addr, "DELETE", &format!("/api/characters/{}", ids[0]), b"").expect("answer");
    assert_eq!(answer.status, 204);
    assert!(store.stored_bytes() < stored);
    let answer = request(addr, "POST", "/api/characters?name=long.bvh", &bvh).expect("answer");
    assert_eq!(answer.status, 201, "{}", answer.text());
    assert!(store.stored_bytes() <= budget);
    assert_serving(addr);
}

#[test]
fn a_client_that_stops_reading_is_disconnected() {
    let server = RunningServer::start_with(ServerConfig {
        send_timeout: Duration::from_millis(500),
        ..ServerConfig::default()
    });
    let addr = server.addr;
    // A display model of about 16 MiB: more than the sockets' buffers hold.
    let id = common::load::upload(addr, "long.bvh", &common::rigs::long_bvh(460_000));
    let mut stream = connect(addr).expect("connects");
    write!(
        stream,
        "GET /api/characters/{id}/model.glb HTTP/1.1\r\nHost: {addr}\r\n\r\n"
    )
    .expect("sent");
    // The client reads nothing for 2 s: the server gives up on it after 0.5 s.
    std::thread::sleep(Duration::from_secs(2));
    stream
        .set_read_timeout(Some(Duration::from_secs(5)))
        .expect("timeout");
    let mut got = Vec::new();
    let t0 = Instant::now();
    let end = stream.read_to_end(&mut got);
    println!(
        "a client that stopped reading got {:.1} MiB before the server closed ({end:?} after {:?})",
        got.len() as f64 / 1048576.0,
        t0.elapsed()
    );
    assert!(
        end.is_ok()
            || end
                .as_ref()
                .is_err_and(|e| e.kind() == io::ErrorKind::ConnectionReset),
        "the server closed the connection: {end:?}"
    );
    assert!(
        got.len() < 16 << 20,
        "{} bytes: the whole answer",
        got.len()
    );
    assert_serving(addr);
}
