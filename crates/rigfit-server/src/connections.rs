//! The connection loop of [`crate::serve`]: hyper's HTTP/1 server on each accepted
//! connection, with the bounds a local server needs to shed work (docs/serve-api.md,
//! "Limits and timeouts"):
//! - at most `max_connections` connections at once (below the process's file limit); at
//!   the cap, a new connection makes the connections with no request under way close (idle
//!   keep-alive connections, partial request heads), else it waits for one to end;
//! - a header timeout: a connection that does not send a whole request head in time (idle
//!   keep-alive connections included) is closed;
//! - a send timeout: a connection whose client stops reading the answer is closed;
//! - shutdown: the listener closes at once, idle connections close, requests under way get
//!   `shutdown_grace` to finish; then their connections are dropped, which cancels their
//!   solves (see `api::run_blocking`).
//!
//! hyper answers some malformed requests itself (400, 414, 431) with an empty body, below
//! the router's layers; `Guarded` gives those answers the API's `{"error": ...}` shape.

use std::future::Future;
use std::io;
use std::pin::{Pin, pin};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::task::{Context, Poll, ready};
use std::time::Duration;

use axum::Router;
use hyper::body::Incoming;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{Notify, OwnedSemaphorePermit, Semaphore, watch};
use tokio::task::JoinSet;
use tokio::time::{Instant, Sleep};
use tower::ServiceExt as _;

use crate::ServerConfig;

/// Serves `app` on `listener` until `shutdown` completes, then shuts down within
/// `config.shutdown_grace` (plus the moment aborted connections take to drop).
pub(crate) async fn run(
    listener: TcpListener,
    app: Router,
    config: &ServerConfig,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> io::Result<()> {
    let slots = Arc::new(Semaphore::new(config.max_connections.max(1)));
    let pressure = Arc::new(Notify::new());
    let (closing_tx, closing_rx) = watch::channel(false);
    let mut connections = JoinSet::new();
    let mut shutdown = pin!(shutdown);
    loop {
        let stream = tokio::select! {
            () = shutdown.as_mut() => break,
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    // Out of file descriptors, or a connection reset before it was taken:
                    // wait a moment rather than spin.
                    tracing::warn!("accepting a connection: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
        };
        let slot = tokio::select! {
            () = shutdown.as_mut() => break,
            slot = free_slot(&slots, &pressure) => match slot {
                Some(slot) => slot,
                None => break,
            },
        };
        while connections.try_join_next().is_some() {}
        // Small answers go out at once (no Nagle delay).
        let _ = stream.set_nodelay(true);
        connections.spawn(connection(
            stream,
            app.clone(),
            config.clone(),
            closing_rx.clone(),
            Arc::clone(&pressure),
            slot,
        ));
    }
    // The port closes now; then every connection is told to finish.
    drop(listener);
    let _ = closing_tx.send(true);
    let drained = tokio::time::timeout(config.shutdown_grace, async {
        while connections.join_next().await.is_some() {}
    })
    .await;
    if drained.is_err() {
        tracing::warn!(
            "{} connections still busy after {:.1} s: closing them (their solves are cancelled)",
            connections.len(),
            config.shutdown_grace.as_secs_f64()
        );
        connections.abort_all();
        while connections.join_next().await.is_some() {}
    }
    Ok(())
}

/// A connection slot for a connection just accepted. At the cap, the connections with no
/// request under way (idle keep-alive connections, partial request heads) are asked to close,
/// every 100 ms until a slot frees; connections whose requests are under way keep theirs (a
/// partial body ends at the body timeout).
async fn free_slot(slots: &Arc<Semaphore>, pressure: &Notify) -> Option<OwnedSemaphorePermit> {
    loop {
        if let Ok(slot) = Arc::clone(slots).try_acquire_owned() {
            return Some(slot);
        }
        pressure.notify_waiters();
        let wait = Arc::clone(slots).acquire_owned();
        match tokio::time::timeout(Duration::from_millis(100), wait).await {
            Ok(slot) => return slot.ok(),
            Err(_) => continue,
        }
    }
}

/// Counts a connection's requests under way (from the head read to the answer made).
#[derive(Debug)]
struct InFlight(Arc<AtomicUsize>);

impl InFlight {
    fn enter(count: &Arc<AtomicUsize>) -> Self {
        count.fetch_add(1, Ordering::Relaxed);
        Self(Arc::clone(count))
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// One connection: hyper's HTTP/1 server with the header timeout, until it closes, times
/// out, is asked to make room while it has no request under way, or the server shuts down
/// (then it finishes the request under way, if any).
async fn connection(
    stream: TcpStream,
    app: Router,
    config: ServerConfig,
    mut closing: watch::Receiver<bool>,
    pressure: Arc<Notify>,
    _slot: OwnedSemaphorePermit,
) {
    let in_flight = Arc::new(AtomicUsize::new(0));
    let counted = Arc::clone(&in_flight);
    let service = tower::service_fn(move |request: axum::extract::Request<Incoming>| {
        let entered = InFlight::enter(&counted);
        let app = app.clone();
        async move {
            let response = app.oneshot(request).await;
            drop(entered);
            response
        }
    });
    let io = TokioIo::new(Guarded::new(stream, config.send_timeout));
    let mut builder = http1::Builder::new();
    builder
        .timer(TokioTimer::new())
        .header_read_timeout(config.header_timeout)
        .keep_alive(true);
    let mut conn = pin!(builder.serve_connection(io, TowerToHyperService::new(service)));
    let closed = async move {
        // The watch's guard must not live across an await: only whether it fired is kept.
        let _ = closing.wait_for(|closing| *closing).await.is_ok();
    };
    let mut closed = pin!(closed);
    let result = loop {
        tokio::select! {
            result = conn.as_mut() => break result,
            () = closed.as_mut() => {
                conn.as_mut().graceful_shutdown();
                break conn.await;
            }
            () = pressure.notified() => {
                if in_flight.load(Ordering::Relaxed) == 0 {
                    tracing::debug!("closing a connection with no request under way: at the cap");
                    return;
                }
            }
        }
    };
    if let Err(e) = result {
        tracing::debug!("connection closed: {e}");
    }
}

/// A connection's stream, with a send timeout and hyper's own error answers reshaped.
#[derive(Debug)]
pub(crate) struct Guarded {
    stream: TcpStream,
    /// A reshaped answer not yet (all) written, and how much of it was.
    pending: Vec<u8>,
    pending_written: usize,
    /// Fires when a write has waited `send_timeout` for the client to read.
    stall: Pin<Box<Sleep>>,
    stall_armed: bool,
    send_timeout: Duration,
}

impl Guarded {
    fn new(stream: TcpStream, send_timeout: Duration) -> Self {
        Self {
            stream,
            pending: Vec::new(),
            pending_written: 0,
            stall: Box::pin(tokio::time::sleep(send_timeout)),
            stall_armed: false,
            send_timeout,
        }
    }

    /// `poll` (a write or flush of the stream), failing once the client has not read for
    /// `send_timeout`.
    fn watch_stall<T>(
        &mut self,
        cx: &mut Context<'_>,
        poll: Poll<io::Result<T>>,
    ) -> Poll<io::Result<T>> {
        match poll {
            Poll::Ready(result) => {
                self.stall_armed = false;
                Poll::Ready(result)
            }
            Poll::Pending => {
                if !self.stall_armed {
                    let deadline = Instant::now() + self.send_timeout;
                    self.stall.as_mut().reset(deadline);
                    self.stall_armed = true;
                }
                if self.stall.as_mut().poll(cx).is_ready() {
                    Poll::Ready(Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        "the client stopped reading the answer",
                    )))
                } else {
                    Poll::Pending
                }
            }
        }
    }

    /// Writes what is left of a reshaped answer.
    fn poll_pending(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        while self.pending_written < self.pending.len() {
            let poll =
                Pin::new(&mut self.stream).poll_write(cx, &self.pending[self.pending_written..]);
            let n = ready!(self.watch_stall(cx, poll))?;
            if n == 0 {
                return Poll::Ready(Err(io::ErrorKind::WriteZero.into()));
            }
            self.pending_written += n;
        }
        self.pending.clear();
        self.pending_written = 0;
        Poll::Ready(Ok(()))
    }
}

/// hyper's own answer to a request it could not parse (status 400, 414 or 431, written as a
/// lone head with `content-length: 0`: every error answer of the router has a JSON body),
/// as the API's `{"error": ...}` answer. `None` for any other write.
fn reshaped_error_answer(written: &[u8]) -> Option<Vec<u8>> {
    let head = std::str::from_utf8(written).ok()?;
    let rest = head.strip_prefix("HTTP/1.1 ")?;
    let code: u16 = rest.get(..3)?.parse().ok()?;
    if !(400..600).contains(&code) || head.find("\r\n\r\n")? + 4 != head.len() {
        return None;
    }
    let mut lines = head[..head.len() - 4].split("\r\n");
    let status_line = lines.next()?;
    let headers: Vec<&str> = lines.collect();
    if !headers
        .iter()
        .any(|h| h.eq_ignore_ascii_case("content-length: 0"))
    {
        return None;
    }
    let message = match code {
        431 => "request header fields too large",
        414 => "request URI too long",
        _ => "malformed HTTP request (the request line or a header could not be read)",
    };
    let body = serde_json::json!({ "error": message }).to_string();
    let mut answer = format!("{status_line}\r\n");
    for header in headers {
        if !header.to_ascii_lowercase().starts_with("content-length:") {
            answer.push_str(header);
            answer.push_str("\r\n");
        }
    }
    answer.push_str(&format!(
        "content-type: application/json\r\nx-content-type-options: nosniff\r\ncontent-length: {}\r\n\r\n{body}",
        body.len()
    ));
    Some(answer.into_bytes())
}

impl AsyncRead for Guarded {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().stream).poll_read(cx, buf)
    }
}

impl AsyncWrite for Guarded {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        ready!(this.poll_pending(cx))?;
        if let Some(answer) = reshaped_error_answer(buf) {
            this.pending = answer;
            this.pending_written = 0;
            // Written now if the socket takes it, else by the flush hyper does next.
            if let Poll::Ready(Err(e)) = this.poll_pending(cx) {
                return Poll::Ready(Err(e));
            }
            return Poll::Ready(Ok(buf.len()));
        }
        let poll = Pin::new(&mut this.stream).poll_write(cx, buf);
        this.watch_stall(cx, poll)
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        ready!(this.poll_pending(cx))?;
        let poll = Pin::new(&mut this.stream).poll_flush(cx);
        this.watch_stall(cx, poll)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        ready!(this.poll_pending(cx))?;
        Pin::new(&mut this.stream).poll_shutdown(cx)
    }
}

/// The soft limit on open files of this process (Linux: /proc/self/limits), if known.
pub fn open_file_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with("Max open files"))?;
    let soft = line.split_whitespace().nth(3)?;
    soft.parse().ok()
}

/// The default connection cap: 1024, or three quarters of the open-file limit when that is
/// lower (the rest for the listener, the runtime and the answers being written).
pub fn default_max_connections() -> usize {
    let cap = 1024;
    match open_file_limit() {
        Some(files) => ((files.saturating_mul(3) / 4) as usize).clamp(8, cap),
        None => 256,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hypers_own_error_answers_get_a_json_body() {
        let head = b"HTTP/1.1 431 Request Header Fields Too Large\r\ncontent-length: 0\r\ndate: Tue, 24 Nov 2026 21:00:00 GMT\r\n\r\n";
        let answer =
            String::from_utf8(reshaped_error_answer(head).expect("reshaped")).expect("text");
        let (head, body) = answer.split_once("\r\n\r\n").expect("head and body");
        assert!(head.starts_with("HTTP/1.1 431 "));
        assert!(head.contains("\r\ndate: "));
        assert!(head.contains(&format!("content-length: {}", body.len())));
        assert!(!head.contains("content-length: 0"));
        assert!(head.contains("content-type: application/json"));
        let value: serde_json::Value = serde_json::from_str(body).expect("JSON");
        assert_eq!(value["error"], "request header fields too large");
        // The router's answers (with their bodies), and bodies, go through unchanged.
        for other in [
            &b"HTTP/1.1 400 Bad Request\r\ncontent-type: application/json\r\ncontent-length: 20\r\n\r\n"[..],
            b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\n{}",
            b"HTTP/1.1 200 OK\r\ncontent-length: 0\r\n\r\n",
            b"HTTP/1.1 204 No Content\r\n\r\n",
            b"{\"error\": \"x\"}",
        ] {
            assert!(reshaped_error_answer(other).is_none());
        }
    }

    #[test]
    fn the_connection_cap_stays_under_the_file_limit() {
        let cap = default_max_connections();
        assert!((8..=1024).contains(&cap));
        if let Some(files) = open_file_limit() {
            assert!(cap as u64 <= files.max(8));
        }
    }
}
