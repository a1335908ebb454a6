//! A record write: the caller's stamp on every record, and the Idempotency-Key's claim kept in
//! the write's own transaction.

use serde_json::Value;

use super::LedgerError;
use crate::store::{new_stamp, sha256_hex, Store};
use crate::usecases::records::{Claim, Record, Records, Replay, Stamp, Written};

/// A write in progress: the store, the writer (the API key's name) and the Idempotency-Key
/// claimed with the request's fingerprint.
pub struct Write<'s> {
    store: &'s Store,
    owner: String,
    claim: Option<KeyClaim>,
}

/// An Idempotency-Key and the request's fingerprints.
struct KeyClaim {
    key: String,
    fingerprint: String,
    /// The fingerprint a claim written before fingerprints were canonical has for the same
    /// request (the body as sent), so a retry across that upgrade still finds its first answer.
    sent_fingerprint: String,
}

/// `value` as JSON text with every object's members sorted by name (recursively), so that
/// two documents equal as JSON values have one text whatever order their members came in.
pub fn canonical(value: &Value) -> String {
    match value {
        Value::Object(members) => {
            let mut sorted: Vec<(&String, &Value)> = members.iter().collect();
            sorted.sort_by(|a, b| a.0.cmp(b.0));
            let inner: Vec<String> = sorted
                .into_iter()
                .map(|(name, v)| format!("{}:{}", Value::String(name.clone()), canonical(v)))
                .collect();
            format!("{{{}}}", inner.join(","))
        }
        Value::Array(items) => {
            let inner: Vec<String> = items.iter().map(canonical).collect();
            format!("[{}]", inner.join(","))
        }
        scalar => scalar.to_string(),
    }
}

/// The field a malformed or reused key is reported at.
const KEY: &str = "Idempotency-Key";

impl<'s> Write<'s> {
    /// Refuses a malformed Idempotency-Key (1 to 255 visible ASCII characters). The request's
    /// identity for the key is `operation` (method and path) and its `body` in canonical form
    /// ([`canonical`]): a retry that sends the same members in another order is the same
    /// request.
    pub fn begin(
        store: &'s Store,
        owner: &str,
        key: Option<&[u8]>,
        operation: &str,
        body: &Value,
    ) -> Result<Write<'s>, LedgerError> {
        // Fingerprints only for a write with a key: a measurement body may be large.
        let claim = match key {
            None => None,
            Some(key) => {
                if !(1..=255).contains(&key.len()) || !key.iter().all(u8::is_ascii_graphic) {
                    return Err(LedgerError::invalid(
                        KEY,
                        "an Idempotency-Key is 1 to 255 visible ASCII characters (a UUID will do)",
                    ));
                }
                Some(KeyClaim {
                    key: String::from_utf8_lossy(key).into_owned(),
                    fingerprint: sha256_hex(format!("{operation}\n{}", canonical(body)).as_bytes()),
                    sent_fingerprint: sha256_hex(format!("{operation}\n{body}").as_bytes()),
                })
            }
        };
        Ok(Write {
            store,
            owner: owner.to_string(),
            claim,
        })
    }

    /// The first answer under this key, when there is one (asked before any work is done).
    pub async fn replay(&self) -> Result<Option<Replay>, LedgerError> {
        let Some(claim) = &self.claim else {
            return Ok(None);
        };
        match self.store.claimed(&self.owner, &claim.key).await? {
            None => Ok(None),
            Some((first, replay))
                if first == claim.fingerprint || first == claim.sent_fingerprint =>
            {
                Ok(Some(replay))
            }
            Some(_) => Err(key_reused()),
        }
    }

    pub fn store(&self) -> &'s Store {
        self.store
    }

    /// A new record's stamp, with the writer's name.
    pub fn stamp(&self) -> Stamp {
        new_stamp(&self.owner)
    }

    /// Writes `records` (and the claim, naming `record`, the record the answer shows) in one
    /// transaction. [`Answer::Fresh`] once committed; [`Answer::Replay`] when a retry with the
    /// same key won meanwhile. `taken` is the caller's words when a record has a unique name.
    pub async fn commit(
        self,
        records: &[Record],
        location: String,
        record: String,
        taken: Option<&str>,
    ) -> Result<Answer, LedgerError> {
        let claim = self.claim.map(|claim| Claim {
            owner: self.owner.clone(),
            key: claim.key,
            fingerprint: claim.fingerprint,
            answer: Replay {
                status: 201,
                location,
                record,
                body: String::new(),
            },
        });
        match self.store.write(records, claim.as_ref()).await? {
            Written::Committed => Ok(Answer::Fresh),
            Written::Replayed(replay) => Ok(Answer::Replay(replay)),
            Written::KeyReused => Err(key_reused()),
            // Only a unique name can be taken; ids are fresh UUIDv7s.
            Written::Taken => Err(match taken {
                Some(taken) => LedgerError::Taken(taken.to_string()),
                None => LedgerError::Broken("a fresh record id collided".into()),
            }),
        }
    }
}

/// How a committed write is answered.
#[derive(Debug, Clone, PartialEq)]
pub enum Answer {
    /// The records were written: answer with them.
    Fresh,
    /// A retry under the same key had written them first: answer as it did.
    Replay(Replay),
}

/// 422, as the IETF's Idempotency-Key draft says for a key reused with another payload.
fn key_reused() -> LedgerError {
    LedgerError::invalid(
        KEY,
        "this Idempotency-Key was sent before with another request: use a new key for a new request",
    )
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    #[test]
    fn canonical_text_ignores_member_order_but_not_values() {
        let a = json!({"b": [1, {"y": 2, "x": null}], "a": "q\"uote", "c": 1.5});
        let b = json!({"c": 1.5, "a": "q\"uote", "b": [1, {"x": null, "y": 2}]});
        assert_eq!(super::canonical(&a), super::canonical(&b));
        assert_eq!(
            super::canonical(&a),
            r#"{"a":"q\"uote","b":[1,{"x":null,"y":2}],"c":1.5}"#
        );
        let reordered_list = json!({"b": [{"y": 2, "x": null}, 1], "a": "q\"uote", "c": 1.5});
        assert_ne!(super::canonical(&a), super::canonical(&reordered_list));
    }
}
