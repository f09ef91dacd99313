//! `rigfit serve` as a process: it prints its address as the first line, answers on it, and
//! stops cleanly on SIGTERM (within 5 s, solves under way or not); its resident memory stays
//! within the memory budget however many uploads come; a bad RIG is one line and exit status
//! 2 before listening.

mod common;
#[path = "../../rigfit-server/tests/common/rigs.rs"]
mod rigs;

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{assert_bad_input, data, rigfit};

/// Starts `rigfit serve ARGS --port 0` and reads the address from its first line.
fn start(args: &[&str]) -> (Child, SocketAddr, String) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_rigfit"));
    command.arg("serve").args(args).args(["--port", "0"]);
    start_command(command)
}

/// Starts `command` (a `rigfit serve --port 0`) and reads the address from its first line.
fn start_command(mut command: Command) -> (Child, SocketAddr, String) {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("rigfit serve starts");
    let stdout = child.stdout.take().expect("stdout");
    let mut first = String::new();
    BufReader::new(stdout)
        .read_line(&mut first)
        .expect("the first line");
    let url = first
        .trim_end()
        .strip_prefix("rigfit serve: http://")
        .and_then(|rest| rest.strip_suffix('/'))
        .unwrap_or_else(|| panic!("first line: {first:?}"));
    let addr: SocketAddr = url.parse().expect("HOST:PORT");
    (child, addr, first)
}

/// `GET path` over a fresh connection; the status code and body.
fn http_get(addr: SocketAddr, path: &str) -> (u16, String) {
    let mut stream = TcpStream::connect_timeout(&addr, Duration::from_secs(10)).expect("connects");
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .expect("timeout");
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .expect("request sent");
    let mut answer = String::new();
    stream.read_to_string(&mut answer).expect("answer");
    status_and_body(&answer)
}

/// The status code and body of a raw HTTP/1.1 answer (status 0 when there is none).
fn status_and_body(answer: &str) -> (u16, String) {
    let status = answer
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let body = answer
        .split_once("\r\n\r\n")
        .map_or(String::new(), |(_, b)| b.to_string());
    (status, body)
}

/// `POST path` with a `Content-Type` and body over a fresh connection; the status code and
/// body. A server may answer before it has read the whole body: the answer is read anyway.
fn http_post(addr: SocketAddr, path: &str, content_type: &str, body: &[u8]) -> (u16, String) {
    let mut stream = TcpStream::connect_timeout(&addr, Duration::from_secs(10)).expect("connects");
    stream
        .set_read_timeout(Some(Duration::from_secs(120)))
        .expect("timeout");
    let head = format!(
        "POST {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\n\r\n",
        body.len()
    );
    let _ = stream
        .write_all(head.as_bytes())
        .and_then(|()| stream.write_all(body));
    let mut answer = Vec::new();
    let _ = stream.read_to_end(&mut answer);
    let answer = String::from_utf8_lossy(&answer).into_owned();
    status_and_body(&answer)
}

/// A process's resident memory and its peak (`VmRSS`, `VmHWM`), in bytes.
fn resident_memory(pid: u32) -> (u64, u64) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("/proc status");
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map_or(0, |kb| kb * 1024)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

/// Sends SIGTERM and waits for the exit status (killed outright after 30 s).
fn terminate(mut child: Child) -> Option<i32> {
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(30) {
        if let Ok(Some(status)) = child.try_wait() {
            return status.code();
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

#[test]
fn serve_prints_its_address_answers_and_stops_on_sigterm() {
    let (child, addr, first) = start(&[]);
    assert!(addr.ip().is_loopback(), "127.0.0.1 by default: {first}");
    assert_ne!(addr.port(), 0);
    let (status, body) = http_get(addr, "/api/characters");
    let (traversal, _) = http_get(addr, "/app/../../Cargo.toml");
    let (after, _) = http_get(addr, "/api/characters/c0");
    let code = terminate(child);
    assert_eq!(status, 200, "{body}");
    assert!(body.contains("\"humanoid\""), "{body}");
    assert_eq!(traversal, 404);
    assert_eq!(after, 200);
    assert_eq!(code, Some(0), "a clean stop on SIGTERM");
}

#[test]
fn serve_stops_cleanly_on_a_sigterm_sent_as_soon_as_the_address_is_read() {
    // The handlers are installed before the address is printed: no window in which SIGTERM
    // kills the process outright.
    for _ in 0..3 {
        let (child, _, _) = start(&[]);
        assert_eq!(
            terminate(child),
            Some(0),
            "a clean stop on an early SIGTERM"
        );
    }
}

#[test]
fn serve_loads_the_rig_given_as_c0() {
    let rig = data("cmu/01_01.bvh");
    let (child, addr, _) = start(&[rig.to_str().expect("path")]);
    let (status, body) = http_get(addr, "/api/characters/c0");
    terminate(child);
    assert_eq!(status, 200);
    assert!(body.contains("\"name\":\"01_01\""), "{body}");
    assert!(body.contains("\"format\":\"bvh\""), "{body}");
}

#[test]
fn serve_on_a_loopback_host_name_gives_no_warning() {
    let (mut child, addr, _) = start(&["--host", "localhost"]);
    assert!(addr.ip().is_loopback());
    let (status, _) = http_get(addr, "/api/characters");
    let mut stderr = child.stderr.take().expect("stderr");
    assert_eq!(terminate(child), Some(0));
    let mut err = String::new();
    stderr.read_to_string(&mut err).expect("stderr");
    assert_eq!(status, 200);
    assert!(!err.contains("warning"), "{err}");
}

#[test]
fn serve_with_a_bad_rig_is_one_line_and_exit_2() {
    let missing = std::path::Path::new("/nonexistent.glb");
    let o = rigfit(&["serve", "/nonexistent.glb", "--port", "0"]);
    assert_bad_input(&o, missing);
    assert!(o.stdout.is_empty(), "nothing served");
    let bad = common::malformed_dir().join("glb_truncated.glb");
    let o = rigfit(&["serve", bad.to_str().expect("path"), "--port", "0"]);
    assert_bad_input(&o, &bad);
    let o = rigfit(&["serve", "notes.txt", "--port", "0"]);
    assert_bad_input(&o, std::path::Path::new("notes.txt"));
}

/// A solve that runs for many seconds on [`rigs::tree_bvh`]'s rig (50 chains of 20 joints): 200 strokes of varied lengths.
fn heavy_solve(seed: usize) -> String {
    let strokes: Vec<String> = (0..200)
        .map(|s| {
            let a = s as f64 * 0.61 + seed as f64 * 0.1;
            let length = 0.3 + 0.07 * ((s * 7) % 10) as f64;
            let points: Vec<String> = (0..250)
                .map(|k| {
                    let t = 1.05 * length * k as f64 / 250.0;
                    format!("[{}, {}, {}]", 0.5 * a.cos() * t, t, 0.5 * a.sin() * t)
                })
                .collect();
            format!("{{\"points\": [{}]}}", points.join(", "))
        })
        .collect();
    format!("{{\"strokes\": [{}]}}", strokes.join(", "))
}

#[test]
fn sigterm_with_solves_under_way_exits_within_5_s() {
    let (child, addr, _) = start(&[]);
    let (status, body) = http_post(
        addr,
        "/api/characters?name=tree.bvh",
        "application/octet-stream",
        rigs::tree_bvh(50, 20).as_bytes(),
    );
    assert_eq!(status, 201, "{body}");
    // Three solves (more than the workers of a small machine), their clients waiting.
    let clients: Vec<TcpStream> = (0..3)
        .map(|i| {
            let body = heavy_solve(i);
            let mut stream =
                TcpStream::connect_timeout(&addr, Duration::from_secs(10)).expect("connects");
            write!(
                stream,
                "POST /api/characters/c1/solve HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
                body.len()
            )
            .expect("sent");
            stream
        })
        .collect();
    std::thread::sleep(Duration::from_millis(1000));
    let t0 = Instant::now();
    let code = terminate(child);
    let took = t0.elapsed();
    println!("SIGTERM with 3 solves under way: exited in {took:?} with {code:?}");
    assert_eq!(code, Some(0));
    assert!(took < Duration::from_secs(5), "{took:?}");
    drop(clients);
}

#[test]
fn resident_memory_stays_within_the_budget_however_many_uploads() {
    const MIB: u64 = 1 << 20;
    let budget_mib = 256;
    let (child, addr, _) = start(&["--memory-budget", &budget_mib.to_string()]);
    let pid = child.id();
    let (base, _) = resident_memory(pid);
    let bvh = rigs::long_bvh(460_000); // 8 MiB
    let upload = || {
        http_post(
            addr,
            "/api/characters?name=long.bvh",
            "application/octet-stream",
            &bvh,
        )
    };
    let mut stored = Vec::new();
    let mut refused = 0;
    for _ in 0..8 {
        let (status, body) = upload();
        match status {
            201 => stored.push(body),
            507 => refused += 1,
            _ => panic!("{status}: {body}"),
        }
    }
    let (rss, peak) = resident_memory(pid);
    println!(
        "8 uploads of {:.1} MiB with a {budget_mib} MiB budget: {} stored, {refused} refused (507); resident {} MiB, peak {} MiB (at start {} MiB)",
        bvh.len() as f64 / MIB as f64,
        stored.len(),
        rss / MIB,
        peak / MIB,
        base / MIB
    );
    assert!(!stored.is_empty() && refused > 0);
    let limit = budget_mib * MIB + base + 64 * MIB;
    assert!(peak < limit, "peak {} MiB", peak / MIB);
    // Deleting frees the budget; the memory is reused by the next uploads.
    let ids: Vec<String> = stored
        .iter()
        .filter_map(|b| {
            b.split("\"id\":\"")
                .nth(1)
                .and_then(|r| r.split('"').next())
                .map(str::to_string)
        })
        .collect();
    for id in &ids {
        let mut stream =
            TcpStream::connect_timeout(&addr, Duration::from_secs(10)).expect("connects");
        write!(
            stream,
            "DELETE /api/characters/{id} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
        )
        .expect("sent");
        let mut answer = String::new();
        stream.read_to_string(&mut answer).expect("answer");
        assert!(answer.starts_with("HTTP/1.1 204"), "{answer}");
    }
    let (after_delete, _) = resident_memory(pid);
    let again = (0..8).filter(|_| upload().0 == 201).count();
    let (rss, peak) = resident_memory(pid);
    println!(
        "after deleting {}: resident {} MiB; 8 more uploads: {again} stored, resident {} MiB, peak {} MiB",
        ids.len(),
        after_delete / MIB,
        rss / MIB,
        peak / MIB
    );
    assert_eq!(again, stored.len());
    assert!(peak < limit, "peak {} MiB", peak / MIB);
    assert_eq!(terminate(child), Some(0));
}

#[test]
fn three_hundred_idle_connections_do_not_starve_a_server_with_256_files() {
    // As the issue found it: a process allowed 256 open files, 300 connections that send
    // nothing or half a request head.
    let mut command = Command::new("sh");
    command.args([
        "-c",
        &format!(
            "ulimit -n 256 && exec {} serve --port 0",
            env!("CARGO_BIN_EXE_rigfit")
        ),
    ]);
    let (child, addr, _) = start_command(command);
    let held: Vec<TcpStream> = (0..300)
        .map(|i| {
            let mut stream =
                TcpStream::connect_timeout(&addr, Duration::from_secs(10)).expect("connects");
            if i % 2 == 1 {
                write!(stream, "GET /api/characters HTTP/1.1\r\nHost: {addr}\r\n").expect("sent");
            }
            stream
        })
        .collect();
    let t0 = Instant::now();
    let (status, body) = http_get(addr, "/api/characters");
    let waited = t0.elapsed();
    println!(
        "ulimit -n 256, 300 idle or partial connections: a new request answered in {waited:?}"
    );
    assert_eq!(status, 200, "{body}");
    assert!(waited < Duration::from_secs(5), "{waited:?}");
    assert_eq!(terminate(child), Some(0));
    drop(held);
}
