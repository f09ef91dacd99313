//! The page's static files, embedded in the binary at build time (also in debug builds):
//! `web/index.html`, `web/app/**` and `web/vendor/**`. Nothing else is served and no request
//! path ever reaches the file system.

use axum::body::Body;
use axum::http::{HeaderValue, Method, StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};
use rust_embed::RustEmbed;

use crate::error::ApiError;

/// The embedded files of `web/` (paths relative to it, `/`-separated).
#[derive(RustEmbed)]
#[folder = "../../web/"]
#[include = "index.html"]
#[include = "app/**"]
#[include = "vendor/**"]
struct WebFiles;

impl std::fmt::Debug for WebFiles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("WebFiles")
    }
}

/// The paths of every embedded file (relative to `web/`).
pub fn embedded_paths() -> Vec<String> {
    WebFiles::iter().map(|p| p.into_owned()).collect()
}

/// The `sha256-...` source of every inline `<script>` of `html` (the page's import map), for
/// the Content-Security-Policy.
fn inline_script_hashes(html: &str) -> Vec<String> {
    use base64::Engine as _;
    use sha2::Digest as _;
    let mut hashes = Vec::new();
    let mut rest = html;
    while let Some(start) = rest.find("<script") {
        let tag_and_after = &rest[start..];
        let Some(tag_end) = tag_and_after.find('>') else {
            break;
        };
        let tag = &tag_and_after[..tag_end];
        let after = &tag_and_after[tag_end + 1..];
        let Some(close) = after.find("</script>") else {
            break;
        };
        if !tag.contains("src=") {
            let digest = sha2::Sha256::digest(&after.as_bytes()[..close]);
            let encoded = base64::engine::general_purpose::STANDARD.encode(digest);
            hashes.push(format!("'sha256-{encoded}'"));
        }
        rest = &after[close..];
    }
    hashes
}

/// The Content-Security-Policy every answer carries: the page's scripts, styles, models and
/// requests come from the server itself only (its inline import map allowed by hash; data:
/// and blob: URLs for the models three.js unpacks); no plug-ins, no `<base>`, no form
/// posts, no framing by any page.
pub fn content_security_policy() -> &'static str {
    static POLICY: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    POLICY.get_or_init(|| {
        let hashes = WebFiles::get("index.html")
            .map(|f| inline_script_hashes(&String::from_utf8_lossy(&f.data)))
            .unwrap_or_default();
        format!(
            "default-src 'self'; script-src 'self'{}; style-src 'self'; img-src 'self' data: blob:; \
             connect-src 'self' data: blob:; worker-src 'self' blob:; object-src 'none'; \
             base-uri 'none'; form-action 'none'; frame-ancestors 'none'",
            hashes
                .iter()
                .map(|h| format!(" {h}"))
                .collect::<String>()
        )
    })
}

/// The `Content-Type` of a file by its extension.
pub fn content_type(path: &str) -> &'static str {
    let ext = path.rsplit_once('.').map_or("", |(_, e)| e);
    match ext.to_ascii_lowercase().as_str() {
        "html" | "htm" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" | "map" => "application/json",
        "glb" => "model/gltf-binary",
        "gltf" => "model/gltf+json",
        "png" => "image/png",
        "jpg" | "jpeg" => "image/jpeg",
        "svg" => "image/svg+xml",
        "ico" => "image/x-icon",
        "wasm" => "application/wasm",
        "txt" | "md" => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

/// Decodes `%XX` escapes; `None` when an escape is malformed or the result is not UTF-8.
fn percent_decode(path: &str) -> Option<String> {
    let bytes = path.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3)?;
            let hex = std::str::from_utf8(hex).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The embedded file a URL path names: `/` and `/index.html` are `index.html`; `/app/...`
/// and `/vendor/...` are files under those folders. `None` for anything else, including any path with an
/// empty, `.` or `..` segment or a backslash (after decoding).
pub fn embedded_key(url_path: &str) -> Option<String> {
    if url_path == "/" {
        return Some("index.html".to_string());
    }
    let decoded = percent_decode(url_path)?;
    let rest = decoded.strip_prefix('/')?;
    let mut segments = rest.split('/');
    let top = segments.next()?;
    if rest == "index.html" {
        return Some(rest.to_string());
    }
    if !matches!(top, "app" | "vendor") {
        return None;
    }
    let clean = rest
        .split('/')
        .all(|s| !s.is_empty() && s != "." && s != ".." && !s.contains(['\\', '\0']));
    clean.then(|| rest.to_string())
}

/// The fallback of the router: embedded files for `GET`/`HEAD`, 404 for any other path.
pub async fn static_file(method: Method, uri: Uri) -> Response {
    let path = uri.path();
    let not_found = || ApiError::not_found(format!("{path}: not found")).into_response();
    let Some(key) = embedded_key(path) else {
        return not_found();
    };
    let Some(file) = WebFiles::get(&key) else {
        return not_found();
    };
    if method != Method::GET && method != Method::HEAD {
        let mut response =
            ApiError::new(StatusCode::METHOD_NOT_ALLOWED, format!("{path}: only GET"))
                .into_response();
        response
            .headers_mut()
            .insert(header::ALLOW, HeaderValue::from_static("GET, HEAD"));
        return response;
    }
    let body = if method == Method::HEAD {
        Body::empty()
    } else {
        Body::from(file.data.into_owned())
    };
    (
        [
            (header::CONTENT_TYPE, content_type(&key)),
            (header::CACHE_CONTROL, "no-cache"),
        ],
        body,
    )
        .into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_paths_under_app_and_vendor_name_files() {
        assert_eq!(embedded_key("/").as_deref(), Some("index.html"));
        assert_eq!(embedded_key("/app/main.js").as_deref(), Some("app/main.js"));
        assert_eq!(
            embedded_key("/vendor/three/build/three.module.js").as_deref(),
            Some("vendor/three/build/three.module.js")
        );
        for bad in [
            "/index.html/..",
            "/../Cargo.toml",
            "/app/../../etc/passwd",
            "/app/%2e%2e/%2e%2e/etc/passwd",
            "/app/%2E%2E%2Fx",
            "/app/a%5c..%5cb",
            "/app//x.js",
            "/app/./x.js",
            "/app/%zz",
            "/Cargo.toml",
            "/web/index.html",
            "/node_modules/x.js",
        ] {
            let key = embedded_key(bad);
            assert!(
                key.is_none() || WebFiles::get(key.as_deref().unwrap_or("")).is_none(),
                "{bad} -> {key:?}"
            );
        }
        assert_eq!(embedded_key("/app/%2e%2e/x"), None);
    }

    #[test]
    fn the_policy_allows_the_import_map_by_hash() {
        let html =
            "<script type=\"importmap\">{}</script><script type=\"module\" src=\"/a.js\"></script>";
        // echo -n '{}' | openssl dgst -sha256 -binary | base64
        assert_eq!(
            inline_script_hashes(html),
            ["'sha256-RBNvo1WzZ4oRRq0W9+hknpT7T8If536DEMBg9hyq/4o='"]
        );
        let policy = content_security_policy();
        assert!(policy.contains("frame-ancestors 'none'"), "{policy}");
        if WebFiles::get("index.html").is_some() {
            assert!(policy.contains("'sha256-"), "{policy}");
        }
    }

    #[test]
    fn content_types_by_extension() {
        assert_eq!(content_type("index.html"), "text/html; charset=utf-8");
        assert_eq!(
            content_type("app/main.js"),
            "text/javascript; charset=utf-8"
        );
        assert_eq!(content_type("a.mjs"), "text/javascript; charset=utf-8");
        assert_eq!(content_type("app/app.css"), "text/css; charset=utf-8");
        assert_eq!(content_type("x.json"), "application/json");
        assert_eq!(content_type("x.glb"), "model/gltf-binary");
        assert_eq!(content_type("x.PNG"), "image/png");
    }
}
