//! Serving: bind, run the router, shut down gracefully on SIGTERM or Ctrl-C. On SIGTERM
//! readiness turns 503 at once and the service keeps answering for the drain delay (so load
//! balancers see it and stop sending work), then stops accepting connections, lets in-flight
//! requests finish, and exits. Ctrl-C skips the delay. With an API keys file, SIGHUP reloads it.

use std::future::Future;
use std::sync::Arc;

use tokio::net::TcpListener;

use crate::config::ServeArgs;
use crate::http::{cors_layer, router, AppState};
use crate::keys::Auth;
use crate::ratelimit::RateLimit;
use crate::store::Store;

/// Runs the service with `args` until a shutdown signal.
pub async fn run(args: ServeArgs) -> std::io::Result<()> {
    let mut state = AppState::new(args.limits());
    match &args.api_keys_file {
        Some(path) => {
            let auth = Auth::load(path.clone(), args.metrics_require_key)
                .map(Arc::new)
                .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))?;
            tracing::info!(file = %path.display(), "API keys required on /v1");
            reload_on_hangup(auth.clone());
            state = state.with_auth(auth);
        }
        None => tracing::warn!(
            "no API keys file: the API is open to anyone who can reach it (--api-keys-file)"
        ),
    }
    if let Some((rate, burst)) = args.rate_limit() {
        let limit = RateLimit::new(rate, burst).ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("--rate-limit-per-second ({rate}) must be a positive number and --rate-limit-burst ({burst}) at least 1"),
            )
        })?;
        let per = if args.api_keys_file.is_some() {
            "API key"
        } else {
            "client address"
        };
        tracing::info!(per_second = rate, burst, per, "rate limit on /v1");
        state = state.with_rate_limit(Arc::new(limit));
    }
    let options = args.store_options().map_err(std::io::Error::other)?;
    let store = Store::open(&options)
        .await
        .map_err(|e| std::io::Error::other(format!("--database-url: {e}")))?;
    tracing::info!(backend = ?store.backend(), "records store open, migrations applied");
    state = state.with_store(store.clone());
    let listener = TcpListener::bind(args.listen).await?;
    tracing::info!(address = %listener.local_addr()?, "preston listening; docs at /docs");
    let shutdown_state = state.clone();
    let drain = std::time::Duration::from_millis(args.drain_delay_ms);
    serve_on(listener, state, &args.cors_origins, async move {
        let signal = shutdown_signal().await;
        shutdown_state.set_ready(false);
        if signal == Signal::Terminate && !drain.is_zero() {
            tracing::info!(
                delay_ms = drain.as_millis() as u64,
                "SIGTERM: not ready; draining before closing the listener"
            );
            tokio::time::sleep(drain).await;
        }
        tracing::info!("shutting down; finishing in-flight requests");
    })
    .await?;
    store.close().await;
    Ok(())
}

/// Serves on `listener` until `shutdown` completes, then drains in-flight requests.
pub async fn serve_on(
    listener: TcpListener,
    state: AppState,
    cors_origins: &[String],
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let app = router(state, cors_layer(cors_origins));
    // The peer address, for rate limits by client address.
    axum::serve(
        listener,
        app.into_make_service_with_connect_info::<std::net::SocketAddr>(),
    )
    .with_graceful_shutdown(shutdown)
    .await
}

/// Reloads the keys file on each SIGHUP; a malformed file keeps the keys in force (logged).
fn reload_on_hangup(auth: Arc<Auth>) {
    #[cfg(unix)]
    tokio::spawn(async move {
        let mut hangups = match tokio::signal::unix::signal(
            tokio::signal::unix::SignalKind::hangup(),
        ) {
            Ok(signal) => signal,
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen for SIGHUP: API keys will not reload");
                return;
            }
        };
        while hangups.recv().await.is_some() {
            match auth.reload() {
                Ok(keys) => {
                    tracing::info!(file = %auth.path().display(), keys, "API keys reloaded")
                }
                Err(e) => {
                    tracing::error!(error = %e, "API keys not reloaded; the previous keys stay in force")
                }
            }
        }
    });
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Signal {
    Interrupt,
    Terminate,
}

async fn shutdown_signal() -> Signal {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let terminate = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut signal) => {
                signal.recv().await;
            }
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen for SIGTERM");
                std::future::pending::<()>().await
            }
        }
    };
    #[cfg(not(unix))]
    let terminate = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => Signal::Interrupt,
        _ = terminate => Signal::Terminate,
    }
}
