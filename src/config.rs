//! Command line and environment configuration, and the documented limits. Every server
//! setting has a flag and an environment variable; the defaults run a local service with no
//! external dependencies.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::store::{StoreOptions, DEFAULT_DATABASE_URL};
use crate::usecases::operators::DEFAULT_OPERATOR_CACHE_BYTES;
use crate::usecases::ComputeLimits;

/// Preston: dwell-time planning for dual-rotor small-tool polishing.
#[derive(Debug, Parser)]
#[command(version, about, args_conflicts_with_subcommands = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Settings for `serve`, the default command.
    #[command(flatten)]
    pub serve: ServeArgs,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the HTTP service (the default).
    Serve(Box<ServeArgs>),
    /// Print the OpenAPI document (the content of openapi/openapi.json).
    Openapi,
    /// Compute offline: print exactly the JSON `POST /v1/<endpoint>` would return for the
    /// request body in FILE (`-` for standard input). Problems go to standard output as
    /// problem+json, with exit status 2.
    Compute {
        /// The endpoint: its path under `/v1/`.
        endpoint: String,
        /// The request body, a JSON file.
        file: PathBuf,
    },
    /// Copy the SQLite records store (`--database-url`) to FILE, consistently, while the
    /// service runs (SQLite's `VACUUM INTO`). FILE must not exist. To restore: stop the
    /// service, put the copy in place of the database file (removing its -wal and -shm
    /// files), start it. For PostgreSQL use pg_dump.
    Backup {
        /// Where the copy goes.
        file: PathBuf,
    },
    /// Exit 0 when the service on this host answers `GET /healthz` with 200, 1 otherwise (for
    /// container health checks: the image has no shell or curl).
    Healthcheck {
        /// The address the service listens on; a wildcard (0.0.0.0, [::]) is probed on loopback.
        #[arg(long, env = "PRESTON_LISTEN", default_value = "127.0.0.1:8080")]
        listen: SocketAddr,
        /// How long to wait for the connection and again for the answer, in milliseconds.
        #[arg(long, default_value_t = 2000)]
        timeout_ms: u64,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogFormat {
    Text,
    Json,
}

#[derive(Debug, Clone, Args)]
pub struct ServeArgs {
    /// Address to listen on.
    #[arg(long, env = "PRESTON_LISTEN", default_value = "127.0.0.1:8080")]
    pub listen: SocketAddr,
    /// Largest request body in bytes (413 beyond).
    #[arg(long, env = "PRESTON_MAX_BODY_BYTES", default_value_t = ServiceLimits::default().max_body_bytes)]
    pub max_body_bytes: usize,
    /// Largest radial_grid.count (422 beyond).
    #[arg(long, env = "PRESTON_MAX_RADIAL_SAMPLES", default_value_t = ServiceLimits::default().max_radial_samples)]
    pub max_radial_samples: usize,
    /// Most tool positions in one request (422 beyond).
    #[arg(long, env = "PRESTON_MAX_POSITIONS", default_value_t = ServiceLimits::default().max_positions)]
    pub max_positions: usize,
    /// Most removal-function profiles in one request (422 beyond).
    #[arg(long, env = "PRESTON_MAX_PROFILES", default_value_t = ServiceLimits::default().max_profiles)]
    pub max_profiles: usize,
    /// Largest removal operator, radial samples × tool positions (422 beyond).
    #[arg(long, env = "PRESTON_MAX_OPERATOR_ENTRIES", default_value_t = ServiceLimits::default().max_operator_entries)]
    pub max_operator_entries: usize,
    /// Most candidate positions in one optimization (422 beyond).
    #[arg(long, env = "PRESTON_MAX_OPTIMIZE_POSITIONS", default_value_t = ServiceLimits::default().max_optimize_positions)]
    pub max_optimize_positions: usize,
    /// Largest interferometer map file in bytes, on the map endpoints (413 beyond).
    #[arg(long, env = "PRESTON_MAX_MAP_BYTES", default_value_t = ServiceLimits::default().max_map_bytes)]
    pub max_map_bytes: usize,
    /// Most pixels in one interferometer map (422 beyond).
    #[arg(long, env = "PRESTON_MAX_MAP_PIXELS", default_value_t = ServiceLimits::default().max_map_pixels)]
    pub max_map_pixels: usize,
    /// Longest a dwell optimization may run in the solver, in milliseconds.
    #[arg(long, env = "PRESTON_SOLVER_TIME_LIMIT_MS", default_value_t = 10_000)]
    pub solver_time_limit_ms: u64,
    /// Computations running at once (default: one more than the number of CPUs).
    #[arg(long, env = "PRESTON_MAX_CONCURRENT_COMPUTATIONS")]
    pub max_concurrent_computations: Option<usize>,
    /// How long a request may wait for a computation slot before a 503, in milliseconds.
    #[arg(long, env = "PRESTON_QUEUE_TIMEOUT_MS", default_value_t = 5000)]
    pub queue_timeout_ms: u64,
    /// Most requests waiting for a computation slot; more get a 503 at once.
    #[arg(long, env = "PRESTON_MAX_QUEUED_COMPUTATIONS", default_value_t = ServiceLimits::default().max_queued_computations)]
    pub max_queued_computations: usize,
    /// Longest a computing request may take, waiting included, in milliseconds (503 beyond).
    #[arg(long, env = "PRESTON_REQUEST_TIMEOUT_MS", default_value_t = 30_000)]
    pub request_timeout_ms: u64,
    /// Memory for removal operators kept for reuse by later predictions and optimizations on
    /// the same process, grid and positions, in MiB (0: none kept).
    #[arg(long, env = "PRESTON_OPERATOR_CACHE_MIB", default_value_t = ServiceLimits::default().operator_cache_bytes / MIB)]
    pub operator_cache_mib: usize,
    /// On SIGTERM, how long to keep serving with /readyz at 503 before closing the listener,
    /// in milliseconds, so load balancers stop sending traffic first. Ctrl-C skips it.
    #[arg(long, env = "PRESTON_DRAIN_DELAY_MS", default_value_t = 2000)]
    pub drain_delay_ms: u64,
    /// Origins allowed to call the API from a browser (comma-separated; `*` for any). CORS is
    /// off when empty.
    #[arg(long, env = "PRESTON_CORS_ORIGINS", value_delimiter = ',')]
    pub cors_origins: Vec<String>,
    /// API keys file: one key per line as `name:<SHA-256 hex of the key>` (`#` comments, blank
    /// lines ignored). With it every /v1 request needs `Authorization: Bearer <key>`; SIGHUP
    /// reloads it. Without it the API is open.
    #[arg(long, env = "PRESTON_API_KEYS_FILE")]
    pub api_keys_file: Option<PathBuf>,
    /// With an API keys file, require a key for /metrics too (it is open by default).
    #[arg(long, env = "PRESTON_METRICS_REQUIRE_KEY")]
    pub metrics_require_key: bool,
    /// Requests per second each client may make to /v1: per API key when keys are configured
    /// (default 50), else per client address (default off). 0 turns it off.
    #[arg(long, env = "PRESTON_RATE_LIMIT_PER_SECOND")]
    pub rate_limit_per_second: Option<f64>,
    /// Requests a client may make at once beyond its rate (default twice the rate, at least 1).
    #[arg(long, env = "PRESTON_RATE_LIMIT_BURST")]
    pub rate_limit_burst: Option<u32>,
    /// Where records are kept: `sqlite://FILE` (created on first start; the default is
    /// `preston.db` in the working directory) or `postgres://USER:PASSWORD@HOST/DATABASE`
    /// (for several replicas). Migrations are applied at start.
    #[arg(long, env = "PRESTON_DATABASE_URL", default_value = DEFAULT_DATABASE_URL)]
    pub database_url: String,
    /// A file holding the database URL (its first line), read at start instead of
    /// `--database-url`: a URL with a password belongs in a mounted secret, not in the
    /// environment.
    #[arg(long, env = "PRESTON_DATABASE_URL_FILE")]
    pub database_url_file: Option<PathBuf>,
    /// Most connections to the database.
    #[arg(long, env = "PRESTON_DATABASE_POOL_SIZE", default_value_t = 8)]
    pub database_pool_size: u32,
    /// How long a request waits for a database connection (and SQLite for a lock), in
    /// milliseconds.
    #[arg(long, env = "PRESTON_DATABASE_TIMEOUT_MS", default_value_t = 5000)]
    pub database_timeout_ms: u64,
    /// Log format. The level comes from RUST_LOG (default `info`).
    #[arg(long, env = "PRESTON_LOG_FORMAT", value_enum, default_value_t = LogFormat::Text)]
    pub log_format: LogFormat,
}

/// Sizes and waits the server refuses to exceed.
#[derive(Debug, Clone)]
pub struct ServiceLimits {
    /// Largest request body, bytes (413 beyond).
    pub max_body_bytes: usize,
    /// Largest `radial_grid.count` (422 beyond).
    pub max_radial_samples: usize,
    /// Most tool positions in one request (dwell or removal-function profiles; 422 beyond).
    pub max_positions: usize,
    /// Most removal-function profiles (`tool_positions_mm`) in one request.
    pub max_profiles: usize,
    /// Largest removal operator, radial samples × tool positions (422 beyond).
    pub max_operator_entries: usize,
    /// Most candidate positions in one optimization (bounds the rows of its QP and the rare
    /// fallback to a variable per position, whose Hessian is dense within the band; 422 beyond).
    pub max_optimize_positions: usize,
    /// Longest a dwell optimization may run in the solver; a request may ask for less.
    pub solver_time_limit: Duration,
    /// Largest map file, bytes, on the map endpoints (413 beyond).
    pub max_map_bytes: usize,
    /// Most pixels in one map (422 beyond).
    pub max_map_pixels: usize,
    /// Computations running at once; more wait for a slot. One more than the CPUs by default:
    /// between one computation's end and the next one's start on a core lie the hand-offs
    /// between threads (the result to the runtime, the next queued request to its lane), and
    /// with a computation to spare no core idles through them (201² predictions with a new
    /// speed at 16 clients: about 5 % more a second).
    pub max_concurrent_computations: usize,
    /// How long a request waits for a computation slot before a 503 with Retry-After.
    pub queue_timeout: Duration,
    /// Most requests waiting for a computation slot; more get a 503 at once.
    pub max_queued_computations: usize,
    /// Longest a computing request may take, waiting included (503 beyond).
    pub request_timeout: Duration,
    /// Memory for the operator cache, bytes (0: none kept).
    pub operator_cache_bytes: usize,
}

const MIB: usize = 1024 * 1024;

impl Default for ServiceLimits {
    fn default() -> Self {
        let compute = ComputeLimits::default();
        ServiceLimits {
            max_body_bytes: 4 * 1024 * 1024,
            max_radial_samples: compute.max_radial_samples,
            max_positions: compute.max_positions,
            max_profiles: compute.max_profiles,
            max_operator_entries: compute.max_operator_entries,
            max_optimize_positions: compute.max_optimize_positions,
            solver_time_limit: compute.solver_time_limit,
            max_map_bytes: 64 * MIB,
            max_map_pixels: compute.max_map_pixels,
            max_concurrent_computations: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(2)
                + 1,
            queue_timeout: Duration::from_secs(5),
            max_queued_computations: 64,
            request_timeout: Duration::from_secs(30),
            operator_cache_bytes: DEFAULT_OPERATOR_CACHE_BYTES,
        }
    }
}

impl ServiceLimits {
    /// The limits the use cases enforce.
    pub fn compute(&self) -> ComputeLimits {
        ComputeLimits {
            max_radial_samples: self.max_radial_samples,
            max_positions: self.max_positions,
            max_profiles: self.max_profiles,
            max_operator_entries: self.max_operator_entries,
            max_optimize_positions: self.max_optimize_positions,
            solver_time_limit: self.solver_time_limit,
            max_map_pixels: self.max_map_pixels,
            ..ComputeLimits::default()
        }
    }
}

/// The per-key rate limit when keys are configured and no rate is given, requests per second.
pub const DEFAULT_KEY_RATE_PER_SECOND: f64 = 50.0;

impl ServeArgs {
    /// The rate limit asked for, as (requests per second, burst); `None` when off.
    pub fn rate_limit(&self) -> Option<(f64, u32)> {
        let default = self
            .api_keys_file
            .is_some()
            .then_some(DEFAULT_KEY_RATE_PER_SECOND);
        let rate = self.rate_limit_per_second.or(default)?;
        if rate == 0.0 {
            return None;
        }
        let burst = self
            .rate_limit_burst
            .unwrap_or_else(|| (2.0 * rate).ceil().clamp(1.0, u32::MAX as f64) as u32);
        Some((rate, burst))
    }

    /// How to reach the records store (the URL file read, when given).
    pub fn store_options(&self) -> Result<StoreOptions, String> {
        let url = match &self.database_url_file {
            None => self.database_url.clone(),
            Some(path) => std::fs::read_to_string(path)
                .map_err(|e| format!("--database-url-file {}: {e}", path.display()))?
                .lines()
                .next()
                .unwrap_or_default()
                .trim()
                .to_string(),
        };
        Ok(StoreOptions {
            url,
            max_connections: self.database_pool_size.max(1),
            timeout: Duration::from_millis(self.database_timeout_ms.max(1)),
        })
    }

    pub fn limits(&self) -> ServiceLimits {
        let defaults = ServiceLimits::default();
        ServiceLimits {
            max_body_bytes: self.max_body_bytes,
            max_radial_samples: self.max_radial_samples,
            max_positions: self.max_positions,
            max_profiles: self.max_profiles,
            max_operator_entries: self.max_operator_entries,
            max_optimize_positions: self.max_optimize_positions,
            solver_time_limit: Duration::from_millis(self.solver_time_limit_ms.max(1)),
            max_map_bytes: self.max_map_bytes,
            max_map_pixels: self.max_map_pixels,
            max_concurrent_computations: self
                .max_concurrent_computations
                .unwrap_or(defaults.max_concurrent_computations)
                .max(1),
            queue_timeout: Duration::from_millis(self.queue_timeout_ms),
            max_queued_computations: self.max_queued_computations,
            request_timeout: Duration::from_millis(self.request_timeout_ms.max(1)),
            operator_cache_bytes: self.operator_cache_mib.saturating_mul(MIB),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serve_is_the_default_with_documented_defaults() {
        let cli = Cli::try_parse_from(["preston"]).unwrap();
        assert!(cli.command.is_none());
        assert_eq!(cli.serve.listen.to_string(), "127.0.0.1:8080");
        assert!(cli.serve.cors_origins.is_empty());
        let limits = cli.serve.limits();
        assert_eq!(limits.max_radial_samples, 10_001);
        assert_eq!(limits.queue_timeout, Duration::from_secs(5));
        let store = cli.serve.store_options().unwrap();
        assert_eq!(store.url, "sqlite://preston.db");
        assert_eq!(store.max_connections, 8);
        // A URL file's first line wins over --database-url.
        let file = std::env::temp_dir().join(format!("preston-url-{}", std::process::id()));
        std::fs::write(&file, "postgres://u:p@db/preston\n").unwrap();
        let cli = Cli::try_parse_from(["preston", "--database-url-file", file.to_str().unwrap()])
            .unwrap();
        assert_eq!(
            cli.serve.store_options().unwrap().url,
            "postgres://u:p@db/preston"
        );
        std::fs::remove_file(&file).unwrap();
    }

    #[test]
    fn subcommands_parse() {
        let cli = Cli::try_parse_from(["preston", "compute", "predict", "f.json"]).unwrap();
        assert!(matches!(cli.command, Some(Command::Compute { .. })));
        let cli = Cli::try_parse_from([
            "preston",
            "serve",
            "--listen",
            "0.0.0.0:9000",
            "--cors-origins",
            "https://a.example,https://b.example",
        ])
        .unwrap();
        let Some(Command::Serve(args)) = cli.command else {
            panic!("serve expected")
        };
        assert_eq!(args.listen.port(), 9000);
        assert_eq!(args.cors_origins.len(), 2);
    }
}
