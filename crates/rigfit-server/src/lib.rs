//! rigfit-server: `rigfit serve`, the sketching page's HTTP server. A thin shell over
//! rigfit-formats (the command line's readers and writers) and `rigfit_core::pose::solve_pose`;
//! the API is docs/serve-api.md.
//!
//! [`router`] builds the whole app as an `axum::Router` (tests drive it in-process);
//! [`serve`] runs it on a listener until a shutdown signal.

pub mod api;
pub mod assets;
pub mod characters;
pub mod connections;
pub mod error;
pub mod guard;
pub mod memory;
pub mod request;

use std::future::Future;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::middleware;
use axum::routing::get;
use rigfit_formats::FormatError;
use rigfit_formats::rig_file::{RigFile, RigFormat, RigOptions, parse_rig};
use tokio::sync::Semaphore;
use tower_http::catch_panic::CatchPanicLayer;

pub use characters::{Character, CharacterStore, MAX_CHARACTERS};
pub use error::ApiError;

/// How the server runs: who it answers, how much work it takes on, and when it gives up
/// (docs/serve-api.md, "Limits and timeouts").
#[derive(Debug, Clone)]
pub struct ServerConfig {
    /// Answer only requests addressed to this machine by a loopback name (`Host:` localhost,
    /// 127.x.x.x or `[::1]`), so that a web page elsewhere cannot reach the server through a
    /// DNS name that points here. True unless the server listens on other addresses.
    pub loopback_only: bool,
    /// How many reads, solves and writes run at once (the rest queue).
    pub workers: usize,
    /// The longest a solve may run; past it the solve stops and the request gets 503.
    pub solve_timeout: Duration,
    /// The longest a connection may take to send a request's head (the request line and
    /// headers), counted from the end of the previous answer on a kept-alive connection.
    pub header_timeout: Duration,
    /// The longest a request's body may take to arrive (408 past it).
    pub body_timeout: Duration,
    /// The longest the server waits for a client to read an answer before closing.
    pub send_timeout: Duration,
    /// The most connections open at once; more wait to be accepted.
    pub max_connections: usize,
    /// The memory the characters may take, in bytes (estimated; see `memory`): an upload
    /// past it is refused (507) until characters are deleted.
    pub memory_budget: usize,
    /// On shutdown, how long requests under way may take to finish before their
    /// connections are closed and their solves cancelled.
    pub shutdown_grace: Duration,
}

/// The default memory budget of the characters: 1 GiB.
pub const DEFAULT_MEMORY_BUDGET: usize = 1 << 30;

impl Default for ServerConfig {
    fn default() -> Self {
        Self {
            loopback_only: true,
            workers: std::thread::available_parallelism().map_or(2, usize::from),
            solve_timeout: Duration::from_secs(30),
            header_timeout: Duration::from_secs(10),
            body_timeout: Duration::from_secs(60),
            send_timeout: Duration::from_secs(30),
            max_connections: connections::default_max_connections(),
            memory_budget: DEFAULT_MEMORY_BUDGET,
            shutdown_grace: Duration::from_secs(3),
        }
    }
}

/// What every request shares: the characters, the worker slots and the configuration.
#[derive(Debug, Clone)]
pub struct AppState {
    pub characters: Arc<CharacterStore>,
    workers: Arc<Semaphore>,
    config: Arc<ServerConfig>,
}

impl AppState {
    /// A server state holding no character yet.
    pub fn new(config: &ServerConfig) -> Self {
        Self {
            characters: Arc::new(CharacterStore::with_budget(config.memory_budget)),
            workers: Arc::new(Semaphore::new(config.workers.max(1))),
            config: Arc::new(config.clone()),
        }
    }

    /// The configuration the server runs with.
    pub fn config(&self) -> &ServerConfig {
        &self.config
    }

    /// How many jobs (reads, solves, writes) are running on the blocking pool now. A job
    /// whose request was cancelled counts until it has actually stopped.
    pub fn busy_workers(&self) -> usize {
        (self.config.workers.max(1)).saturating_sub(self.workers.available_permits())
    }

    /// Adds a character read from a file (`path` gives its name and format); it counts
    /// against the memory budget but is not refused by it.
    pub fn add_rig_file(&self, path: &Path, rig_file: RigFile) -> Option<Arc<Character>> {
        let format = RigFormat::from_path(path).unwrap_or(RigFormat::Glb);
        let bytes = memory::rig_file_bytes(&rig_file);
        self.characters
            .add(|id| Character::new(id, path, format, rig_file), bytes)
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
/// in shape (JSON errors, panics caught, the security headers) and refuse other callers
/// (the `Host` and `Origin` checks).
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
    guarded(api.layer(middleware::from_fn_with_state(state, guard::callers)))
}

/// `router` wrapped in the layers every answer goes through: a handler that panics answers
/// 500 (the server goes on), every error answer is `{"error": ...}`, and every answer
/// carries the security headers (`guard::security_headers`).
pub fn guarded(router: Router) -> Router {
    router
        .layer(CatchPanicLayer::custom(error::panic_response))
        .layer(middleware::map_response(error::json_error_bodies))
        .layer(middleware::map_response(guard::security_headers))
}

/// Serves the app on `listener` until `shutdown` completes, then stops within the
/// configuration's `shutdown_grace`: the port closes at once, requests under way may finish
/// until then, and solves still running are cancelled (`connections`).
pub async fn serve(
    listener: tokio::net::TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let config = state.config().clone();
    connections::run(listener, router(state), &config, shutdown).await
}
