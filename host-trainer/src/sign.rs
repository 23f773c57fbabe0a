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
//!
//! **Serial ledger.** Serials belong to the key, i.e. to its key id, not to a key file: a copy
//! of `lab.key` (another name, another directory) continues the same serials. The last serial
//! issued per key id is kept in the signing state directory, `<KEY ID>.serial` (JSON) beside
//! its lock `<KEY ID>.serial.lock`, which serialises concurrent signers (fleet groups,
//! shards). The directory is `--serial-state DIR` (or `FBG_SIGNING_STATE_DIR`), else
//! `$XDG_STATE_HOME/fbg-trainer/signing`, else `~/.local/state/fbg-trainer/signing`: per user
//! account, so copies on one account share their serials; a key copied to another account
//! or host needs its ledger copied too (or a `--serial` above the last one issued). The
//! ledger of earlier versions beside the key (`lab.key.serial`) is still read: the next serial
//! is above the larger of the two.
//!
//! A serial is issued under an exclusive lock on the lock file (never renamed, so every
//! process locks the same file), and the state is replaced atomically.
//!
//! **Rollbacks.** `--allow-rollback` signs a deliberate downgrade: it needs `--serial S` (the
//! rollback's own serial, usually the old release's) and `--replaces N`, the one serial it may
//! replace (N > S, and N already issued with the key). The trailer is then version 2
//! (`fbg_shared::signature`), and a device built to accept rollbacks accepts it only while
//! serial N runs. A rollback's serial may be below the last one issued; it does not move the
//! ledger.

use std::fs::OpenOptions;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use ed25519_dalek::pkcs8::{DecodePrivateKey, EncodePrivateKey};
use ed25519_dalek::{Signer as _, SigningKey};
use fbg_shared::container::Envelope;
use fbg_shared::signature::{
    self, key_id, KeyId, SignFlags, TrailerHead, PUBLIC_KEY_LEN, SIGNATURE_LEN, TRAILER_V2_HEAD_LEN,
};
use serde::{Deserialize, Serialize};

use crate::data::files::write_bytes_atomically;
use crate::error::TrainerError;

/// Format tag of the serial state file.
pub const STATE_FORMAT: &str = "fbg-trainer signing state v1";

fn err(path: &Path, message: impl Into<String>) -> TrainerError {
    TrainerError::Output { path: path.to_path_buf(), message: message.into() }
}

/// Environment variable naming the signing state directory (the serial ledger).
pub const STATE_DIR_ENV: &str = "FBG_SIGNING_STATE_DIR";

/// The files of a key pair whose private key is `key`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct KeyFiles {
    /// Private key (PKCS#8 PEM, mode 0600).
    pub private: PathBuf,
    /// Public key, raw 32 bytes.
    pub public: PathBuf,
    /// Public key, hex.
    pub public_hex: PathBuf,
    /// The serial state earlier versions kept beside the key (`lab.key.serial`; read only).
    pub legacy_state: PathBuf,
}

impl KeyFiles {
    /// `lab.key` → `lab.pub`, `lab.pub.hex`, `lab.key.serial`.
    pub fn of(private: &Path) -> KeyFiles {
        let public = private.with_extension("pub");
        let mut hex = public.clone().into_os_string();
        hex.push(".hex");
        let mut state = private.to_path_buf().into_os_string();
        state.push(".serial");
        KeyFiles { private: private.to_path_buf(), public, public_hex: hex.into(), legacy_state: state.into() }
    }
}

/// The signing state directory: `explicit`, else [`STATE_DIR_ENV`], else
/// `$XDG_STATE_HOME/fbg-trainer/signing`, else `$HOME/.local/state/fbg-trainer/signing`.
pub fn state_dir(explicit: Option<&Path>) -> Result<PathBuf, TrainerError> {
    let env = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(d) = explicit.map(Path::to_path_buf).or_else(|| env(STATE_DIR_ENV)) {
        return Ok(d);
    }
    if let Some(d) = env("XDG_STATE_HOME").filter(|d| d.is_absolute()) {
        return Ok(d.join("fbg-trainer/signing"));
    }
    env("HOME").map(|h| h.join(".local/state/fbg-trainer/signing")).ok_or_else(|| TrainerError::Config {
        origin: "signing".into(),
        key: STATE_DIR_ENV.into(),
        message:
            "no directory for the serial ledger: set --serial-state, FBG_SIGNING_STATE_DIR, XDG_STATE_HOME or HOME"
                .into(),
    })
}

fn lock_of(path: &Path) -> PathBuf {
    let mut p = path.to_path_buf().into_os_string();
    p.push(".lock");
    p.into()
}

/// The files signing with `opts` reads or writes (`BlobSigner::files_read`); only the
/// private key and its legacy state when the key cannot be read (its load will say why).
pub fn key_inputs(opts: Option<&SignOptions>) -> Vec<PathBuf> {
    let Some(opts) = opts else { return Vec::new() };
    match BlobSigner::load(opts) {
        Ok(s) => s.files_read(),
        Err(_) => {
            let f = KeyFiles::of(&opts.key);
            let lock = lock_of(&f.legacy_state);
            vec![f.private, f.legacy_state, lock]
        }
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

/// How to sign: the key, the serial (next per key id when `None`), the flags and where the
/// serial ledger is.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SignOptions {
    /// The private key file.
    pub key: PathBuf,
    /// The serial; `None`: the next one of the key id's ledger.
    pub serial: Option<u64>,
    /// Set the allow-rollback flag (a deliberate downgrade a device built for it may accept);
    /// needs `serial` and `replaces`.
    pub allow_rollback: bool,
    /// The one serial a rollback may replace (above `serial`, already issued).
    pub replaces: Option<u64>,
    /// The signing state directory ([`state_dir`]; `None`: the default).
    pub state_dir: Option<PathBuf>,
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
    /// The serial a rollback may replace (trailer version 2), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replaces: Option<u64>,
}

impl SignatureRecord {
    /// What the record says about a rollback, for a summary line: empty for none.
    pub fn rollback_text(&self) -> String {
        match (self.allow_rollback, self.replaces) {
            (true, Some(r)) => format!(", a rollback that may replace serial {r} only"),
            (true, None) => ", allow-rollback flag of a version-1 trailer (grants no rollback)".to_string(),
            (false, _) => String::new(),
        }
    }
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
        if opts.allow_rollback != opts.replaces.is_some() || (opts.allow_rollback && opts.serial.is_none()) {
            return Err(TrainerError::Config {
                origin: "sign".into(),
                key: "allow-rollback".into(),
                message: "a rollback needs --allow-rollback, --serial S and --replaces N together".into(),
            });
        }
        if let (Some(s), Some(r)) = (opts.serial, opts.replaces) {
            if r <= s {
                return Err(TrainerError::Config {
                    origin: "sign".into(),
                    key: "replaces".into(),
                    message: format!(
                        "--replaces {r} must be above the rollback's --serial {s} (it names the newer serial it may replace)"
                    ),
                });
            }
        }
        Ok(BlobSigner { key, id, files: KeyFiles::of(path), opts: opts.clone(), too_open })
    }

    /// This key id's serial ledger (`<KEY ID>.serial` in the state directory).
    pub fn ledger(&self) -> Result<PathBuf, TrainerError> {
        Ok(state_dir(self.opts.state_dir.as_deref())?.join(format!("{}.serial", self.id)))
    }

    /// Every file signing with this key reads or writes: the private key, the ledger and its
    /// lock, and the legacy state beside the key and its lock. No command's output may be one.
    pub(crate) fn files_read(&self) -> Vec<PathBuf> {
        let mut v =
            vec![self.files.private.clone(), self.files.legacy_state.clone(), lock_of(&self.files.legacy_state)];
        if let Ok(l) = self.ledger() {
            v.push(lock_of(&l));
            v.push(l);
        }
        v
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

    /// Issue the serial for one blob: the one given, or the last issued plus one (per key id,
    /// from the ledger and the legacy state beside the key). A given serial below the last
    /// issued one is refused (serials only grow; a downgrade is a new, higher serial or a
    /// rollback); a rollback's serial may be lower, but the serial it replaces must have been
    /// issued, and it leaves the ledger as it is. Serialised across processes by a lock file.
    pub fn issue_serial(&self) -> Result<u64, TrainerError> {
        let state = self.ledger()?;
        if let Some(dir) = state.parent() {
            std::fs::create_dir_all(dir).map_err(|e| TrainerError::io(dir, e))?;
        }
        let mut lock_path = state.clone().into_os_string();
        lock_path.push(".lock");
        let lock_path = PathBuf::from(lock_path);
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(|e| TrainerError::io(&lock_path, e))?;
        lock.lock().map_err(|e| TrainerError::io(&lock_path, e))?;
        let last = self.read_state(&state)?.max(self.read_state(&self.files.legacy_state)?);
        let serial = match (self.opts.serial, self.opts.replaces, last) {
            (Some(s), Some(r), l) => {
                if r > l.unwrap_or(0) {
                    return Err(err(
                        &state,
                        format!(
                            "--replaces {r}: no such serial was issued with key {} (last: {}); a rollback replaces a released serial",
                            self.id,
                            l.map_or("none".to_string(), |l| l.to_string())
                        ),
                    ));
                }
                return Ok(s);
            }
            (Some(s), None, Some(l)) if s < l => {
                return Err(err(
                    &state,
                    format!(
                        "--serial {s} is below the last serial issued with key {} ({l}); serials only grow",
                        self.id
                    ),
                ))
            }
            (Some(s), None, _) => s,
            (None, _, Some(l)) => l.checked_add(1).ok_or_else(|| err(&state, "serials exhausted"))?,
            (None, _, None) => 1,
        };
        let next = State {
            format: STATE_FORMAT.into(),
            key_id: self.id.to_string(),
            last_serial: serial.max(last.unwrap_or(0)),
        };
        let text = serde_json::to_string_pretty(&next).map_err(|e| err(&state, e.to_string()))?;
        write_bytes_atomically(&state, format!("{text}\n").as_bytes())?;
        drop(lock); // releases the lock
        Ok(serial)
    }

    /// The last serial a state file records for this key (`None` when it does not exist).
    fn read_state(&self, state: &Path) -> Result<Option<u64>, TrainerError> {
        match std::fs::read_to_string(state) {
            Ok(text) => {
                let s: State = serde_json::from_str(&text).map_err(|e| {
                    err(state, format!("unreadable serial state ({e}); it records the last serial issued"))
                })?;
                if s.format != STATE_FORMAT || s.key_id != self.id.to_string() {
                    return Err(err(state, format!("is the serial state of key {}, not of {}", s.key_id, self.id)));
                }
                Ok(Some(s.last_serial))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(TrainerError::io(state, e)),
        }
    }

    /// `blob` signed with a newly issued serial: the blob, the trailer head and the signature
    /// over both (`fbg_shared::signature`). A signed blob's signature is replaced.
    pub fn sign(&self, blob: &[u8]) -> Result<(Vec<u8>, SignatureRecord), TrainerError> {
        let serial = self.issue_serial()?;
        Ok(self.sign_with_serial(blob, serial))
    }

    /// [`Self::sign`] with a given serial (no state involved). A rollback (the options'
    /// `replaces`) is written as a version-2 trailer, anything else as version 1.
    pub(crate) fn sign_with_serial(&self, blob: &[u8], serial: u64) -> (Vec<u8>, SignatureRecord) {
        let blob = fbg_shared::container::strip(blob);
        let replaces = self.opts.replaces.filter(|_| self.opts.allow_rollback);
        let flags = if replaces.is_some() { SignFlags::ALLOW_ROLLBACK } else { SignFlags::NONE };
        let head = TrailerHead { flags, serial, key_id: self.id, replaces };
        let mut out = Vec::with_capacity(blob.len() + TRAILER_V2_HEAD_LEN + SIGNATURE_LEN);
        out.extend_from_slice(blob);
        out.extend_from_slice(&head.to_bytes());
        let sig = self.key.sign(&out);
        out.extend_from_slice(&sig.to_bytes());
        (out, SignatureRecord { key_id: self.id.to_string(), serial, allow_rollback: replaces.is_some(), replaces })
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
    match fbg_shared::container::open(bytes) {
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
                replaces: s.head.replaces,
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

/// How a command that runs a model on the host (`compensate`, `evaluate`) treats its
/// signature: the public keys it trusts (`--pubkey`) and whether it refuses a model that
/// does not verify with one of them (`--require-signature`).
#[derive(Clone, Debug, Default)]
pub struct HostTrust {
    /// The trusted keys.
    pub keys: Vec<signature::TrustedKey>,
    /// Refuse a model that is unsigned, signed by none of `keys`, or changed after signing.
    pub require: bool,
}

impl HostTrust {
    /// The public key files `pubkeys` (as [`read_public_key`] reads them), `require` as given.
    pub fn load(pubkeys: &[PathBuf], require: bool) -> Result<HostTrust, TrainerError> {
        let keys = pubkeys
            .iter()
            .map(|p| read_public_key(p).map(|public| signature::TrustedKey { id: key_id(&public), public }))
            .collect::<Result<_, _>>()?;
        Ok(HostTrust { keys, require })
    }

    /// What to say about the signature of the model file `bytes` (read from `path`) before
    /// using it: `Ok(None)` nothing (verified, or unsigned and not required); `Ok(Some(w))` a
    /// warning (a signature that does not verify, or one there is no key to check); an error
    /// when [`HostTrust::require`] and it does not verify. Without a key the host cannot tell
    /// a trailer changed after signing from an intact one, and says so.
    pub fn check(&self, path: &Path, bytes: &[u8]) -> Result<Option<String>, TrainerError> {
        let problem = match fbg_shared::container::open(bytes) {
            Ok(Envelope::Unsigned(_)) if !self.require => return Ok(None),
            Ok(Envelope::Unsigned(_)) => signature::SignatureError::Unsigned.to_string(),
            Ok(Envelope::Signed(s)) if self.keys.is_empty() => format!(
                "signed by key {} (serial {}), but no public key was given to check it (--pubkey FILE): a signature changed after signing goes unnoticed",
                s.head.key_id, s.head.serial
            ),
            Ok(Envelope::Signed(s)) => match signature::verify(&s, &self.keys) {
                Ok(()) => return Ok(None),
                Err(e) => format!("serial {}: {e}", s.head.serial),
            },
            // A trailer this build cannot read: the blob decoder refuses the file with this reason.
            Err(_) if !self.require => return Ok(None),
            Err(e) => e.to_string(),
        };
        if self.require {
            Err(TrainerError::Model {
                path: path.display().to_string(),
                message: format!("{problem}; refused (--require-signature)"),
            })
        } else {
            Ok(Some(format!("{}: {problem}", path.display())))
        }
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
