//! Signing model blobs for the edge (core's [`dynotraj_core::model::signed`] format): key pairs
//! as hex files, signing, and checking a signed file against a public key.
//!
//! A key file holds one line of 64 hex digits: the 32-byte Ed25519 secret seed (`.key`,
//! written owner-only) or the public key (`.pub`). The edge is provisioned with a `.pub` at
//! build time (`DYNOTRAJ_MODEL_PUBKEY`, see edge/build.rs).

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
    write_secret(&secret, &format!("{}\n", hex(&seed)))?;
    std::fs::write(&public, format!("{}\n", hex(key.verifying_key().as_bytes())))
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
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
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

fn read_hex32(path: &Path) -> anyhow::Result<[u8; 32]> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading key {}", path.display()))?;
    parse_hex32(&text, &path.display().to_string())
}

/// Reads a secret key file.
///
/// # Errors
/// A missing file or one that is not 64 hex digits.
pub fn read_signing_key(path: &Path) -> anyhow::Result<SigningKey> {
    Ok(SigningKey::from_bytes(&read_hex32(path)?))
}

/// Reads a public key file.
///
/// # Errors
/// A missing file or one that is not 64 hex digits.
pub fn read_public_key(path: &Path) -> anyhow::Result<PublicKey> {
    read_hex32(path)
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
    Ok(SigningKey::from_bytes(&parse_hex32(DEVELOPMENT_SECRET, "keys/dev-model-signing.key")?))
}

/// The repository's development public key.
///
/// # Errors
/// The compiled-in key is malformed (a broken checkout).
pub fn development_public_key() -> anyhow::Result<PublicKey> {
    parse_hex32(DEVELOPMENT_PUBLIC, "keys/dev-model-signing.pub")
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
}
