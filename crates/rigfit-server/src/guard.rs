//! Who may drive the server (docs/serve-api.md, "Who may call"): the `Host` a request is
//! addressed to (a loopback name while the server listens on loopback only: no DNS
//! rebinding), the `Origin` of a browser's request (only the server's own page: no other
//! web page can drive the local server), the `Content-Type` of request bodies (types a
//! browser may not send cross-site without asking first), and the headers every answer
//! carries (`nosniff`, the page's Content-Security-Policy, no framing).

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};

use axum::extract::{Request, State};
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use crate::AppState;
use crate::error::ApiError;

/// The host part of an authority (`Host` header, or an origin without its scheme).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HostName {
    Ip(IpAddr),
    /// A DNS name, lower-case, without a trailing dot.
    Name(String),
}

/// An authority `host[:port]` (RFC 3986 3.2.2-3.2.3, no user information).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Authority {
    pub host: HostName,
    pub port: Option<u16>,
}

/// A port: 1 to 5 digits.
fn parse_port(text: &str) -> Option<u16> {
    if text.is_empty() || text.len() > 5 || !text.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

/// Parses `host[:port]`: an IPv6 literal in brackets followed by nothing or `:PORT`, a
/// dotted IPv4 address, or a DNS name of letters, digits, `-`, `_` and `.`. Anything else
/// (`[::1]evil.com`, `a@b`, `host:port:port`, spaces) is `None`.
pub fn parse_authority(text: &str) -> Option<Authority> {
    if text.is_empty() || text.len() > 300 {
        return None;
    }
    if let Some(rest) = text.strip_prefix('[') {
        let (inside, after) = rest.split_once(']')?;
        let ip: Ipv6Addr = inside.parse().ok()?;
        let port = match after {
            "" => None,
            _ => Some(parse_port(after.strip_prefix(':')?)?),
        };
        return Some(Authority {
            host: HostName::Ip(IpAddr::V6(ip)),
            port,
        });
    }
    let (name, port) = match text.split_once(':') {
        Some((name, port)) => (name, Some(parse_port(port)?)),
        None => (text, None),
    };
    let name = name.strip_suffix('.').unwrap_or(name);
    if name.is_empty()
        || !name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.'))
        || name.split('.').any(str::is_empty)
    {
        return None;
    }
    let host = match name.parse::<Ipv4Addr>() {
        Ok(ip) => HostName::Ip(IpAddr::V4(ip)),
        Err(_) => HostName::Name(name.to_ascii_lowercase()),
    };
    Some(Authority { host, port })
}

impl Authority {
    /// True for a name of this machine: `localhost`, `*.localhost`, 127.x.x.x, `[::1]`.
    pub fn is_loopback(&self) -> bool {
        match &self.host {
            HostName::Ip(ip) => ip.is_loopback(),
            HostName::Name(name) => name == "localhost" || name.ends_with(".localhost"),
        }
    }
}

/// True for a `Host` header naming this machine by a loopback name.
pub fn is_loopback_host(host: &str) -> bool {
    parse_authority(host).is_some_and(|a| a.is_loopback())
}

/// The authority of an `Origin` header (`http://host[:port]` or `https://...`), with the
/// scheme's default port filled in. `None` for `null` or anything malformed.
fn origin_authority(origin: &str) -> Option<(Authority, u16)> {
    let (rest, default_port) = if let Some(rest) = origin.strip_prefix("http://") {
        (rest, 80)
    } else if let Some(rest) = origin.strip_prefix("https://") {
        (rest, 443)
    } else {
        return None;
    };
    let authority = parse_authority(rest)?;
    let port = authority.port.unwrap_or(default_port);
    Some((authority, port))
}

/// True when `origin` is the origin of the page the server serves at `host` (the same host
/// and port: the page's own requests).
pub fn is_own_origin(origin: &str, host: &str) -> bool {
    let Some(host) = parse_authority(host) else {
        return false;
    };
    let Some((origin, origin_port)) = origin_authority(origin) else {
        return false;
    };
    origin.host == host.host && origin_port == host.port.unwrap_or(80)
}

/// Middleware: the `Host` and `Origin` checks. While the server listens on loopback only, a
/// request whose `Host` is not a loopback name gets 403; a request with an `Origin` header
/// that is not the server's own (another site's page, `null`) gets 403. Requests without
/// `Origin` (curl, scripts; browsers' own same-origin page loads) go on.
pub async fn callers(State(state): State<AppState>, request: Request, next: Next) -> Response {
    if let Err(e) = check_caller(request.headers(), state.config().loopback_only) {
        return e.into_response();
    }
    next.run(request).await
}

fn check_caller(headers: &HeaderMap, loopback_only: bool) -> Result<(), ApiError> {
    let host = headers
        .get(header::HOST)
        .map(|h| String::from_utf8_lossy(h.as_bytes()).into_owned());
    if let Some(host) = &host {
        let authority = parse_authority(host);
        if loopback_only && !authority.as_ref().is_some_and(Authority::is_loopback) {
            return Err(ApiError::new(
                StatusCode::FORBIDDEN,
                format!(
                    "Host '{host}': this server answers only to localhost (start it with --host to serve other names)"
                ),
            ));
        }
        if authority.is_none() {
            return Err(ApiError::bad_request(format!(
                "Host '{host}': not a host name with an optional port"
            )));
        }
    }
    if let Some(origin) = headers.get(header::ORIGIN) {
        let origin = String::from_utf8_lossy(origin.as_bytes());
        let own = host.as_deref().is_some_and(|h| is_own_origin(&origin, h));
        if !own {
            return Err(ApiError::new(
                StatusCode::FORBIDDEN,
                format!(
                    "Origin '{origin}': only the server's own page may send requests (cross-site requests are refused)"
                ),
            ));
        }
    }
    Ok(())
}

/// The media type of a request (`application/json` from `application/json; charset=utf-8`),
/// lower-case; `None` when absent.
fn media_type(headers: &HeaderMap) -> Option<String> {
    let value = headers.get(header::CONTENT_TYPE)?;
    let text = String::from_utf8_lossy(value.as_bytes());
    Some(
        text.split(';')
            .next()
            .unwrap_or("")
            .trim()
            .to_ascii_lowercase(),
    )
}

/// The types a solve or export body may have.
pub const JSON_TYPES: &[&str] = &["application/json"];
/// The types an upload may have: the file's own (`model/gltf-binary`, `model/gltf+json`),
/// JSON, or plain bytes. None is one a browser sends cross-site without a preflight.
pub const UPLOAD_TYPES: &[&str] = &[
    "application/octet-stream",
    "model/gltf-binary",
    "model/gltf+json",
    "application/json",
];

/// 415 unless the request's `Content-Type` is one of `accepted` (parameters such as
/// `charset` allowed). A missing type is refused too: with one of these types a browser must
/// ask the server (a preflight, which it refuses) before sending from another site.
pub fn require_content_type(
    headers: &HeaderMap,
    what: &str,
    accepted: &[&str],
) -> Result<(), ApiError> {
    let found = media_type(headers);
    if found.as_deref().is_some_and(|t| accepted.contains(&t)) {
        return Ok(());
    }
    let found = match &found {
        Some(t) => format!("'{t}'"),
        None => "none".to_string(),
    };
    Err(ApiError::new(
        StatusCode::UNSUPPORTED_MEDIA_TYPE,
        format!(
            "{what}: Content-Type {found}: expected {}",
            accepted.join(" or ")
        ),
    ))
}

/// Middleware (for `map_response`): the headers every answer carries. `nosniff`; no framing
/// by any page (`frame-ancestors 'none'`, `X-Frame-Options`); no use of the answers by other
/// sites' pages (`Cross-Origin-Resource-Policy`); no referrer; and the page's
/// Content-Security-Policy (scripts, styles and data from the server itself only).
pub async fn security_headers(mut response: Response) -> Response {
    let headers = response.headers_mut();
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    headers.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    headers.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    headers.insert(
        "cross-origin-resource-policy",
        HeaderValue::from_static("same-origin"),
    );
    if let Ok(csp) = HeaderValue::from_str(crate::assets::content_security_policy()) {
        headers.insert(header::CONTENT_SECURITY_POLICY, csp);
    }
    response
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_host_names() {
        for host in [
            "localhost",
            "localhost:8717",
            "LOCALHOST.:8717",
            "127.0.0.1:8717",
            "127.1.2.3",
            "[::1]:80",
            "[::1]",
            "app.localhost:1",
        ] {
            assert!(is_loopback_host(host), "{host}");
        }
        for host in [
            "evil.example:8717",
            "10.0.0.1",
            "0.0.0.0:8717",
            "",
            "[::]:1",
            "[::1]evil.com",
            "[::1]evil.com:8717",
            "[::1]:8717evil",
            "[::1]:",
            "localhost:",
            "localhost:8717:1",
            "localhost:99999",
            "evil.com@localhost",
            "localhost@evil.com",
            "localhost evil.com",
            "127.0.0.1.evil.com",
            "localhost..",
            "[127.0.0.1]",
            "[::1",
        ] {
            assert!(!is_loopback_host(host), "{host}");
        }
    }

    #[test]
    fn own_origins() {
        assert!(is_own_origin("http://127.0.0.1:8717", "127.0.0.1:8717"));
        assert!(is_own_origin("http://localhost:8717", "LocalHost:8717"));
        assert!(is_own_origin("http://[::1]:8717", "[::1]:8717"));
        assert!(is_own_origin("http://localhost", "localhost:80"));
        for (origin, host) in [
            ("http://evil.com", "127.0.0.1:8717"),
            ("http://127.0.0.1:8718", "127.0.0.1:8717"),
            ("http://localhost:8717", "127.0.0.1:8717"),
            ("null", "127.0.0.1:8717"),
            ("http://127.0.0.1:8717/", "127.0.0.1:8717"),
            ("file://", "127.0.0.1:8717"),
            ("http://[::1]evil.com:8717", "[::1]:8717"),
            ("", "127.0.0.1:8717"),
        ] {
            assert!(!is_own_origin(origin, host), "{origin} {host}");
        }
    }

    #[test]
    fn content_types() {
        let mut headers = HeaderMap::new();
        assert!(require_content_type(&headers, "x", JSON_TYPES).is_err());
        for (value, ok) in [
            ("application/json", true),
            ("Application/JSON; charset=utf-8", true),
            ("text/plain", false),
            ("application/x-www-form-urlencoded", false),
            ("multipart/form-data; boundary=x", false),
        ] {
            headers.insert(header::CONTENT_TYPE, HeaderValue::from_static(value));
            assert_eq!(
                require_content_type(&headers, "x", JSON_TYPES).is_ok(),
                ok,
                "{value}"
            );
        }
        let error =
            require_content_type(&headers, "solve request", JSON_TYPES).expect_err("form data");
        assert_eq!(error.status, StatusCode::UNSUPPORTED_MEDIA_TYPE);
        assert!(error.message.starts_with("solve request: Content-Type"));
    }
}
