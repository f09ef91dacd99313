//! `rigfit serve` as a process: it prints its address as the first line, answers on it, and
//! stops cleanly on SIGTERM; a bad RIG is one line and exit status 2 before listening.

mod common;

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{assert_bad_input, data, rigfit};

/// Starts `rigfit serve ARGS --port 0` and reads the address from its first line.
fn start(args: &[&str]) -> (Child, SocketAddr, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_rigfit"))
        .arg("serve")
        .args(args)
        .args(["--port", "0"])
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
