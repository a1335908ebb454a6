//! API keys: the keys file and the set of keys it gives.
//!
//! The keys file holds one key per line as `name:<SHA-256 of the key, 64 hex digits>`, optionally
//! followed by `:read` (the key may compute and read records but not write them; without a role
//! a key reads and writes); `#` starts a comment, blank lines are ignored. It never holds the keys themselves. A presented
//! key is hashed and its digest compared with every stored digest in full, folding the byte
//! differences with OR and never stopping early, so the time taken does not depend on where (or
//! whether) a digest differs, nor on which key matched.
//!
//! The set is replaced atomically on reload (SIGHUP, see `server.rs`); a malformed file keeps
//! the old set. `http::auth` is the middleware that asks for a key.

use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

use sha2::{Digest, Sha256};

/// Why a keys file was refused: the line (1-based) and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum KeysFileError {
    #[error("cannot read {path}: {reason}")]
    Unreadable { path: String, reason: String },
    #[error("{path}, line {line}: {reason}")]
    Line {
        path: String,
        line: usize,
        reason: String,
    },
}

/// What a key may do.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Role {
    /// Compute, read and write records (a line without a role).
    #[default]
    ReadWrite,
    /// Compute and read records (`:read`).
    Read,
}

/// The configured keys: names, the SHA-256 digests of the keys and their roles.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct KeySet {
    keys: Vec<(String, [u8; 32], Role)>,
}

fn hex_digest(text: &str) -> Option<[u8; 32]> {
    if text.len() != 64 || !text.is_ascii() {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, byte) in out.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&text[2 * i..2 * i + 2], 16).ok()?;
    }
    Some(out)
}

impl KeySet {
    /// Parses a keys file's text; `path` only names the file in errors.
    pub fn parse(text: &str, path: &str) -> Result<Self, KeysFileError> {
        let mut keys: Vec<(String, [u8; 32], Role)> = Vec::new();
        for (index, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let refuse = |reason: String| KeysFileError::Line {
                path: path.to_string(),
                line: index + 1,
                reason,
            };
            let Some((name, digest)) = line.split_once(':') else {
                return Err(refuse(
                    "expected name:<sha-256 hex of the key>, found no ':'".into(),
                ));
            };
            let (digest, role) = match digest.split_once(':') {
                None => (digest, Role::ReadWrite),
                Some((digest, role)) if role.trim() == "read" => (digest, Role::Read),
                Some((_, role)) => {
                    return Err(refuse(format!(
                        "the role {:?} is not known: the only role is `read` (a line without one \
                         reads and writes)",
                        role.trim()
                    )))
                }
            };
            let (name, digest) = (name.trim(), digest.trim());
            let name_ok = !name.is_empty()
                && name.len() <= 64
                && name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
            if !name_ok {
                return Err(refuse(format!(
                    "the name {name:?} must be 1 to 64 of A–Z, a–z, 0–9, '-', '_', '.'"
                )));
            }
            let Some(digest) = hex_digest(digest) else {
                return Err(refuse(format!(
                    "the key's SHA-256 must be 64 hex digits, found {} characters",
                    digest.chars().count()
                )));
            };
            if keys.iter().any(|(n, _, _)| n == name) {
                return Err(refuse(format!("the name {name:?} appears twice")));
            }
            if keys.iter().any(|(_, d, _)| *d == digest) {
                return Err(refuse("this key's digest appears twice".into()));
            }
            keys.push((name.to_string(), digest, role));
        }
        Ok(KeySet { keys })
    }

    /// Reads and parses the keys file at `path`.
    pub fn load(path: &Path) -> Result<Self, KeysFileError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| KeysFileError::Unreadable {
            path: shown.clone(),
            reason: e.to_string(),
        })?;
        KeySet::parse(&text, &shown)
    }

    pub fn len(&self) -> usize {
        self.keys.len()
    }

    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The name and role of the key `presented`, comparing its digest with every stored one
    /// in full.
    pub fn identify(&self, presented: &str) -> Option<(&str, Role)> {
        let digest: [u8; 32] = Sha256::digest(presented.as_bytes()).into();
        let mut found = None;
        for (name, stored, role) in &self.keys {
            let difference = stored
                .iter()
                .zip(&digest)
                .fold(0u8, |acc, (a, b)| acc | (a ^ b));
            // No early exit: every digest is compared whatever matched before.
            if std::hint::black_box(difference) == 0 {
                found = Some((name.as_str(), *role));
            }
        }
        found
    }
}

/// Authentication as configured: the keys (replaced on reload) and what they guard.
#[derive(Debug)]
pub struct Auth {
    path: PathBuf,
    keys: RwLock<Arc<KeySet>>,
    /// Whether `/metrics` needs a key too.
    pub metrics_need_key: bool,
}

impl Auth {
    /// Loads the keys file; a malformed file is an error naming the line.
    pub fn load(path: PathBuf, metrics_need_key: bool) -> Result<Self, KeysFileError> {
        let keys = KeySet::load(&path)?;
        Ok(Auth {
            path,
            keys: RwLock::new(Arc::new(keys)),
            metrics_need_key,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Reads the file again: the new set on success (how many keys), the old one kept on error.
    pub fn reload(&self) -> Result<usize, KeysFileError> {
        let keys = KeySet::load(&self.path)?;
        let count = keys.len();
        if let Ok(mut held) = self.keys.write() {
            *held = Arc::new(keys);
        }
        Ok(count)
    }

    /// The keys now in force.
    pub fn keys(&self) -> Arc<KeySet> {
        self.keys
            .read()
            .map(|k| k.clone())
            .unwrap_or_else(|poisoned| poisoned.into_inner().clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn digest_hex(key: &str) -> String {
        Sha256::digest(key.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }

    #[test]
    fn a_keys_file_parses_and_identifies_keys_by_their_digest() {
        let text = format!(
            "# shop keys\n\nmes:{}\n  engineering-desk : {}  # Anna's batch scripts\nviewer:{}:read\n",
            digest_hex("s3cret-mes"),
            digest_hex("other key").to_uppercase(),
            digest_hex("look only"),
        );
        let keys = KeySet::parse(&text, "keys").unwrap();
        assert_eq!(keys.len(), 3);
        assert_eq!(keys.identify("s3cret-mes"), Some(("mes", Role::ReadWrite)));
        assert_eq!(
            keys.identify("other key"),
            Some(("engineering-desk", Role::ReadWrite))
        );
        assert_eq!(keys.identify("look only"), Some(("viewer", Role::Read)));
        assert_eq!(keys.identify("s3cret-mes "), None);
        assert_eq!(keys.identify(""), None);
        assert!(KeySet::parse("# nothing\n\n", "keys").unwrap().is_empty());
    }

    #[test]
    fn a_malformed_keys_file_is_refused_naming_the_line() {
        let good = format!("mes:{}", digest_hex("a"));
        let cases = [
            (format!("{good}\nno-colon-here\n"), 2, "no ':'"),
            (
                format!("\n\nmes:{}", &digest_hex("a")[..63]),
                3,
                "64 hex digits",
            ),
            (format!("mes:{}", "g".repeat(64)), 1, "64 hex digits"),
            (format!(":{}", digest_hex("a")), 1, "the name"),
            (
                format!("mes:{}:write", digest_hex("a")),
                1,
                "the only role is `read`",
            ),
            (format!("a b:{}", digest_hex("a")), 1, "the name"),
            (
                format!("{good}\nmes:{}", digest_hex("b")),
                2,
                "appears twice",
            ),
            (
                format!("{good}\nerp:{}", digest_hex("a")),
                2,
                "appears twice",
            ),
        ];
        for (text, line, says) in cases {
            match KeySet::parse(&text, "keys.txt") {
                Err(e @ KeysFileError::Line { line: l, .. }) => {
                    assert_eq!(l, line, "{text:?}: {e}");
                    let shown = e.to_string();
                    assert!(
                        shown.starts_with(&format!("keys.txt, line {line}: ")),
                        "{shown}"
                    );
                    assert!(shown.contains(says), "{shown}");
                }
                other => panic!("{text:?}: {other:?}"),
            }
        }
    }
}
