//! The records store: one sqlx pool over SQLite (the default, a file created on first start)
//! or PostgreSQL (for several replicas), with the schema's migrations embedded in the binary
//! and applied at start, forward only. The same SQL runs on both (text keys and timestamps,
//! `$n` placeholders, which SQLite also reads).
//!
//! SQLite connections run in WAL mode (readers never wait on the writer) with foreign keys
//! enforced and a busy timeout equal to the pool's acquire timeout, so that concurrent writers
//! queue instead of failing.

use std::borrow::Cow;
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use sqlx::any::AnyPoolOptions;
use sqlx::error::BoxDynError;
use sqlx::migrate::{Migration, MigrationSource, MigrationType, Migrator};
use sqlx::AnyPool;
use tokio::sync::OnceCell;

use crate::usecases::records::{RecordsError, Stamp};

mod blobs;
pub use blobs::sha256_hex;
mod records;

/// The schema, in order: (version, description, SQL). Append only: a released migration never
/// changes (its checksum is recorded where it ran).
const MIGRATIONS: &[(i64, &str, &str)] = &[
    (
        1,
        "process profiles",
        include_str!("../../migrations/0001_process_profiles.sql"),
    ),
    (
        2,
        "parts and cycles",
        include_str!("../../migrations/0002_parts_and_cycles.sql"),
    ),
    (
        3,
        "cycle indexes",
        include_str!("../../migrations/0003_cycle_indexes.sql"),
    ),
    (
        4,
        "computed by",
        include_str!("../../migrations/0004_computed_by.sql"),
    ),
    (5, "blobs", include_str!("../../migrations/0005_blobs.sql")),
    (
        6,
        "idempotency records",
        include_str!("../../migrations/0006_idempotency_records.sql"),
    ),
    (
        7,
        "measurement maps",
        include_str!("../../migrations/0007_measurement_maps.sql"),
    ),
];

/// Which code writes the records: the crate's version, the build's git revision (build.rs)
/// and the records schema (the last migration's version).
pub fn computed_by() -> String {
    format!(
        "preston {} (git {}), records schema {}",
        env!("CARGO_PKG_VERSION"),
        env!("PRESTON_GIT_REVISION"),
        MIGRATIONS.len()
    )
}

/// The default store: a SQLite file in the working directory.
pub const DEFAULT_DATABASE_URL: &str = "sqlite://preston.db";

/// How to reach the store.
#[derive(Debug, Clone, PartialEq)]
pub struct StoreOptions {
    /// `sqlite://FILE` or `postgres://…`.
    pub url: String,
    pub max_connections: u32,
    /// How long a request waits for a connection (and SQLite for a lock).
    pub timeout: Duration,
}

/// Why the store could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// (Only the scheme is kept: the rest of a URL may hold a password.)
    #[error("the database URL must start with sqlite:// or postgres:// (it starts with `{0}`)")]
    Scheme(String),
    #[error("cannot open the database: {0}")]
    Connect(sqlx::Error),
    #[error("cannot migrate the database: {0}")]
    Migrate(sqlx::migrate::MigrateError),
    #[error("a backup copies a SQLite store; back PostgreSQL up with pg_dump")]
    NotSqlite,
    #[error("cannot copy the database: {0}")]
    Backup(sqlx::Error),
}

/// Which database the store runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    Sqlite,
    Postgres,
}

/// An open store. SQLite is migrated at open; PostgreSQL connects lazily and is migrated on
/// first use, so the service starts (and computes) while its database is down.
#[derive(Debug, Clone)]
pub struct Store {
    pool: AnyPool,
    backend: Backend,
    migrated: Arc<OnceCell<()>>,
}

/// Now, as the records keep it: RFC 3339 UTC with milliseconds.
pub fn now() -> String {
    humantime::format_rfc3339_millis(std::time::SystemTime::now()).to_string()
}

/// A new record's stamp: a UUIDv7 (time-ordered) id, now, and the API key's name.
pub fn new_stamp(created_by: &str) -> Stamp {
    Stamp {
        id: uuid::Uuid::now_v7().to_string(),
        created_at: now(),
        created_by: created_by.to_string(),
        computed_by: computed_by(),
    }
}

#[derive(Debug)]
struct Embedded;

impl<'s> MigrationSource<'s> for Embedded {
    fn resolve(
        self,
    ) -> Pin<Box<dyn Future<Output = Result<Vec<Migration>, BoxDynError>> + Send + 's>> {
        Box::pin(async {
            Ok(MIGRATIONS
                .iter()
                .map(|&(version, description, sql)| {
                    Migration::new(
                        version,
                        Cow::Borrowed(description),
                        MigrationType::Simple,
                        Cow::Borrowed(sql),
                        false,
                    )
                })
                .collect())
        })
    }
}

/// The embedded migrations.
pub async fn migrator() -> Migrator {
    Migrator::new(Embedded)
        .await
        .expect("embedded migrations resolve")
}

impl Store {
    /// Connects and applies the migrations not yet applied.
    pub async fn open(options: &StoreOptions) -> Result<Store, StoreError> {
        sqlx::any::install_default_drivers();
        let (backend, url) = if let Some(rest) = options.url.strip_prefix("sqlite:") {
            // Create the file on first start unless the URL says otherwise.
            let url = if rest.contains("mode=") {
                options.url.clone()
            } else if rest.contains('?') {
                format!("{}&mode=rwc", options.url)
            } else {
                format!("{}?mode=rwc", options.url)
            };
            (Backend::Sqlite, url)
        } else if options.url.starts_with("postgres://") || options.url.starts_with("postgresql://")
        {
            (Backend::Postgres, options.url.clone())
        } else {
            let scheme = options.url.split("://").next().unwrap_or_default();
            return Err(StoreError::Scheme(scheme.chars().take(20).collect()));
        };
        let busy = format!("PRAGMA busy_timeout = {}", options.timeout.as_millis());
        let pool_options = AnyPoolOptions::new()
            .max_connections(options.max_connections)
            .acquire_timeout(options.timeout)
            .after_connect(move |conn, _| {
                let busy = busy.clone();
                Box::pin(async move {
                    if backend == Backend::Sqlite {
                        for pragma in [
                            "PRAGMA journal_mode = WAL",
                            "PRAGMA foreign_keys = ON",
                            &busy,
                        ] {
                            sqlx::query(pragma).execute(&mut *conn).await?;
                        }
                    }
                    Ok(())
                })
            });
        let store = match backend {
            Backend::Sqlite => {
                let pool = pool_options
                    .connect(&url)
                    .await
                    .map_err(StoreError::Connect)?;
                let store = Store::new(pool, backend);
                store.migrate().await.map_err(StoreError::Migrate)?;
                store
            }
            Backend::Postgres => {
                let pool = pool_options
                    .connect_lazy(&url)
                    .map_err(StoreError::Connect)?;
                let store = Store::new(pool, backend);
                if let Err(e) = store.migrate().await {
                    tracing::warn!(error = %e, "the database is not reachable yet: record endpoints answer 503 until it is");
                }
                store
            }
        };
        Ok(store)
    }

    fn new(pool: AnyPool, backend: Backend) -> Store {
        Store {
            pool,
            backend,
            migrated: Arc::default(),
        }
    }

    /// Applies the migrations not yet applied, once per process (again after a failure).
    async fn migrate(&self) -> Result<(), sqlx::migrate::MigrateError> {
        self.migrated
            .get_or_try_init(|| async { migrator().await.run(&self.pool).await })
            .await
            .map(|_| ())
    }

    /// Ready for records: migrated (PostgreSQL may have been down at start).
    async fn ready(&self) -> Result<(), RecordsError> {
        self.migrate()
            .await
            .map_err(|e| RecordsError::Unavailable(e.to_string()))
    }

    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// Whether the database answers now, migrated.
    pub async fn is_reachable(&self) -> bool {
        self.ready().await.is_ok() && sqlx::query("SELECT 1").execute(&self.pool).await.is_ok()
    }

    /// The applied migrations' versions, in order.
    pub async fn applied_versions(&self) -> Result<Vec<i64>, sqlx::Error> {
        let rows: Vec<(i64,)> =
            sqlx::query_as("SELECT version FROM _sqlx_migrations ORDER BY version")
                .fetch_all(&self.pool)
                .await?;
        Ok(rows.into_iter().map(|(v,)| v).collect())
    }

    /// A consistent copy of a SQLite store at `file` (which must not exist), taken while it
    /// serves: `VACUUM INTO` reads one snapshot, the WAL's committed transactions included.
    pub async fn backup(&self, file: &std::path::Path) -> Result<(), StoreError> {
        if self.backend != Backend::Sqlite {
            return Err(StoreError::NotSqlite);
        }
        sqlx::query("VACUUM INTO $1")
            .bind(file.to_string_lossy().into_owned())
            .execute(&self.pool)
            .await
            .map(|_| ())
            .map_err(StoreError::Backup)
    }

    /// Closes the pool (waits for connections in use).
    pub async fn close(&self) {
        self.pool.close().await;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temporary(name: &str) -> (std::path::PathBuf, StoreOptions) {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos();
        let path =
            std::env::temp_dir().join(format!("preston-{name}-{}-{nanos}.db", std::process::id()));
        let options = StoreOptions {
            url: format!("sqlite://{}", path.display()),
            max_connections: 2,
            timeout: Duration::from_secs(5),
        };
        (path, options)
    }

    fn remove(path: &std::path::Path) {
        for suffix in ["", "-wal", "-shm"] {
            let _ = std::fs::remove_file(format!("{}{suffix}", path.display()));
        }
    }

    /// A new file is created and migrated once; opening it again applies nothing twice; it
    /// is in WAL mode, and every connection enforces foreign keys (a calibration of a profile
    /// that does not exist is refused).
    #[tokio::test]
    async fn a_new_sqlite_file_is_created_migrated_once_and_enforces_foreign_keys() {
        let (path, options) = temporary("store");
        let store = Store::open(&options).await.unwrap();
        assert!(path.exists());
        assert_eq!(store.backend(), Backend::Sqlite);
        assert_eq!(
            store.applied_versions().await.unwrap(),
            vec![1, 2, 3, 4, 5, 6, 7]
        );
        assert!(store.is_reachable().await);
        let (mode,): (String,) = sqlx::query_as("PRAGMA journal_mode")
            .fetch_one(&store.pool)
            .await
            .unwrap();
        assert_eq!(mode, "wal");
        let orphan = sqlx::query(
            "INSERT INTO calibrations (id, profile, request, result, learned, created_at, created_by) \
             VALUES ($1, $2, '{}', '{}', FALSE, '2026-11-25T00:00:00Z', '')",
        )
        .bind("c1")
        .bind("no such profile")
        .execute(&store.pool)
        .await;
        assert!(orphan.is_err(), "{orphan:?}");
        store.close().await;
        let again = Store::open(&options).await.unwrap();
        assert_eq!(
            again.applied_versions().await.unwrap(),
            vec![1, 2, 3, 4, 5, 6, 7]
        );
        again.close().await;
        remove(&path);
    }

    /// A store at the previous schema (version 1, with a profile in it) is migrated forward at
    /// open, and the profile reads back through the records; a backup copy opens as a store
    /// with the same records.
    #[tokio::test]
    async fn a_store_at_the_previous_schema_is_migrated_and_a_backup_restores_it() {
        use crate::usecases::records::Records;
        let (path, options) = temporary("previous");
        {
            sqlx::any::install_default_drivers();
            let pool = sqlx::any::AnyPoolOptions::new()
                .connect(&format!("{}?mode=rwc", options.url))
                .await
                .unwrap();
            let first = Migrator::new(Embedded).await.unwrap();
            let mut only_first = first;
            only_first.migrations = Cow::Owned(only_first.migrations[..1].to_vec());
            only_first.run(&pool).await.unwrap();
            sqlx::query(
                "INSERT INTO process_profiles (name, body, created_at, created_by) \
                 VALUES ('old', '{\"process\": {}}', '2026-11-01T00:00:00.000Z', 'mes')",
            )
            .execute(&pool)
            .await
            .unwrap();
            pool.close().await;
        }
        let store = Store::open(&options).await.unwrap();
        assert_eq!(
            store.applied_versions().await.unwrap(),
            vec![1, 2, 3, 4, 5, 6, 7]
        );
        let old = store.profile("old").await.unwrap().unwrap();
        assert_eq!(old.stamp.created_by, "mes");
        assert_eq!(
            old.stamp.computed_by, "",
            "written before computed_by was kept"
        );
        assert!(store.calibrations("old").await.unwrap().is_empty());
        let (copy, copy_options) = temporary("copy");
        store.backup(&copy).await.unwrap();
        assert!(
            store.backup(&copy).await.is_err(),
            "an existing file is never overwritten"
        );
        store.close().await;
        let restored = Store::open(&copy_options).await.unwrap();
        assert_eq!(restored.profile("old").await.unwrap(), Some(old));
        restored.close().await;
        remove(&path);
        remove(&copy);
    }

    #[tokio::test]
    async fn a_url_of_another_kind_is_refused() {
        let options = StoreOptions {
            url: "mysql://localhost/preston".into(),
            max_connections: 1,
            timeout: Duration::from_secs(1),
        };
        assert!(matches!(
            Store::open(&options).await,
            Err(StoreError::Scheme(_))
        ));
    }

    /// Every file in migrations/ is embedded, in version order, and nothing else is.
    #[test]
    fn every_migration_file_is_embedded_in_order() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations");
        let mut files: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.ends_with(".sql"))
            .collect();
        files.sort();
        assert_eq!(files.len(), MIGRATIONS.len());
        for (file, &(version, _, sql)) in files.iter().zip(MIGRATIONS) {
            let number: i64 = file.split('_').next().unwrap().parse().unwrap();
            assert_eq!(number, version, "{file}");
            let text = std::fs::read_to_string(
                std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("migrations")
                    .join(file),
            )
            .unwrap();
            assert_eq!(text, sql, "{file}");
        }
    }
}
