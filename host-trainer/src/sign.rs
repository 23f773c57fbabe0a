//! Signing keys and signed blobs: `fbg-trainer keygen` and the `--sign` option of `train`,
//! `recalibrate` and `fleet`.
//!
//! The trailer format is `fbg_shared::signature` (one definition for host and device); this
//! module holds the host's half: Ed25519 keys (`ed25519-dalek`), the key files and the serial
//! state.
//!
//! Files of a key `lab.key`:
//!
//! | file | content |
//! |---|---|
//! | `lab.key` | the private key, PKCS#8 PEM (readable by OpenSSL: `openssl pkey -in lab.key -pubout`); created with mode 0600, never overwritten |
//! | `lab.pub` | the public key, raw 32 bytes: the file the firmware build takes (`FBG_TRUSTED_KEYS`) |
//! | `lab.pub.hex` | the same, 64 hex digits and a newline |
//! | `lab.key.serial` | the last serial issued with this key (JSON), so that serials grow per key |
//! | `lab.key.serial.lock` | the lock that serialises concurrent signers (fleet groups, shards) |
//!
//! A serial is issued under an exclusive lock on the lock file (never renamed, so every
//! process locks the same file), and the state is replaced atomically.

use std::fs::OpenOptions;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use ed25519_dalek::pkcs8::{DecodePrivateKey, EncodePrivateKey};
use ed25519_dalek::{Signer as _, SigningKey};
use fbg_shared::signature::{
    self, key_id, Envelope, KeyId, SignFlags, TrailerHead, PUBLIC_KEY_LEN, SIGNATURE_LEN, TRAILER_HEAD_LEN,
};
use serde::{Deserialize, Serialize};

use crate::data::files::write_bytes_atomically;
use crate::error::TrainerError;

/// Format tag of the serial state file.
pub const STATE_FORMAT: &str = "fbg-trainer signing state v1";

fn err(path: &Path, message: impl Into<String>) -> TrainerError {
    TrainerError::Output { path: path.to_path_buf(), message: message.into() }
}

/// The files of a key pair whose private key is `key`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct KeyFiles {
    /// Private key (PKCS#8 PEM, mode 0600).
    pub private: PathBuf,
    /// Public key, raw 32 bytes.
    pub public: PathBuf,
    /// Public key, hex.
    pub public_hex: PathBuf,
    /// Last serial issued.
    pub state: PathBuf,
}

impl KeyFiles {
    /// `lab.key` → `lab.pub`, `lab.pub.hex`, `lab.key.serial`.
    pub fn of(private: &Path) -> KeyFiles {
        let public = private.with_extension("pub");
        let mut hex = public.clone().into_os_string();
        hex.push(".hex");
        let mut state = private.to_path_buf().into_os_string();
        state.push(".serial");
        KeyFiles { private: private.to_path_buf(), public, public_hex: hex.into(), state: state.into() }
    }

    fn lock(&self) -> PathBuf {
        let mut p = self.state.clone().into_os_string();
        p.push(".lock");
        p.into()
    }
}

/// What `keygen` made.
#[derive(Clone, Debug, Serialize)]
pub struct NewKey {
    /// The files written.
    pub files: KeyFiles,
    /// The key id (first 8 bytes of SHA-256 of the public key), hex.
    pub key_id: String,
    /// The public key, hex.
    pub public_key: String,
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Make a new Ed25519 key pair: the private key in `private` (created with mode 0600; refused
/// when it or the public key files exist: a lab key is never overwritten), the public key
/// beside it raw and in hex. The key comes from the operating system's random source.
pub fn keygen(private: &Path) -> Result<NewKey, TrainerError> {
    let files = KeyFiles::of(private);
    for p in [&files.private, &files.public, &files.public_hex] {
        if p.symlink_metadata().is_ok() {
            return Err(err(p, "exists; a key is never overwritten (choose another --out, or remove it yourself)"));
        }
    }
    if let Some(dir) = private.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| TrainerError::io(dir, e))?;
    }
    let mut seed = [0u8; 32];
    getrandom::fill(&mut seed).map_err(|e| err(private, format!("no random source for the key: {e}")))?;
    let key = SigningKey::from_bytes(&seed);
    seed.fill(0);
    // PKCS#8 v1 (the private key alone), which OpenSSL 3.0 reads too; v2 would add the public
    // key, which is derived from the private one anyway.
    let pair = ed25519_dalek::pkcs8::KeypairBytes { secret_key: key.to_bytes(), public_key: None };
    let pem = pair
        .to_pkcs8_pem(ed25519_dalek::pkcs8::spki::der::pem::LineEnding::LF)
        .map_err(|e| err(private, format!("encoding the key: {e}")))?;
    let mut opts = OpenOptions::new();
    opts.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.mode(0o600);
    }
    // `create_new`: refused if the file appeared since the check above (no race overwrites it).
    let mut f = opts.open(private).map_err(|e| TrainerError::io(private, e))?;
    f.write_all(pem.as_bytes()).and_then(|_| f.sync_all()).map_err(|e| TrainerError::io(private, e))?;
    let public = key.verifying_key().to_bytes();
    write_bytes_atomically(&files.public, &public)?;
    write_bytes_atomically(&files.public_hex, format!("{}\n", hex(&public)).as_bytes())?;
    Ok(NewKey { key_id: key_id(&public).to_string(), public_key: hex(&public), files })
}

/// A public key file: raw 32 bytes (`lab.pub`) or 64 hex digits (`lab.pub.hex`).
pub fn read_public_key(path: &Path) -> Result<[u8; PUBLIC_KEY_LEN], TrainerError> {
    let bytes = std::fs::read(path).map_err(|e| TrainerError::io(path, e))?;
    let text: String = String::from_utf8_lossy(&bytes).chars().filter(|c| !c.is_whitespace()).collect();
    let raw: Vec<u8> = if text.len() == 2 * PUBLIC_KEY_LEN && text.chars().all(|c| c.is_ascii_hexdigit()) {
        (0..text.len()).step_by(2).filter_map(|i| u8::from_str_radix(&text[i..i + 2], 16).ok()).collect()
    } else {
        bytes
    };
    raw.as_slice().try_into().map_err(|_| TrainerError::Model {
        path: path.display().to_string(),
        message: format!(
            "not an Ed25519 public key: {} bytes (expected 32 raw bytes, as `keygen` writes lab.pub, or 64 hex digits)",
            raw.len()
        ),
    })
}

/// How to sign: the key, the serial (next per key when `None`) and the flags.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SignOptions {
    /// The private key file.
    pub key: PathBuf,
    /// The serial; `None`: the next one of the key's state.
    pub serial: Option<u64>,
    /// Set the allow-rollback flag (a deliberate downgrade a device may accept).
    pub allow_rollback: bool,
}

/// What a signature says, for `coefficients.json`, summaries and `inspect`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignatureRecord {
    /// The key id, hex.
    pub key_id: String,
    /// The serial.
    pub serial: u64,
    /// The allow-rollback flag.
    pub allow_rollback: bool,
}

/// A loaded signing key.
pub struct BlobSigner {
    key: SigningKey,
    id: KeyId,
    files: KeyFiles,
    opts: SignOptions,
    /// Whether the private key file can be read by others than its owner.
    pub too_open: bool,
}

#[derive(Serialize, Deserialize)]
struct State {
    format: String,
    key_id: String,
    last_serial: u64,
}

impl BlobSigner {
    /// Load the key of `opts.key` (PKCS#8 PEM as `keygen` writes it, or as OpenSSL's
    /// `openssl genpkey -algorithm ed25519` does).
    pub fn load(opts: &SignOptions) -> Result<BlobSigner, TrainerError> {
        let path = &opts.key;
        let pem = std::fs::read_to_string(path).map_err(|e| TrainerError::io(path, e))?;
        let key = SigningKey::from_pkcs8_pem(&pem).map_err(|e| TrainerError::Model {
            path: path.display().to_string(),
            message: format!("not an Ed25519 private key in PKCS#8 PEM (as `fbg-trainer keygen` writes): {e}"),
        })?;
        #[cfg(unix)]
        let too_open = {
            use std::os::unix::fs::PermissionsExt;
            std::fs::metadata(path).map(|m| m.permissions().mode() & 0o077 != 0).unwrap_or(false)
        };
        #[cfg(not(unix))]
        let too_open = false;
        let id = key_id(&key.verifying_key().to_bytes());
        Ok(BlobSigner { key, id, files: KeyFiles::of(path), opts: opts.clone(), too_open })
    }

    /// The key id.
    pub fn key_id(&self) -> KeyId {
        self.id
    }

    /// The public key.
    pub fn public_key(&self) -> [u8; PUBLIC_KEY_LEN] {
        self.key.verifying_key().to_bytes()
    }

    /// The private key file.
    pub fn path(&self) -> &Path {
        &self.files.private
    }

    /// Issue the serial for one blob: the one given, or the last issued plus one. A given
    /// serial below the last issued one is refused (serials only grow; a downgrade is a new,
    /// higher serial or the allow-rollback flag). Serialised across processes by a lock file.
    pub fn issue_serial(&self) -> Result<u64, TrainerError> {
        let lock_path = self.files.lock();
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(|e| TrainerError::io(&lock_path, e))?;
        lock.lock().map_err(|e| TrainerError::io(&lock_path, e))?;
        let state = &self.files.state;
        let last = match std::fs::read_to_string(state) {
            Ok(text) => {
                let s: State = serde_json::from_str(&text).map_err(|e| {
                    err(state, format!("unreadable serial state ({e}); it records the last serial issued"))
                })?;
                if s.format != STATE_FORMAT || s.key_id != self.id.to_string() {
                    return Err(err(state, format!("is the serial state of key {}, not of {}", s.key_id, self.id)));
                }
                Some(s.last_serial)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(TrainerError::io(state, e)),
        };
        let serial = match (self.opts.serial, last) {
            (Some(s), Some(l)) if s < l => {
                return Err(err(
                    state,
                    format!(
                        "--serial {s} is below the last serial issued with key {} ({l}); serials only grow",
                        self.id
                    ),
                ))
            }
            (Some(s), _) => s,
            (None, Some(l)) => l.checked_add(1).ok_or_else(|| err(state, "serials exhausted"))?,
            (None, None) => 1,
        };
        let next = State {
            format: STATE_FORMAT.into(),
            key_id: self.id.to_string(),
            last_serial: serial.max(last.unwrap_or(0)),
        };
        let text = serde_json::to_string_pretty(&next).map_err(|e| err(state, e.to_string()))?;
        write_bytes_atomically(state, format!("{text}\n").as_bytes())?;
        drop(lock); // releases the lock
        Ok(serial)
    }

    /// `blob` signed with a newly issued serial: the blob, the trailer head and the signature
    /// over both (`fbg_shared::signature`). A signed blob's signature is replaced.
    pub fn sign(&self, blob: &[u8]) -> Result<(Vec<u8>, SignatureRecord), TrainerError> {
        let serial = self.issue_serial()?;
        Ok(self.sign_with_serial(blob, serial))
    }

    /// [`Self::sign`] with a given serial (no state involved).
    pub fn sign_with_serial(&self, blob: &[u8], serial: u64) -> (Vec<u8>, SignatureRecord) {
        let blob = signature::strip(blob);
        let flags = if self.opts.allow_rollback { SignFlags::ALLOW_ROLLBACK } else { SignFlags::NONE };
        let head = TrailerHead { flags, serial, key_id: self.id };
        let mut out = Vec::with_capacity(blob.len() + TRAILER_HEAD_LEN + SIGNATURE_LEN);
        out.extend_from_slice(blob);
        out.extend_from_slice(&head.to_bytes());
        let sig = self.key.sign(&out);
        out.extend_from_slice(&sig.to_bytes());
        (out, SignatureRecord { key_id: self.id.to_string(), serial, allow_rollback: self.opts.allow_rollback })
    }
}

/// What a model file says about its signature, and whether it verifies with a public key.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SignatureCheck {
    /// Signed at all.
    pub signed: bool,
    /// The trailer's fields (none when unsigned).
    pub record: Option<SignatureRecord>,
    /// The key id of the public key checked against, hex.
    pub checked_key_id: Option<String>,
    /// `Some(true)` when it verifies with that key (with the device's verifier,
    /// `fbg_shared::signature::verify`); `None` when no key was given.
    pub verifies: Option<bool>,
    /// Why it does not verify.
    pub problem: Option<String>,
}

/// Read the signature of `bytes` and check it against `public` when given, exactly as a
/// device trusting only that key would.
pub fn check(bytes: &[u8], public: Option<&[u8; PUBLIC_KEY_LEN]>) -> SignatureCheck {
    let trusted = public.map(|p| signature::TrustedKey { id: key_id(p), public: *p });
    let checked_key_id = trusted.map(|t| t.id.to_string());
    match signature::open(bytes) {
        Ok(Envelope::Unsigned(_)) => SignatureCheck {
            signed: false,
            record: None,
            checked_key_id,
            verifies: trusted.map(|_| false),
            problem: trusted.map(|_| signature::SignatureError::Unsigned.to_string()),
        },
        Ok(Envelope::Signed(s)) => {
            let record = SignatureRecord {
                key_id: s.head.key_id.to_string(),
                serial: s.head.serial,
                allow_rollback: s.head.flags.contains(SignFlags::ALLOW_ROLLBACK),
            };
            let result = trusted.map(|t| signature::verify(&s, &[t]));
            SignatureCheck {
                signed: true,
                record: Some(record),
                checked_key_id,
                verifies: result.map(|r| r.is_ok()),
                problem: result.and_then(|r| r.err()).map(|e| e.to_string()),
            }
        }
        Err(e) => SignatureCheck {
            signed: true,
            record: None,
            checked_key_id,
            verifies: trusted.map(|_| false),
            problem: Some(e.to_string()),
        },
    }
}

/// `--sign KEY [--serial N] [--allow-rollback]` of `train`, `recalibrate` and `fleet`.
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct SignArgs {
    /// Sign the written blob(s) with this private key (from `fbg-trainer keygen`): a signature
    /// trailer with the key id and a serial follows the blob's CRC; devices accept signed
    /// models only.
    #[arg(long, value_name = "KEY")]
    pub sign: Option<PathBuf>,
    /// Serial of the signature (default: the next serial of the key, kept in `<KEY>.serial`).
    #[arg(long, requires = "sign")]
    pub serial: Option<u64>,
    /// Set the signed allow-rollback flag: a device whose build allows rollback accepts this
    /// model even over one with a higher serial.
    #[arg(long, requires = "sign")]
    pub allow_rollback: bool,
}

impl SignArgs {
    /// The signing options, when `--sign` was given.
    pub fn options(&self) -> Option<SignOptions> {
        self.sign.as_ref().map(|key| SignOptions {
            key: key.clone(),
            serial: self.serial,
            allow_rollback: self.allow_rollback,
        })
    }

    /// Load the signer, when `--sign` was given (a private key readable by others is warned
    /// about on stderr).
    pub fn signer(&self) -> Result<Option<BlobSigner>, TrainerError> {
        let Some(opts) = self.options() else { return Ok(None) };
        let s = BlobSigner::load(&opts)?;
        if s.too_open {
            eprintln!(
                "warning: {} can be read by other users; a lab key should be private (chmod 600)",
                s.path().display()
            );
        }
        Ok(Some(s))
    }
}

/// Encode-and-sign helper: the bytes to write for `blob`, signed when `signer` is given.
pub fn maybe_sign(
    blob: Vec<u8>,
    signer: Option<&BlobSigner>,
) -> Result<(Vec<u8>, Option<SignatureRecord>), TrainerError> {
    match signer {
        None => Ok((blob, None)),
        Some(s) => {
            let (bytes, rec) = s.sign(&blob)?;
            Ok((bytes, Some(rec)))
        }
    }
}
