//! Blobs: bytes kept once under their SHA-256, for what is too big to live inside a record's
//! JSON (an interferometer map: ~20 MB as JSON numbers, a few MB as bytes). A blob is written
//! in a statement of its own, never inside a document; a record names it by its hash, so the
//! same bytes sent twice are kept once. The SQL is the same on SQLite and PostgreSQL.

use sha2::{Digest, Sha256};
use sqlx::Row;

use super::{now, Store};
use crate::usecases::records::RecordsError;

/// The hex SHA-256 of `bytes`: a blob's name (and an Idempotency-Key's fingerprint).
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

impl Store {
    /// Keeps `bytes` (once: a blob already kept is left as it is) and returns its name.
    pub async fn put_blob(&self, bytes: &[u8]) -> Result<String, RecordsError> {
        self.ready().await?;
        let name = sha256_hex(bytes);
        let size = i64::try_from(bytes.len())
            .map_err(|_| RecordsError::Unavailable("a blob beyond 2^63 bytes".into()))?;
        sqlx::query(
            "INSERT INTO blobs (sha256, size_bytes, bytes, created_at) VALUES ($1, $2, $3, $4) \
             ON CONFLICT (sha256) DO NOTHING",
        )
        .bind(&name)
        .bind(size)
        .bind(bytes)
        .bind(now())
        .execute(&self.pool)
        .await
        .map_err(|e| RecordsError::Unavailable(e.to_string()))?;
        Ok(name)
    }

    /// The bytes kept under `name`, if any.
    pub async fn blob(&self, name: &str) -> Result<Option<Vec<u8>>, RecordsError> {
        self.ready().await?;
        let row = sqlx::query("SELECT bytes FROM blobs WHERE sha256 = $1")
            .bind(name)
            .fetch_optional(&self.pool)
            .await
            .map_err(|e| RecordsError::Unavailable(e.to_string()))?;
        row.map(|r| r.try_get::<Vec<u8>, _>("bytes"))
            .transpose()
            .map_err(|e| RecordsError::Unavailable(e.to_string()))
    }
}
