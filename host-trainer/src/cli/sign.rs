//! `fbg-trainer sign` and `fbg-trainer keygen`: signing keys and signed blobs.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};

use fbg_trainer::data::files::{check_outputs, write_bytes_atomically};
use fbg_trainer::{export, sign};

use crate::args::SignArgs;

/// Sign an existing blob (or re-sign a signed one): the blob, a trailer with the key id, a
/// serial and flags, and the Ed25519 signature over both.
#[derive(clap::Args)]
pub struct SignCmd {
    /// The blob to sign.
    #[arg(long)]
    model: PathBuf,
    /// The signed blob to write.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    sign: SignArgs,
    /// Print the signature (key id, serial, flags) as JSON on stdout.
    #[arg(long)]
    json: bool,
}

impl SignCmd {
    pub fn run(self) -> Result<()> {
        let (model, out) = (&self.model, &self.out);
        if self.sign.sign.is_none() {
            bail!("--sign KEY is required")
        }
        let mut inputs = vec![model.as_path()];
        let keys = self.sign.key_files();
        inputs.extend(keys.iter().map(PathBuf::as_path));
        check_outputs(&[out], &inputs)?;
        // Only a blob that decodes is signed: a signature vouches for a valid model.
        export::read_blob(model)?;
        let bytes = std::fs::read(model).with_context(|| format!("{}: cannot read", model.display()))?;
        let signer = self.sign.signer()?.context("--sign KEY is required")?;
        let (signed, rec) = signer.sign(&bytes)?;
        write_bytes_atomically(out, &signed)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&rec)?);
        } else {
            eprintln!(
                "wrote {} ({} B): key id {}, serial {}{}",
                out.display(),
                signed.len(),
                rec.key_id,
                rec.serial,
                rec.rollback_text()
            );
        }
        Ok(())
    }
}

/// Make an Ed25519 signing key pair for signed model updates: the private key in OUT
/// (PKCS#8 PEM, mode 0600, never overwritten), the public key beside it as `<stem>.pub`
/// (raw 32 bytes: the file the firmware build trusts, `FBG_TRUSTED_KEYS`) and
/// `<stem>.pub.hex`; prints the key id (first 8 bytes of SHA-256 of the public key).
#[derive(clap::Args)]
pub struct KeygenArgs {
    /// The private key file to create.
    #[arg(long, default_value = "lab.key")]
    out: PathBuf,
    /// Print the files, key id and public key as JSON on stdout.
    #[arg(long)]
    json: bool,
}

impl KeygenArgs {
    pub fn run(self) -> Result<()> {
        let k = sign::keygen(&self.out)?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&k)?);
        } else {
            println!("key id {}", k.key_id);
            eprintln!(
                "wrote {} (private, mode 0600: keep it offline), {} (public, raw: FBG_TRUSTED_KEYS of the firmware build) and {}",
                k.files.private.display(),
                k.files.public.display(),
                k.files.public_hex.display()
            );
            eprintln!("public key {}", k.public_key);
        }
        Ok(())
    }
}
