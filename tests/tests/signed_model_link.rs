//! A model over the link is accepted only with a valid Ed25519 signature by the key the edge
//! was provisioned with (issue 8): signed, unsigned, signed by another key, changed after
//! signing and a forged key id, each streamed into the edge in front of the same 16-car frames.
//! A refused model is counted, the edge keeps forecasting with constant velocity, and every
//! answer is then bit-identical to an edge that never saw a model.

use dynotraj_core::model::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::model::signed::{SIGNATURE_LEN, SignatureError, TRAILER_LEN, key_id};
use dynotraj_core::wire::Message;
use dynotraj_edge::ModelStatus;
use dynotraj_edge::provisioned::MODEL_KEY;
use dynotraj_formats::model_signing::{development_public_key, development_signing_key, sign};
use dynotraj_sim::cost_inputs::random_blob;
use dynotraj_tests::edge_fixture::{InProcess, encode_all, host_messages, outputs, run_in_process, scene_tracks};
use ed25519_dalek::{Signer as _, SigningKey};

fn blob() -> Vec<u8> {
    random_blob(&Dims::DEFAULT, Precision::Int8, 0.05)
}

/// The edge's answers to the 16-car fixture with `sent` as the model over the link.
fn streamed(sent: Option<&[u8]>) -> InProcess {
    let tracks = scene_tracks(6);
    run_in_process(&encode_all(&host_messages(&tracks, sent)), &[])
}

fn forecasts(r: &InProcess) -> usize {
    r.replies.iter().filter(|m| matches!(m, Message::Prediction(_))).count()
}

/// Whether this build trusts the repository's development key (no DYNOTRAJ_MODEL_PUBKEY at
/// build time); the tests below sign with that key, so they skip, saying so, in a build
/// provisioned with another.
fn development_build() -> bool {
    let dev = dynotraj_edge::provisioned::MODEL_KEY_IS_DEVELOPMENT;
    if !dev {
        dynotraj_testkit::skipped(
            "signed_model_link",
            "the edge was built with DYNOTRAJ_MODEL_PUBKEY; these tests sign with the development key",
        );
    }
    dev
}

#[test]
fn the_test_build_trusts_the_repository_development_key() {
    if development_build() {
        assert_eq!(
            MODEL_KEY,
            development_public_key().unwrap(),
            "edge/build.rs provisions keys/dev-model-signing.pub unless told otherwise"
        );
    }
}

#[test]
fn a_model_signed_by_the_provisioned_key_is_loaded_and_used() {
    if !development_build() {
        return;
    }
    let blob = blob();
    let signed = sign(&blob, &development_signing_key().unwrap());
    let got = streamed(Some(&signed));
    assert_eq!(got.model, ModelStatus::Loaded { len: blob.len() as u32 });
    assert_eq!((got.load.unsigned, got.load.bad_signatures), (0, 0));
    let tracks = scene_tracks(6);
    let linked = run_in_process(&encode_all(&host_messages(&tracks, None)), &[&blob]);
    assert!(forecasts(&got) >= 16 * 3);
    assert_eq!(
        outputs(&got.replies),
        outputs(&linked.replies),
        "the loaded model forecasts as the same model linked in"
    );
    let cv = streamed(None);
    assert_ne!(outputs(&got.replies), outputs(&cv.replies), "the model changes the forecasts");
}

/// Each refused variant: its status, counted once, and constant-velocity answers throughout.
fn assert_refused(sent: &[u8], want: SignatureError) {
    let got = streamed(Some(sent));
    assert_eq!(got.model, ModelStatus::SignatureRejected(want));
    let (unsigned, bad) = if want == SignatureError::Unsigned { (1, 0) } else { (0, 1) };
    assert_eq!((got.load.unsigned, got.load.bad_signatures), (unsigned, bad), "refusal counted: {:?}", got.load);
    assert_eq!(got.load.crc_mismatches, 0, "the bytes arrived intact; only the signature is wrong");
    let cv = streamed(None);
    assert_eq!(outputs(&got.replies), outputs(&cv.replies), "a refused model leaves constant velocity in use");
}

#[test]
fn an_unsigned_model_is_refused_and_counted() {
    assert_refused(&blob(), SignatureError::Unsigned);
}

#[test]
fn a_model_signed_by_another_key_is_refused_and_counted() {
    let other = SigningKey::from_bytes(&[9u8; 32]);
    let signed = sign(&blob(), &other);
    assert_refused(
        &signed,
        SignatureError::OtherKey { found: key_id(other.verifying_key().as_bytes()), expected: key_id(&MODEL_KEY) },
    );
}

#[test]
fn a_model_changed_after_signing_is_refused_even_with_a_fresh_crc() {
    if !development_build() {
        return;
    }
    // The link's CRC is computed by the sender over what it sends, so a changed weight arrives
    // with a matching CRC: only the signature catches it.
    let mut signed = sign(&blob(), &development_signing_key().unwrap());
    let at = signed.len() / 2;
    signed[at] ^= 0x01;
    assert_refused(&signed, SignatureError::BadSignature);
}

#[test]
fn another_keys_signature_under_the_provisioned_key_id_is_refused() {
    if !development_build() {
        return;
    }
    let blob = blob();
    let mut forged = sign(&blob, &development_signing_key().unwrap());
    let other = SigningKey::from_bytes(&[9u8; 32]);
    let message_len = forged.len() - SIGNATURE_LEN;
    let signature = other.sign(&forged[..message_len]).to_bytes();
    forged[message_len..].copy_from_slice(&signature);
    assert_eq!(forged.len(), blob.len() + TRAILER_LEN);
    assert_refused(&forged, SignatureError::BadSignature);
}
