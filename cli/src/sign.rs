//! `dynotraj keygen`, `dynotraj sign` and `dynotraj verify`: the Ed25519 keys and signatures
//! an edge requires of a model sent over its link.

use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use dynotraj_core::model::blob::ModelBlob;

use dynotraj_formats::model_signing::{self, hex};

/// Options of `dynotraj keygen`.
#[derive(Debug, Args)]
pub struct KeygenArgs {
    /// Folder for NAME.key (the secret: keep it off the vehicle) and NAME.pub (build the edge
    /// with DYNOTRAJ_MODEL_PUBKEY=DIR/NAME.pub).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// File name stem of the pair.
    #[arg(long, default_value = "model-signing")]
    pub name: String,
}

/// Options of `dynotraj sign`.
#[derive(Debug, Args)]
pub struct SignArgs {
    /// The secret key file (from `dynotraj keygen`); `dev` signs with the repository's
    /// development key, which only unprovisioned (development) edges accept.
    #[arg(long, value_name = "FILE|dev")]
    pub key: String,
    /// The model blob to sign (from `dynotraj train`).
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Folder for the signed blob, named as the model with `.signed` appended (default: the
    /// model's folder).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// Options of `dynotraj verify`.
#[derive(Debug, Args)]
pub struct VerifyArgs {
    /// The public key file; `dev` checks against the repository's development key.
    #[arg(long, value_name = "FILE|dev")]
    pub key: String,
    /// The signed model blob.
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
}

/// Runs `dynotraj keygen`.
///
/// # Errors
/// See [`model_signing::keygen`].
pub fn keygen(args: &KeygenArgs) -> anyhow::Result<()> {
    let (secret, public) = model_signing::keygen(&args.out, &args.name)?;
    let key = model_signing::read_public_key(&public)?;
    println!("secret key {} (keep it off the vehicle)", secret.display());
    println!("public key {} ({})", public.display(), hex(&key));
    println!("build the edge with DYNOTRAJ_MODEL_PUBKEY={} to trust it", public.display());
    Ok(())
}

/// Runs `dynotraj sign`.
///
/// # Errors
/// An unreadable key or model, a model the core refuses, an unwritable output.
pub fn sign(args: &SignArgs) -> anyhow::Result<()> {
    let key = if args.key == "dev" {
        model_signing::development_signing_key()?
    } else {
        model_signing::read_signing_key(&PathBuf::from(&args.key))?
    };
    let blob = dynotraj_formats::model_file::read_model_file(&args.model).context("model blob")?;
    ModelBlob::parse_exact(&blob).map_err(|e| {
        anyhow::anyhow!("model blob {}: {e} (sign the blob `dynotraj train` wrote)", args.model.display())
    })?;
    let name = args.model.file_name().with_context(|| format!("--model {}: not a file", args.model.display()))?;
    let mut name = name.to_os_string();
    name.push(".signed");
    let out = match &args.out {
        Some(dir) => {
            std::fs::create_dir_all(dir).with_context(|| format!("--out: creating {}", dir.display()))?;
            dir.join(name)
        }
        None => args.model.with_file_name(name),
    };
    let signed = model_signing::sign(&blob, &key);
    dynotraj_formats::atomic::write_file(&out, &signed).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "{}: {} B blob + {} B signature by key {}",
        out.display(),
        blob.len(),
        signed.len() - blob.len(),
        hex(&key.verifying_key().as_bytes()[..8])
    );
    Ok(())
}

/// Runs `dynotraj verify`.
///
/// # Errors
/// An unreadable key or file, or a signature that does not verify (said in words).
pub fn verify(args: &VerifyArgs) -> anyhow::Result<()> {
    let key = if args.key == "dev" {
        model_signing::development_public_key()?
    } else {
        model_signing::read_public_key(&PathBuf::from(&args.key))?
    };
    let bytes = dynotraj_formats::model_file::read_model_file(&args.model)?;
    let blob = model_signing::verify(&bytes, &key, &args.model.display().to_string())?;
    ModelBlob::parse_exact(blob)
        .map_err(|e| anyhow::anyhow!("model blob {}: signature good, blob refused: {e}", args.model.display()))?;
    println!("{}: signature good (key {}), {} B model blob valid", args.model.display(), hex(&key[..8]), blob.len());
    Ok(())
}
