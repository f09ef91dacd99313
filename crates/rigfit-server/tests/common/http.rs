//! A tiny blocking HTTP/1.1 client over `TcpStream` (one request per connection), enough to
//! drive a running server from tests and the load test without another dependency.

use std::io::{self, BufRead as _, BufReader, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::time::Duration;

/// An answer: status code, headers (names lower-case) and body.
#[derive(Debug, Clone)]
pub struct HttpAnswer {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl HttpAnswer {
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).into_owned()
    }
}

fn invalid(what: impl Into<String>) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, what.into())
}

/// Sends `method path` with `body` and reads the whole answer.
pub fn request(addr: SocketAddr, method: &str, path: &str, body: &[u8]) -> io::Result<HttpAnswer> {
    let mut stream = connect(addr)?;
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: {}\r\nContent-Length: {}\r\n\r\n",
        super::content_type_for(path),
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    // A server may answer (413, 507) before it has read the whole body and close: the
    // answer is read all the same.
    let _ = stream.write_all(body).and_then(|()| stream.flush());
    read_answer(&mut BufReader::new(stream))
}

/// Sends `bytes` as they are (a whole request, or a malformed one) and reads the answer.
pub fn raw(addr: SocketAddr, bytes: &[u8]) -> io::Result<HttpAnswer> {
    let mut stream = connect(addr)?;
    let _ = stream.write_all(bytes).and_then(|()| stream.flush());
    read_answer(&mut BufReader::new(stream))
}

/// Sends `method path` with `body` and the given extra header lines (`Name: value`, no
/// `Content-Type` unless given there) and reads the answer.
pub fn request_with(
    addr: SocketAddr,
    method: &str,
    path: &str,
    headers: &[&str],
    body: &[u8],
) -> io::Result<HttpAnswer> {
    let mut head = format!("{method} {path} HTTP/1.1\r\n");
    if !headers
        .iter()
        .any(|h| h.to_ascii_lowercase().starts_with("host:"))
    {
        head.push_str(&format!("Host: {addr}\r\n"));
    }
    for h in headers {
        head.push_str(h);
        head.push_str("\r\n");
    }
    head.push_str(&format!(
        "Connection: close\r\nContent-Length: {}\r\n\r\n",
        body.len()
    ));
    let mut bytes = head.into_bytes();
    bytes.extend_from_slice(body);
    raw(addr, &bytes)
}

/// Declares a body of `declared_length` bytes with `Expect: 100-continue` and sends nothing
/// unless the server asks for it (as curl does for large bodies): a server that refuses the
/// length answers at once. When the server asks, `filler` bytes are sent.
pub fn request_declaring(
    addr: SocketAddr,
    method: &str,
    path: &str,
    declared_length: usize,
) -> io::Result<HttpAnswer> {
    let stream = connect(addr)?;
    let mut writer = stream.try_clone()?;
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\nContent-Type: {}\r\nContent-Length: {declared_length}\r\nExpect: 100-continue\r\n\r\n",
        super::content_type_for(path)
    );
    writer.write_all(head.as_bytes())?;
    let mut reader = BufReader::new(stream);
    let answer = read_answer(&mut reader)?;
    if answer.status != 100 {
        return Ok(answer);
    }
    let chunk = vec![b' '; 1 << 16];
    let mut left = declared_length;
    while left > 0 {
        let n = left.min(chunk.len());
        if writer.write_all(&chunk[..n]).is_err() {
            break;
        }
        left -= n;
    }
    read_answer(&mut reader)
}

pub fn connect(addr: SocketAddr) -> io::Result<TcpStream> {
    let stream = TcpStream::connect_timeout(&addr, Duration::from_secs(10))?;
    stream.set_read_timeout(Some(Duration::from_secs(120)))?;
    stream.set_write_timeout(Some(Duration::from_secs(120)))?;
    Ok(stream)
}

/// Reads one answer: the status line, headers, and a body by `Content-Length`, chunked
/// encoding, or to the end of the connection (none for 1xx, 204 and 304).
fn read_answer(reader: &mut BufReader<TcpStream>) -> io::Result<HttpAnswer> {
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let status: u16 = line
        .split_whitespace()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| invalid(format!("bad status line '{}'", line.trim_end())))?;
    let mut headers = Vec::new();
    loop {
        line.clear();
        if reader.read_line(&mut line)? == 0 {
            return Err(invalid("the connection closed inside the headers"));
        }
        let trimmed = line.trim_end();
        if trimmed.is_empty() {
            break;
        }
        if let Some((name, value)) = trimmed.split_once(':') {
            headers.push((name.trim().to_ascii_lowercase(), value.trim().to_string()));
        }
    }
    let mut answer = HttpAnswer {
        status,
        headers,
        body: Vec::new(),
    };
    if (100..200).contains(&status) || status == 204 || status == 304 {
        return Ok(answer);
    }
    let length = answer
        .header("content-length")
        .and_then(|v| v.parse::<usize>().ok());
    let chunked = answer
        .header("transfer-encoding")
        .is_some_and(|v| v.eq_ignore_ascii_case("chunked"));
    if let Some(n) = length {
        answer.body = vec![0; n];
        reader.read_exact(&mut answer.body)?;
    } else if chunked {
        loop {
            line.clear();
            reader.read_line(&mut line)?;
            let size = usize::from_str_radix(line.trim().split(';').next().unwrap_or(""), 16)
                .map_err(|_| invalid("bad chunk size"))?;
            let mut chunk = vec![0; size + 2];
            reader.read_exact(&mut chunk)?;
            if size == 0 {
                break;
            }
            answer.body.extend_from_slice(&chunk[..size]);
        }
    } else {
        reader.read_to_end(&mut answer.body)?;
    }
    Ok(answer)
}
