//! Signing model blobs for the edge (core's [`dynotraj_core::model::signed`] format): key pairs
//! as hex files, signing, and checking a signed file against a public key.
//!
//! A key file holds one line: a label saying which key it is, then 64 hex digits, the 32-byte
//! Ed25519 secret seed (`dynotraj-ed25519-secret ...`, `.key`, written owner-only) or the
//! public key (`dynotraj-ed25519-public ...`, `.pub`), so that one is never taken for the
//! other. A bare line of 64 hex digits (files from before the labels) is read as the kind its
//! extension says. The edge is provisioned with a `.pub` at build time
//! (`DYNOTRAJ_MODEL_PUBKEY`, see edge/build.rs).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};
use dynotraj_core::model::signed::{self, PublicKey, SIGNATURE_MAGIC, SignatureError, key_id};
use ed25519_dalek::{Signer as _, SigningKey};

/// The development key pair in the repository (`keys/dev-model-signing.{key,pub}`), compiled in:
/// what tests and unprovisioned builds use. Its secret is public, so it protects nothing; see
/// docs/security.md.
const DEVELOPMENT_SECRET: &str = include_str!("../../keys/dev-model-signing.key");
/// The development public key (what an unprovisioned edge trusts).
const DEVELOPMENT_PUBLIC: &str = include_str!("../../keys/dev-model-signing.pub");

/// Which key of a pair a file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyKind {
    /// The secret seed: signs; stays with whoever releases models.
    Secret,
    /// The public key: verifies; what the edge is built with.
    Public,
}

impl KeyKind {
    /// The label that starts a key file of this kind.
    #[must_use]
    pub const fn label(self) -> &'static str {
        match self {
            Self::Secret => "dynotraj-ed25519-secret",
            Self::Public => "dynotraj-ed25519-public",
        }
    }

    /// The file extension `dynotraj keygen` gives this kind.
    #[must_use]
    pub const fn extension(self) -> &'static str {
        match self {
            Self::Secret => "key",
            Self::Public => "pub",
        }
    }

    const fn other(self) -> Self {
        match self {
            Self::Secret => Self::Public,
            Self::Public => Self::Secret,
        }
    }

    const fn name(self) -> &'static str {
        match self {
            Self::Secret => "secret",
            Self::Public => "public",
        }
    }

    /// What a command that needs this kind uses it for.
    const fn use_of(self) -> &'static str {
        match self {
            Self::Secret => "signing needs the secret key (NAME.key from `dynotraj keygen`)",
            Self::Public => "checking a signature needs the public key (NAME.pub); the secret stays with whoever signs",
        }
    }

    /// One key file's text.
    fn file_text(self, key: &[u8; 32]) -> String {
        format!("{} {}\n", self.label(), hex(key))
    }
}

/// The 32 key bytes of a key file's `text` that must hold a `want` key; `what` names the file.
/// A bare line of hex digits is taken as `bare_kind` (`None`: as `want`).
///
/// # Errors
/// The other kind of key (by its label, or for a bare line by `bare_kind`), or not 64 hex
/// digits; the message names `what` and says which key is needed.
pub fn parse_key(text: &str, what: &str, want: KeyKind, bare_kind: Option<KeyKind>) -> anyhow::Result<[u8; 32]> {
    let t = text.trim();
    let labelled = [KeyKind::Secret, KeyKind::Public].into_iter().find_map(|k| {
        t.strip_prefix(k.label()).filter(|rest| rest.starts_with(char::is_whitespace)).map(|rest| (k, rest.trim()))
    });
    let (found, digits) = labelled.map_or((bare_kind.unwrap_or(want), t), |(k, d)| (k, d));
    if found != want {
        bail!("{what}: this is a {} key; {}", found.name(), want.use_of());
    }
    parse_hex32(digits, what)
}

/// Writes a new key pair `DIR/NAME.key` (secret seed, mode 0600 on Unix) and `DIR/NAME.pub`;
/// returns both paths. Refuses to overwrite an existing secret.
///
/// # Errors
/// No randomness from the OS, an existing `.key`, or a file that cannot be written.
pub fn keygen(dir: &Path, name: &str) -> anyhow::Result<(PathBuf, PathBuf)> {
    let mut seed = [0u8; 32];
    getrandom::fill(&mut seed).map_err(|e| anyhow::anyhow!("no randomness from the OS: {e}"))?;
    let key = SigningKey::from_bytes(&seed);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let (secret, public) = (dir.join(format!("{name}.key")), dir.join(format!("{name}.pub")));
    if secret.exists() {
        bail!("{}: a secret key is already there; not overwriting it", secret.display());
    }
    write_secret(&secret, &KeyKind::Secret.file_text(&seed))?;
    crate::atomic::write_file(&public, KeyKind::Public.file_text(key.verifying_key().as_bytes()))
        .with_context(|| format!("writing {}", public.display()))?;
    Ok((secret, public))
}

#[cfg(unix)]
fn write_secret(path: &Path, text: &str) -> anyhow::Result<()> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .with_context(|| format!("creating {}", path.display()))?;
    f.write_all(text.as_bytes()).with_context(|| format!("writing {}", path.display()))
}

#[cfg(not(unix))]
fn write_secret(path: &Path, text: &str) -> anyhow::Result<()> {
    crate::atomic::write_file(path, text).with_context(|| format!("writing {}", path.display()))
}

/// Lowercase hex of `bytes`.
#[must_use]
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// 32 bytes from one line of 64 hex digits (surrounding whitespace ignored).
///
/// # Errors
/// Names `what` and says what was found instead.
pub fn parse_hex32(text: &str, what: &str) -> anyhow::Result<[u8; 32]> {
    let t = text.trim();
    if t.len() != 64 {
        bail!("{what}: expected 64 hex digits (32 bytes), found {} characters", t.len());
    }
    let mut out = [0u8; 32];
    for (i, o) in out.iter_mut().enumerate() {
        let pair = t.get(2 * i..2 * i + 2).unwrap_or("");
        *o = u8::from_str_radix(pair, 16)
            .map_err(|_| anyhow::anyhow!("{what}: '{pair}' at character {} is not hex", 2 * i + 1))?;
    }
    Ok(out)
}

/// The key in the file at `path`, which must be a `want` key (a bare hex line is the kind its
/// extension says, else taken as `want`).
fn read_key(path: &Path, want: KeyKind) -> anyhow::Result<[u8; 32]> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading key {}", path.display()))?;
    let ext = path.extension().and_then(|e| e.to_str());
    let bare_kind = [want, want.other()].into_iter().find(|k| ext == Some(k.extension()));
    parse_key(&text, &path.display().to_string(), want, bare_kind)
}

/// Reads a secret key file.
///
/// # Errors
/// A missing file, a public key, or not a key file.
pub fn read_signing_key(path: &Path) -> anyhow::Result<SigningKey> {
    Ok(SigningKey::from_bytes(&read_key(path, KeyKind::Secret)?))
}

/// Reads a public key file.
///
/// # Errors
/// A missing file, a secret key, or not a key file.
pub fn read_public_key(path: &Path) -> anyhow::Result<PublicKey> {
    read_key(path, KeyKind::Public)
}

/// `blob` with its signature trailer by `key`.
#[must_use]
pub fn sign(blob: &[u8], key: &SigningKey) -> Vec<u8> {
    let mut out = Vec::with_capacity(blob.len() + signed::TRAILER_LEN);
    out.extend_from_slice(blob);
    out.extend_from_slice(&SIGNATURE_MAGIC);
    out.extend_from_slice(&key_id(key.verifying_key().as_bytes()));
    let signature = key.sign(&out);
    out.extend_from_slice(&signature.to_bytes());
    out
}

/// The repository's development signing key (tests and unprovisioned builds).
///
/// # Errors
/// The compiled-in key is malformed (a broken checkout).
pub fn development_signing_key() -> anyhow::Result<SigningKey> {
    Ok(SigningKey::from_bytes(&parse_key(DEVELOPMENT_SECRET, "keys/dev-model-signing.key", KeyKind::Secret, None)?))
}

/// The repository's development public key.
///
/// # Errors
/// The compiled-in key is malformed (a broken checkout).
pub fn development_public_key() -> anyhow::Result<PublicKey> {
    parse_key(DEVELOPMENT_PUBLIC, "keys/dev-model-signing.pub", KeyKind::Public, None)
}

/// Checks a signed file's bytes against `key`; returns the blob.
///
/// # Errors
/// The refusal, in words, naming `what`.
pub fn verify<'a>(signed_bytes: &'a [u8], key: &PublicKey, what: &str) -> anyhow::Result<&'a [u8]> {
    signed::verify(signed_bytes, key).map_err(|e| anyhow::anyhow!("{what}: {}", describe(&e)))
}

/// A refusal in words.
#[must_use]
pub fn describe(e: &SignatureError) -> String {
    match e {
        SignatureError::Unsigned => "not signed (no DTSG trailer): sign it with `dynotraj sign`".into(),
        SignatureError::OtherKey { found, expected } => {
            format!("signed by key {}, but the key expected is {}", hex(found), hex(expected))
        }
        SignatureError::BadKey => "the public key is not a valid Ed25519 key".into(),
        SignatureError::BadSignature => "the signature does not verify: the file was changed after signing".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signed_blob_verifies_and_any_changed_byte_is_refused() {
        let key = SigningKey::from_bytes(&[3u8; 32]);
        let public = *key.verifying_key().as_bytes();
        let blob: Vec<u8> = (0..300u32).map(|i| (i * 7) as u8).collect();
        let s = sign(&blob, &key);
        assert_eq!(signed::verify(&s, &public), Ok(&blob[..]));
        for at in [0, 150, blob.len(), blob.len() + 5, s.len() - 1] {
            let mut bad = s.clone();
            bad[at] ^= 0x40;
            assert!(signed::verify(&bad, &public).is_err(), "byte {at} changed");
        }
        let other = SigningKey::from_bytes(&[4u8; 32]);
        assert!(matches!(signed::verify(&sign(&blob, &other), &public), Err(SignatureError::OtherKey { .. })));
        assert_eq!(signed::verify(&blob, &public), Err(SignatureError::Unsigned));
    }

    #[test]
    fn key_files_round_trip_and_bad_ones_name_the_problem() {
        let dir = std::env::temp_dir().join(format!("dynotraj-keygen-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (secret, public) = keygen(&dir, "k").unwrap();
        let key = read_signing_key(&secret).unwrap();
        assert_eq!(read_public_key(&public).unwrap(), *key.verifying_key().as_bytes());
        assert!(keygen(&dir, "k").unwrap_err().to_string().contains("not overwriting"));
        let e = parse_hex32("abc", "f.pub").unwrap_err().to_string();
        assert!(e.contains("f.pub") && e.contains("64 hex digits"), "{e}");
        let e = parse_hex32(&"zz".repeat(32), "f.pub").unwrap_err().to_string();
        assert!(e.contains("'zz' at character 1"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_development_key_pair_in_the_repository_matches() {
        let key = development_signing_key().unwrap();
        assert_eq!(development_public_key().unwrap(), *key.verifying_key().as_bytes());
    }

    #[test]
    fn key_files_say_which_key_they_hold_and_the_other_kind_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (secret, public) = keygen(dir.path(), "k").unwrap();
        assert!(std::fs::read_to_string(&secret).unwrap().starts_with("dynotraj-ed25519-secret "));
        assert!(std::fs::read_to_string(&public).unwrap().starts_with("dynotraj-ed25519-public "));
        let key = read_signing_key(&secret).unwrap();
        assert_eq!(read_public_key(&public).unwrap(), *key.verifying_key().as_bytes());
        let err = read_signing_key(&public).unwrap_err().to_string();
        assert!(err.contains("k.pub: this is a public key; signing needs the secret key"), "{err}");
        let err = read_public_key(&secret).unwrap_err().to_string();
        assert!(err.contains("k.key: this is a secret key; checking a signature needs the public key"), "{err}");
        // A bare hex line (a file from before the labels) is the kind its extension says.
        let bare_pub = dir.path().join("old.pub");
        std::fs::write(&bare_pub, format!("{}\n", hex(key.verifying_key().as_bytes()))).unwrap();
        assert!(read_signing_key(&bare_pub).unwrap_err().to_string().contains("this is a public key"));
        assert_eq!(read_public_key(&bare_pub).unwrap(), *key.verifying_key().as_bytes());
        let err = parse_key("dynotraj-ed25519-public 12", "x", KeyKind::Public, None).unwrap_err().to_string();
        assert!(err.contains("x: expected 64 hex digits"), "{err}");
    }
}
