//! Provisions the edge with the Ed25519 public key it requires of a model sent over the link:
//! the file named by `DYNOTRAJ_MODEL_PUBKEY` (`dynotraj-ed25519-public` and 64 hex digits, the
//! `.pub` from `dynotraj keygen`; a bare line of 64 hex digits is read too), else the
//! repository's development key (keys/README.md). Writes `$OUT_DIR/model_key.rs`.

/// The label of a public key file (formats/src/model_signing.rs writes it).
const PUBLIC_LABEL: &str = "dynotraj-ed25519-public";
/// The label of a secret key file, which must never be built into an edge.
const SECRET_LABEL: &str = "dynotraj-ed25519-secret";

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=DYNOTRAJ_MODEL_PUBKEY");
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let dev = manifest.join("../keys/dev-model-signing.pub");
    let (path, development) = match std::env::var_os("DYNOTRAJ_MODEL_PUBKEY") {
        Some(p) if !p.is_empty() => (PathBuf::from(p), false),
        _ => (dev, true),
    };
    println!("cargo:rerun-if-changed={}", path.display());
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| fail(&format!("DYNOTRAJ_MODEL_PUBKEY {}: {e}", path.display())));
    let t = text.trim();
    if t.starts_with(SECRET_LABEL) {
        fail(&format!(
            "{}: this is a secret key; the edge is built with the public key (NAME.pub from `dynotraj keygen`)",
            path.display()
        ));
    }
    let t = t.strip_prefix(PUBLIC_LABEL).map_or(t, str::trim);
    if t.len() != 64 || !t.bytes().all(|c| c.is_ascii_hexdigit()) {
        fail(&format!(
            "{}: expected `{PUBLIC_LABEL}` and 64 hex digits (an Ed25519 public key from `dynotraj keygen`)",
            path.display()
        ));
    }
    let bytes: Vec<String> = (0..32).map(|i| format!("0x{}", &t[2 * i..2 * i + 2])).collect();
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("model_key.rs");
    let code = format!(
        "/// The Ed25519 public key a model sent over the link must be signed with ({}).\npub const MODEL_KEY: \
            dynotraj_core::model::signed::PublicKey = [{}];\n/// Whether [`MODEL_KEY`] is the repository's \
            development key (whose secret is public).\npub const MODEL_KEY_IS_DEVELOPMENT: bool = {development};\n",
        if development { "the repository's development key" } else { "provisioned by DYNOTRAJ_MODEL_PUBKEY" },
        bytes.join(", ")
    );
    std::fs::write(&out, code).unwrap_or_else(|e| fail(&format!("{}: {e}", out.display())));
}

fn fail(msg: &str) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(1)
}
