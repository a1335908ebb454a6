//! [`Records`] on the store's pool: one transaction per write, the Idempotency-Key claimed in
//! it first (a concurrent retry waits on the claim's key and then finds it taken), and plain
//! reads. The SQL is the same on SQLite and PostgreSQL.

use sqlx::any::AnyRow;
use sqlx::{Any, Row, Transaction};

use super::{now, Store};
use crate::usecases::records::{
    CalibrationRecord, Claim, MeasurementHead, MeasurementRecord, PartRecord, PartsPage, PlanHead,
    PlanRecord, ProfileRecord, Record, Records, RecordsError, Replay, RunRecord, Stamp, Written,
};

fn unavailable(error: sqlx::Error) -> RecordsError {
    RecordsError::Unavailable(error.to_string())
}

fn is_unique_violation(error: &sqlx::Error) -> bool {
    matches!(error, sqlx::Error::Database(e) if e.is_unique_violation())
}

fn stamp(row: &AnyRow, id: &str) -> Result<Stamp, sqlx::Error> {
    Ok(Stamp {
        id: row.try_get(id)?,
        created_at: row.try_get("created_at")?,
        created_by: row.try_get("created_by")?,
        // A head (measurement or plan in a history) reads only what its covering index holds.
        computed_by: row.try_get("computed_by").unwrap_or_default(),
    })
}

fn profile(row: AnyRow) -> Result<ProfileRecord, sqlx::Error> {
    Ok(ProfileRecord {
        stamp: stamp(&row, "name")?,
        body: row.try_get("body")?,
    })
}

fn calibration(row: AnyRow) -> Result<CalibrationRecord, sqlx::Error> {
    Ok(CalibrationRecord {
        stamp: stamp(&row, "id")?,
        profile: row.try_get("profile")?,
        request: row.try_get("request")?,
        result: row.try_get("result")?,
        process: row.try_get("process")?,
        preston_coefficient_m2_per_n: row.try_get("preston_coefficient_m2_per_n")?,
        standard_error_m2_per_n: row.try_get("standard_error_m2_per_n")?,
        run: row.try_get("run")?,
    })
}

fn part(row: AnyRow) -> Result<PartRecord, sqlx::Error> {
    Ok(PartRecord {
        stamp: stamp(&row, "id")?,
        name: row.try_get("name")?,
        process_profile: row.try_get("process_profile")?,
        body: row.try_get("body")?,
    })
}

fn measurement(row: AnyRow) -> Result<MeasurementRecord, sqlx::Error> {
    Ok(MeasurementRecord {
        stamp: stamp(&row, "id")?,
        part: row.try_get("part")?,
        request: row.try_get("request")?,
        result: row.try_get("result")?,
        rms_nm: row.try_get("rms_nm")?,
        map_sha256: row.try_get("map_sha256")?,
    })
}

fn measurement_head(row: AnyRow) -> Result<MeasurementHead, sqlx::Error> {
    Ok(MeasurementHead {
        stamp: stamp(&row, "id")?,
        rms_nm: row.try_get("rms_nm")?,
    })
}

fn plan_head(row: AnyRow) -> Result<PlanHead, sqlx::Error> {
    Ok(PlanHead {
        stamp: stamp(&row, "id")?,
        measurement: row.try_get("measurement")?,
        predicted_rms_after_nm: row.try_get("predicted_rms_after_nm")?,
    })
}

fn plan(row: AnyRow) -> Result<PlanRecord, sqlx::Error> {
    Ok(PlanRecord {
        stamp: stamp(&row, "id")?,
        part: row.try_get("part")?,
        measurement: row.try_get("measurement")?,
        request: row.try_get("request")?,
        result: row.try_get("result")?,
        predicted_rms_after_nm: row.try_get("predicted_rms_after_nm")?,
    })
}

fn run(row: AnyRow) -> Result<RunRecord, sqlx::Error> {
    Ok(RunRecord {
        stamp: stamp(&row, "id")?,
        part: row.try_get("part")?,
        plan: row.try_get("plan")?,
        started_at: row.try_get("started_at")?,
        finished_at: row.try_get("finished_at")?,
        machine: row.try_get("machine")?,
        notes: row.try_get("notes")?,
    })
}

const CALIBRATION_COLUMNS: &str = "id, profile, request, result, process, \
    preston_coefficient_m2_per_n, standard_error_m2_per_n, run, created_at, created_by, \
    computed_by";

async fn insert(tx: &mut Transaction<'_, Any>, record: &Record) -> Result<(), sqlx::Error> {
    let query = match record {
        Record::Profile(p) => sqlx::query(
            "INSERT INTO process_profiles (name, body, created_at, created_by, computed_by) \
             VALUES ($1, $2, $3, $4, $5)",
        )
        .bind(&p.stamp.id)
        .bind(&p.body)
        .bind(&p.stamp.created_at)
        .bind(&p.stamp.created_by)
        .bind(&p.stamp.computed_by),
        Record::Calibration(c) => sqlx::query(
            "INSERT INTO calibrations (id, profile, request, result, process, \
             preston_coefficient_m2_per_n, standard_error_m2_per_n, run, learned, created_at, \
             created_by, computed_by) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12)",
        )
        .bind(&c.stamp.id)
        .bind(&c.profile)
        .bind(&c.request)
        .bind(&c.result)
        .bind(&c.process)
        .bind(c.preston_coefficient_m2_per_n)
        .bind(c.standard_error_m2_per_n)
        .bind(&c.run)
        .bind(c.from_run())
        .bind(&c.stamp.created_at)
        .bind(&c.stamp.created_by)
        .bind(&c.stamp.computed_by),
        Record::Part(p) => sqlx::query(
            "INSERT INTO parts (id, name, process_profile, body, created_at, created_by, \
             computed_by) VALUES ($1, $2, $3, $4, $5, $6, $7)",
        )
        .bind(&p.stamp.id)
        .bind(&p.name)
        .bind(&p.process_profile)
        .bind(&p.body)
        .bind(&p.stamp.created_at)
        .bind(&p.stamp.created_by)
        .bind(&p.stamp.computed_by),
        Record::Measurement(m) => sqlx::query(
            "INSERT INTO measurements (id, part, request, result, rms_nm, created_at, \
             created_by, computed_by, map_sha256) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)",
        )
        .bind(&m.stamp.id)
        .bind(&m.part)
        .bind(&m.request)
        .bind(&m.result)
        .bind(m.rms_nm)
        .bind(&m.stamp.created_at)
        .bind(&m.stamp.created_by)
        .bind(&m.stamp.computed_by)
        .bind(&m.map_sha256),
        Record::Plan(p) => sqlx::query(
            "INSERT INTO plans (id, part, measurement, request, result, \
             predicted_rms_after_nm, created_at, created_by, computed_by) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)",
        )
        .bind(&p.stamp.id)
        .bind(&p.part)
        .bind(&p.measurement)
        .bind(&p.request)
        .bind(&p.result)
        .bind(p.predicted_rms_after_nm)
        .bind(&p.stamp.created_at)
        .bind(&p.stamp.created_by)
        .bind(&p.stamp.computed_by),
        Record::Run(r) => sqlx::query(
            "INSERT INTO runs (id, part, plan, started_at, finished_at, machine, notes, \
             created_at, created_by, computed_by) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10)",
        )
        .bind(&r.stamp.id)
        .bind(&r.part)
        .bind(&r.plan)
        .bind(&r.started_at)
        .bind(&r.finished_at)
        .bind(&r.machine)
        .bind(&r.notes)
        .bind(&r.stamp.created_at)
        .bind(&r.stamp.created_by)
        .bind(&r.stamp.computed_by),
    };
    query.execute(&mut **tx).await.map(|_| ())
}

impl Store {
    async fn one<T>(
        &self,
        sql: &str,
        key: &str,
        map: fn(AnyRow) -> Result<T, sqlx::Error>,
    ) -> Result<Option<T>, RecordsError> {
        self.ready().await?;
        let row = sqlx::query(sql)
            .bind(key)
            .fetch_optional(&self.pool)
            .await
            .map_err(unavailable)?;
        row.map(map).transpose().map_err(unavailable)
    }

    async fn all<T>(
        &self,
        sql: &str,
        key: &str,
        map: fn(AnyRow) -> Result<T, sqlx::Error>,
    ) -> Result<Vec<T>, RecordsError> {
        self.ready().await?;
        let rows = sqlx::query(sql)
            .bind(key)
            .fetch_all(&self.pool)
            .await
            .map_err(unavailable)?;
        rows.into_iter()
            .map(map)
            .collect::<Result<_, _>>()
            .map_err(unavailable)
    }

    async fn try_write(
        &self,
        records: &[Record],
        claim: Option<&Claim>,
    ) -> Result<Written, sqlx::Error> {
        let mut tx = self.pool.begin().await?;
        if let Some(claim) = claim {
            let claimed = sqlx::query(
                "INSERT INTO idempotency_keys (owner, key, fingerprint, status, location, body, \
                 record_id, created_at) VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
            )
            .bind(&claim.owner)
            .bind(&claim.key)
            .bind(&claim.fingerprint)
            .bind(i64::from(claim.answer.status))
            .bind(&claim.answer.location)
            .bind(&claim.answer.body)
            .bind(&claim.answer.record)
            .bind(now())
            .execute(&mut *tx)
            .await;
            if let Err(e) = claimed {
                tx.rollback().await?;
                if !is_unique_violation(&e) {
                    return Err(e);
                }
                return Ok(match self.claimed_row(&claim.owner, &claim.key).await? {
                    Some((fingerprint, replay)) if fingerprint == claim.fingerprint => {
                        Written::Replayed(replay)
                    }
                    _ => Written::KeyReused,
                });
            }
        }
        for record in records {
            if let Err(e) = insert(&mut tx, record).await {
                tx.rollback().await?;
                return if is_unique_violation(&e) {
                    Ok(Written::Taken)
                } else {
                    Err(e)
                };
            }
        }
        tx.commit().await?;
        Ok(Written::Committed)
    }

    async fn claimed_row(
        &self,
        owner: &str,
        key: &str,
    ) -> Result<Option<(String, Replay)>, sqlx::Error> {
        let row = sqlx::query(
            "SELECT fingerprint, status, location, body, record_id FROM idempotency_keys \
             WHERE owner = $1 AND key = $2",
        )
        .bind(owner)
        .bind(key)
        .fetch_optional(&self.pool)
        .await?;
        row.map(|row| {
            let status: i64 = row.try_get("status")?;
            Ok((
                row.try_get("fingerprint")?,
                Replay {
                    status: u16::try_from(status).unwrap_or(500),
                    location: row.try_get("location")?,
                    record: row.try_get("record_id")?,
                    body: row.try_get("body")?,
                },
            ))
        })
        .transpose()
    }
}

impl Records for Store {
    async fn write(
        &self,
        records: &[Record],
        claim: Option<&Claim>,
    ) -> Result<Written, RecordsError> {
        self.ready().await?;
        self.try_write(records, claim).await.map_err(unavailable)
    }

    async fn claimed(
        &self,
        owner: &str,
        key: &str,
    ) -> Result<Option<(String, Replay)>, RecordsError> {
        self.ready().await?;
        self.claimed_row(owner, key).await.map_err(unavailable)
    }

    async fn profile(&self, name: &str) -> Result<Option<ProfileRecord>, RecordsError> {
        self.one(
            "SELECT name, body, created_at, created_by, computed_by FROM process_profiles \
             WHERE name = $1",
            name,
            profile,
        )
        .await
    }

    async fn profiles(&self) -> Result<Vec<ProfileRecord>, RecordsError> {
        self.ready().await?;
        let rows = sqlx::query(
            "SELECT name, body, created_at, created_by, computed_by FROM process_profiles \
             ORDER BY name",
        )
        .fetch_all(&self.pool)
        .await
        .map_err(unavailable)?;
        rows.into_iter()
            .map(profile)
            .collect::<Result<_, _>>()
            .map_err(unavailable)
    }

    async fn calibrations(&self, profile: &str) -> Result<Vec<CalibrationRecord>, RecordsError> {
        let sql = format!(
            "SELECT {CALIBRATION_COLUMNS} FROM calibrations WHERE profile = $1 ORDER BY id"
        );
        self.all(&sql, profile, calibration).await
    }

    async fn calibration(&self, id: &str) -> Result<Option<CalibrationRecord>, RecordsError> {
        let sql = format!("SELECT {CALIBRATION_COLUMNS} FROM calibrations WHERE id = $1");
        self.one(&sql, id, calibration).await
    }

    async fn part(&self, id: &str) -> Result<Option<PartRecord>, RecordsError> {
        self.one("SELECT * FROM parts WHERE id = $1", id, part)
            .await
    }

    async fn parts(
        &self,
        cursor: Option<&str>,
        limit: usize,
        name: Option<&str>,
    ) -> Result<PartsPage, RecordsError> {
        self.ready().await?;
        // One more than asked: whether a next page exists.
        let rows = sqlx::query(
            "SELECT * FROM parts WHERE id > $1 AND ($2 = '' OR name = $2) ORDER BY id LIMIT $3",
        )
        .bind(cursor.unwrap_or(""))
        .bind(name.unwrap_or(""))
        .bind(i64::try_from(limit + 1).unwrap_or(i64::MAX))
        .fetch_all(&self.pool)
        .await
        .map_err(unavailable)?;
        let mut items: Vec<PartRecord> = rows
            .into_iter()
            .map(part)
            .collect::<Result<_, _>>()
            .map_err(unavailable)?;
        let next_cursor = if items.len() > limit {
            items.truncate(limit);
            items.last().map(|p| p.stamp.id.clone())
        } else {
            None
        };
        Ok(PartsPage { items, next_cursor })
    }

    async fn measurements(&self, part: &str) -> Result<Vec<MeasurementHead>, RecordsError> {
        self.all(
            "SELECT id, rms_nm, created_at, created_by FROM measurements WHERE part = $1 \
             ORDER BY id",
            part,
            measurement_head,
        )
        .await
    }

    async fn measurement(&self, id: &str) -> Result<Option<MeasurementRecord>, RecordsError> {
        self.one("SELECT * FROM measurements WHERE id = $1", id, measurement)
            .await
    }

    async fn plans(&self, part: &str) -> Result<Vec<PlanHead>, RecordsError> {
        self.all(
            "SELECT id, measurement, predicted_rms_after_nm, created_at, created_by FROM plans \
             WHERE part = $1 ORDER BY id",
            part,
            plan_head,
        )
        .await
    }

    async fn plan(&self, id: &str) -> Result<Option<PlanRecord>, RecordsError> {
        self.one("SELECT * FROM plans WHERE id = $1", id, plan)
            .await
    }

    async fn runs(&self, part: &str) -> Result<Vec<RunRecord>, RecordsError> {
        self.all("SELECT * FROM runs WHERE part = $1 ORDER BY id", part, run)
            .await
    }

    async fn run(&self, id: &str) -> Result<Option<RunRecord>, RecordsError> {
        self.one("SELECT * FROM runs WHERE id = $1", id, run).await
    }
}
