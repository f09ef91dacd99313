//! `rigfit serve [RIG] [--port P] [--host H]`: the sketching page in a browser. Loads RIG
//! (or the built-in humanoid) as character `c0`, listens on 127.0.0.1 unless `--host` says
//! otherwise, prints `rigfit serve: http://HOST:PORT/` as its first line and serves until
//! Ctrl-C or SIGTERM, then exits within a few seconds (requests under way get the server's
//! shutdown grace, solves still running are cancelled, the blocking pool is not waited for).

use std::io::Write as _;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, anyhow};
use rigfit_formats::rig_file::{RigOptions, read_rig};
use rigfit_server::{AppState, ServerConfig};

/// The port `rigfit serve` listens on unless told otherwise.
pub const DEFAULT_PORT: u16 = 8717;

#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// The character to load first (.glb / .gltf with a skin, or .bvh); the built-in humanoid
    /// when absent.
    pub rig: Option<PathBuf>,
    /// The port (0: any free port; the first line printed says which).
    #[arg(long, default_value_t = DEFAULT_PORT)]
    pub port: u16,
    /// The address to listen on. Anything but a loopback address (127.0.0.1, ::1,
    /// localhost) makes the server reachable from other machines.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// The glTF skin of RIG to pose (by name); the first by default.
    #[arg(long)]
    pub skin: Option<String>,
    /// BVH: the frame RIG starts from (a number, or `rest` for all channels zero).
    #[arg(long)]
    pub start_frame: Option<String>,
    /// The memory the loaded characters may take, in MiB (uploads past it are refused).
    #[arg(long, default_value_t = rigfit_server::DEFAULT_MEMORY_BUDGET >> 20)]
    pub memory_budget: usize,
    /// The longest one solve may run, in seconds.
    #[arg(long, default_value_t = 30.0)]
    pub solve_timeout: f64,
}

/// How long the runtime waits, once the server has stopped, for blocking jobs (solves
/// being cancelled) before the process exits anyway.
const BLOCKING_JOBS_GRACE: Duration = Duration::from_millis(500);

pub fn run(args: &ServeArgs) -> anyhow::Result<()> {
    // Everything that can be wrong with the arguments is found before listening.
    let first = match &args.rig {
        Some(path) => {
            let options = RigOptions {
                skin: args.skin.clone(),
                start_frame: super::pose::start_frame(args.start_frame.as_deref())?,
            };
            Some((path.clone(), read_rig(path, &options)?))
        }
        None => None,
    };
    let solve_timeout = Duration::try_from_secs_f64(args.solve_timeout)
        .ok()
        .filter(|d| !d.is_zero())
        .ok_or_else(|| {
            anyhow!(
                "--solve-timeout {}: expected a positive number of seconds",
                args.solve_timeout
            )
        })?;
    if args.memory_budget == 0 {
        return Err(anyhow!(
            "--memory-budget 0: expected a positive number of MiB"
        ));
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the server's runtime")?;
    let result = runtime.block_on(serve(args, first, solve_timeout));
    // Dropping the runtime would wait for every blocking job; cancelled solves stop within
    // moments, and nothing else is worth waiting for.
    runtime.shutdown_timeout(BLOCKING_JOBS_GRACE);
    result
}

async fn serve(
    args: &ServeArgs,
    first: Option<(PathBuf, rigfit_formats::rig_file::RigFile)>,
    solve_timeout: Duration,
) -> anyhow::Result<()> {
    let addresses: Vec<SocketAddr> = tokio::net::lookup_host((args.host.as_str(), args.port))
        .await
        .with_context(|| format!("--host {}: not an address of this machine", args.host))?
        .collect();
    let address = addresses
        .first()
        .copied()
        .ok_or_else(|| anyhow!("--host {}: names no address", args.host))?;
    let loopback_only = address.ip().is_loopback();
    let state = AppState::new(&ServerConfig {
        loopback_only,
        memory_budget: args.memory_budget.saturating_mul(1 << 20),
        solve_timeout,
        ..ServerConfig::default()
    });
    match first {
        Some((path, rig_file)) => {
            state
                .add_rig_file(&path, rig_file)
                .ok_or_else(|| anyhow!("{}: could not be added", path.display()))?;
        }
        None => {
            state.add_humanoid()?;
        }
    }
    let listener = tokio::net::TcpListener::bind(address)
        .await
        .with_context(|| format!("{address}: cannot listen"))?;
    let bound = listener
        .local_addr()
        .with_context(|| format!("{address}: cannot listen"))?;
    let shutdown = shutdown_signal();
    let mut stdout = std::io::stdout();
    writeln!(stdout, "rigfit serve: http://{bound}/")?;
    stdout.flush()?;
    if !loopback_only {
        eprintln!(
            "rigfit serve: warning: listening on {bound}: other machines can reach this server (it has no authentication)"
        );
    }
    rigfit_server::serve(listener, state, shutdown)
        .await
        .context("serving")?;
    Ok(())
}

/// Completes on Ctrl-C or (on Unix) SIGTERM. The handlers are installed now, before the
/// address is printed, so a signal sent as soon as the address is read stops the server
/// cleanly instead of killing it.
fn shutdown_signal() -> impl Future<Output = ()> + Send + 'static {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        let interrupt = signal(SignalKind::interrupt()).ok();
        let terminate = signal(SignalKind::terminate()).ok();
        async move {
            // A handler that could not be installed never fires: serve until killed.
            let wait = |handler: Option<tokio::signal::unix::Signal>| async move {
                match handler {
                    Some(mut handler) => {
                        handler.recv().await;
                    }
                    None => std::future::pending::<()>().await,
                }
            };
            tokio::select! {
                () = wait(interrupt) => {}
                () = wait(terminate) => {}
            }
        }
    }
    #[cfg(not(unix))]
    async {
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
    }
}
