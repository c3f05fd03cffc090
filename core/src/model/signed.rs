//! Signed model blobs: a model blob with an Ed25519 signature trailer, and its check against
//! the public key an edge was provisioned with at build time.
//!
//! ```text
//! signed = blob || "DTSG" || key id (8 B) || signature (64 B)
//! ```
//!
//! The signature (RFC 8032 Ed25519, checked with `verify_strict`, which refuses small-order
//! keys and non-canonical encodings) covers every byte before it: the blob, the magic and the
//! key id. The key id is the first [`KEY_ID_LEN`] bytes of the signer's public key: it says which
//! key signed, so that a refusal can name the key that was expected and the one that was found.
//! It is a label, not a trust decision: only the signature is checked against the provisioned
//! key. The blob itself is parsed and CRC-checked by [`super::blob`] after the signature holds.

use ed25519_dalek::{Signature, VerifyingKey};

/// The four bytes that open the trailer.
pub const SIGNATURE_MAGIC: [u8; 4] = *b"DTSG";
pub use crate::limits::KEY_ID_LEN;
/// Bytes of an Ed25519 signature.
pub const SIGNATURE_LEN: usize = 64;
/// Bytes of an Ed25519 public key.
pub const PUBLIC_KEY_LEN: usize = 32;
/// Bytes the trailer adds to a blob.
pub const TRAILER_LEN: usize = SIGNATURE_MAGIC.len() + KEY_ID_LEN + SIGNATURE_LEN;

/// An Ed25519 public key as its 32 bytes.
pub type PublicKey = [u8; PUBLIC_KEY_LEN];

/// Why a signed blob was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SignatureError {
    /// No trailer: the bytes are shorter than one or do not end in a "DTSG" trailer (an
    /// unsigned blob).
    Unsigned,
    /// The trailer names another key than the one this edge trusts.
    OtherKey {
        /// The key id found in the trailer.
        found: [u8; KEY_ID_LEN],
        /// The key id of the provisioned key.
        expected: [u8; KEY_ID_LEN],
    },
    /// The provisioned key is not a valid Ed25519 point (a build provisioning error).
    BadKey,
    /// The signature does not verify under the provisioned key: the bytes were changed after
    /// signing, or signed by another key that claims this key's id.
    BadSignature,
}

/// The key id of `key`: its first [`KEY_ID_LEN`] bytes.
#[must_use]
pub fn key_id(key: &PublicKey) -> [u8; KEY_ID_LEN] {
    let mut id = [0u8; KEY_ID_LEN];
    for (d, s) in id.iter_mut().zip(key) {
        *d = *s;
    }
    id
}

/// The parts of a signed blob: what was signed, the blob within it, the key id and the
/// signature.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SignedParts<'a> {
    /// Every byte the signature covers (blob, magic, key id).
    pub message: &'a [u8],
    /// The model blob.
    pub blob: &'a [u8],
    /// The signer's key id.
    pub key_id: [u8; KEY_ID_LEN],
    /// The signature.
    pub signature: [u8; SIGNATURE_LEN],
}

/// Splits `signed` into its parts without checking the signature.
///
/// # Errors
/// [`SignatureError::Unsigned`] when there is no trailer.
pub fn split(signed: &[u8]) -> Result<SignedParts<'_>, SignatureError> {
    let Some(blob_len) = signed.len().checked_sub(TRAILER_LEN) else { return Err(SignatureError::Unsigned) };
    let (blob, trailer) = signed.split_at_checked(blob_len).ok_or(SignatureError::Unsigned)?;
    let (magic, rest) = trailer.split_at_checked(SIGNATURE_MAGIC.len()).ok_or(SignatureError::Unsigned)?;
    let (id, sig) = rest.split_at_checked(KEY_ID_LEN).ok_or(SignatureError::Unsigned)?;
    if magic != SIGNATURE_MAGIC {
        return Err(SignatureError::Unsigned);
    }
    let key_id: [u8; KEY_ID_LEN] = id.try_into().map_err(|_| SignatureError::Unsigned)?;
    let signature: [u8; SIGNATURE_LEN] = sig.try_into().map_err(|_| SignatureError::Unsigned)?;
    let message = signed.get(..blob_len + SIGNATURE_MAGIC.len() + KEY_ID_LEN).ok_or(SignatureError::Unsigned)?;
    Ok(SignedParts { message, blob, key_id, signature })
}

/// Checks the signature of `signed` against `key` and returns the blob it covers.
///
/// # Errors
/// See [`SignatureError`].
pub fn verify<'a>(signed: &'a [u8], key: &PublicKey) -> Result<&'a [u8], SignatureError> {
    let parts = split(signed)?;
    let expected = key_id(key);
    if parts.key_id != expected {
        return Err(SignatureError::OtherKey { found: parts.key_id, expected });
    }
    let key = VerifyingKey::from_bytes(key).map_err(|_| SignatureError::BadKey)?;
    key.verify_strict(parts.message, &Signature::from_bytes(&parts.signature))
        .map_err(|_| SignatureError::BadSignature)?;
    Ok(parts.blob)
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    // RFC 8032 section 7.1, test 1: the empty message under this key has this signature. The
    // trailer's own bytes are part of what is signed, so the vector checks the primitive and
    // the tests below check the format.
    const RFC_KEY: PublicKey = hex32("d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a");

    const fn nibble(c: u8) -> u8 {
        match c {
            b'0'..=b'9' => c - b'0',
            b'a'..=b'f' => c - b'a' + 10,
            _ => 0,
        }
    }

    const fn hex32(s: &str) -> [u8; 32] {
        let b = s.as_bytes();
        let mut out = [0u8; 32];
        let mut i = 0;
        while i < 32 {
            out[i] = nibble(b[2 * i]) << 4 | nibble(b[2 * i + 1]);
            i += 1;
        }
        out
    }

    #[test]
    fn the_rfc_8032_vector_verifies_with_the_primitive_used() {
        let sig_hex = "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b";
        let mut sig = [0u8; 64];
        for (i, s) in sig.iter_mut().enumerate() {
            *s = nibble(sig_hex.as_bytes()[2 * i]) << 4 | nibble(sig_hex.as_bytes()[2 * i + 1]);
        }
        let key = VerifyingKey::from_bytes(&RFC_KEY).unwrap();
        assert!(key.verify_strict(b"", &Signature::from_bytes(&sig)).is_ok());
        sig[0] ^= 1;
        assert!(key.verify_strict(b"", &Signature::from_bytes(&sig)).is_err());
    }

    #[test]
    fn unsigned_and_short_inputs_are_refused_as_unsigned() {
        for bytes in [&[][..], &[0u8; TRAILER_LEN - 1][..], &[0u8; 200][..]] {
            assert_eq!(verify(bytes, &RFC_KEY), Err(SignatureError::Unsigned));
        }
    }

    #[test]
    fn a_trailer_naming_another_key_is_refused_before_any_curve_arithmetic() {
        let mut signed = [0u8; 10 + TRAILER_LEN];
        signed[10..14].copy_from_slice(&SIGNATURE_MAGIC);
        let e = verify(&signed, &RFC_KEY);
        assert_eq!(e, Err(SignatureError::OtherKey { found: [0; 8], expected: key_id(&RFC_KEY) }));
    }

    #[test]
    fn a_forged_signature_under_the_right_key_id_is_refused() {
        let mut signed = [7u8; 10 + TRAILER_LEN];
        signed[10..14].copy_from_slice(&SIGNATURE_MAGIC);
        signed[14..22].copy_from_slice(&key_id(&RFC_KEY));
        assert_eq!(verify(&signed, &RFC_KEY), Err(SignatureError::BadSignature));
        let parts = split(&signed).unwrap();
        assert_eq!((parts.blob.len(), parts.message.len()), (10, 10 + 12));
    }
}
