//! rigfit-server: `rigfit serve`, the sketching page's HTTP server. A thin shell over
//! rigfit-formats (the command line's readers and writers) and `rigfit_core::pose::solve_pose`;
//! the API is docs/serve-api.md.
//!
//! [`router`] builds the whole app as an `axum::Router` (tests drive it in-process);
//! [`serve`] runs it on a listener until a shutdown signal.

pub mod api;
pub mod assets;
pub mod characters;
pub mod error;
pub mod request;

use std::future::Future;
use std::path::Path;
use std::sync::Arc;

use axum::Router;
use axum::extract::{Request, State};
use axum::http::{StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use rigfit_formats::FormatError;
use rigfit_formats::rig_file::{RigFile, RigFormat, RigOptions, parse_rig};
use tokio::sync::Semaphore;
use tower_http::catch_panic::CatchPanicLayer;

pub use characters::{Character, CharacterStore, MAX_CHARACTERS};
pub use error::ApiError;

/// How the server runs.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// Answer only requests addressed to this machine by a loopback name (`Host:` localhost,
    /// 127.x.x.x or [::1]), so that a web page elsewhere cannot reach the server through a
    /// DNS name that points here. True unless the server listens on other addresses.
    pub loopback_only: bool,
    /// How many reads, solves and writes run at once (the rest queue).
    pub workers: usize,
}

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            loopback_only: true,
            workers: std::thread::available_parallelism().map_or(2, usize::from),
        }
    }
}

/// What every request shares: the characters and the worker slots.
#[derive(Debug, Clone)]
pub struct AppState {
    pub characters: Arc<CharacterStore>,
    workers: Arc<Semaphore>,
    loopback_only: bool,
}

impl AppState {
    /// A server state holding no character yet.
    pub fn new(config: &ServerConfig) -> Self {
        Self {
            characters: Arc::new(CharacterStore::new()),
            workers: Arc::new(Semaphore::new(config.workers.max(1))),
            loopback_only: config.loopback_only,
        }
    }

    /// Adds a character read from a file (`path` gives its name and format).
    pub fn add_rig_file(&self, path: &Path, rig_file: RigFile) -> Option<Arc<Character>> {
        let format = RigFormat::from_path(path).unwrap_or(RigFormat::Glb);
        self.characters
            .add(|id| Character::new(id, path, format, rig_file))
            .ok()
    }

    /// Adds the built-in humanoid (as the `.glb` `rigfit demo-rig` writes).
    pub fn add_humanoid(&self) -> Result<Arc<Character>, FormatError> {
        let rig_file = humanoid_rig_file()?;
        let name = Path::new("humanoid.glb");
        self.add_rig_file(name, rig_file).ok_or_else(|| {
            FormatError::parse(
                name,
                rigfit_formats::ParseError::new("", "the server holds no more characters"),
            )
        })
    }
}

/// The built-in humanoid read back from its `.glb`, so it is served like an uploaded file.
pub fn humanoid_rig_file() -> Result<RigFile, FormatError> {
    let bytes = rigfit_formats::gltf::rig_to_glb(&rigfit_core::humanoid::humanoid());
    parse_rig(&bytes, Path::new("humanoid.glb"), &RigOptions::default())
}

/// The whole app: the API routes, the page's files, and the layers that keep every answer
/// in shape (JSON errors, panics caught, the loopback check).
pub fn router(state: AppState) -> Router {
    let api = Router::new()
        .route(
            "/api/characters",
            get(api::list_characters).post(api::upload_character),
        )
        .route(
            "/api/characters/{id}",
            get(api::get_character).delete(api::delete_character),
        )
        .route("/api/characters/{id}/model.glb", get(api::model_glb))
        .route(
            "/api/characters/{id}/solve",
            axum::routing::post(api::solve),
        )
        .route(
            "/api/characters/{id}/export",
            axum::routing::post(api::export),
        )
        .fallback(assets::static_file)
        .with_state(state.clone());
    guarded(api).layer(middleware::from_fn_with_state(state, loopback_hosts_only))
}

/// `router` wrapped in the layers every answer goes through: a handler that panics answers
/// 500 (the server goes on), and every error answer is `{"error": ...}`.
pub fn guarded(router: Router) -> Router {
    router
        .layer(CatchPanicLayer::custom(error::panic_response))
        .layer(middleware::map_response(error::json_error_bodies))
}

/// True for a `Host` header naming this machine by a loopback name.
fn is_loopback_host(host: &str) -> bool {
    // Strip the port: "[::1]:8717", "127.0.0.1:8717", "localhost:8717".
    let name = if let Some(rest) = host.strip_prefix('[') {
        rest.split(']').next().unwrap_or("")
    } else {
        host.rsplit_once(':').map_or(host, |(name, _)| name)
    };
    let name = name.trim_end_matches('.').to_ascii_lowercase();
    name == "localhost"
        || name.ends_with(".localhost")
        || name
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Middleware: when the server listens on loopback only, a request whose `Host` names
/// another machine gets 403 (a DNS-rebinding page cannot drive the server).
async fn loopback_hosts_only(
    State(state): State<AppState>,
    request: Request,
    next: Next,
) -> Response {
    if state.loopback_only {
        if let Some(host) = request.headers().get(header::HOST) {
            let host = host.to_str().unwrap_or("");
            if !is_loopback_host(host) {
                return ApiError::new(
                    StatusCode::FORBIDDEN,
                    format!(
                        "Host '{host}': this server answers only to localhost (start it with --host to serve other names)"
                    ),
                )
                .into_response();
            }
        }
    }
    next.run(request).await
}

/// Serves the app on `listener` until `shutdown` completes, then finishes the requests under
/// way and returns.
pub async fn serve(
    listener: tokio::net::TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    axum::serve(listener, router(state))
        .with_graceful_shutdown(shutdown)
        .await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_host_names() {
        for host in [
            "localhost",
            "localhost:8717",
            "127.0.0.1:8717",
            "127.1.2.3",
            "[::1]:80",
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
        ] {
            assert!(!is_loopback_host(host), "{host}");
        }
    }
}
