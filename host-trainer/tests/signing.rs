//! Signing keys and signed blobs: `keygen` (mode 0600, never overwrites), serials per key,
//! a blob signed by the trainer (ed25519-dalek) verified on the device's code path
//! (`fbg_shared::signature::verify`, the verifier the firmware links), and the `sign` and
//! `inspect --pubkey` commands.

use std::path::Path;
use std::process::Command;

use fbg_shared::container::{self, Envelope};
use fbg_shared::signature::{self, key_id, SignFlags, SignatureError, TrustedKey};
use fbg_trainer::sign::{self, BlobSigner, SignOptions};

const TINY: &[u8] = include_bytes!("../../shared/tests/golden/tiny_v7.fbgm");

fn trainer() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
}

fn trusted(dir: &Path, stem: &str) -> TrustedKey {
    let public = sign::read_public_key(&dir.join(format!("{stem}.pub"))).unwrap();
    TrustedKey { id: key_id(&public), public }
}

#[test]
fn keygen_writes_a_private_key_0600_and_refuses_to_overwrite() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    let k = sign::keygen(&key).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&key).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600, "private key mode {mode:o}");
    }
    let raw = std::fs::read(d.path().join("lab.pub")).unwrap();
    assert_eq!(raw.len(), 32);
    let hex = std::fs::read_to_string(d.path().join("lab.pub.hex")).unwrap();
    assert_eq!(hex.trim(), k.public_key);
    assert_eq!(k.key_id, key_id(&raw.clone().try_into().unwrap()).to_string());
    assert_eq!(
        sign::read_public_key(&d.path().join("lab.pub.hex")).unwrap(),
        sign::read_public_key(&d.path().join("lab.pub")).unwrap()
    );
    let pem_before = std::fs::read(&key).unwrap();
    assert!(String::from_utf8_lossy(&pem_before).starts_with("-----BEGIN PRIVATE KEY-----"));

    // Never overwritten, by the library or the command.
    let e = sign::keygen(&key).unwrap_err().to_string();
    assert!(e.contains("exists"), "{e}");
    let out = trainer().args(["keygen", "--out"]).arg(&key).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("never overwritten"));
    assert_eq!(std::fs::read(&key).unwrap(), pem_before);
    // A public key left alone beside a missing private key is not overwritten either.
    std::fs::remove_file(&key).unwrap();
    assert!(sign::keygen(&key).is_err());

    // The command prints the key id.
    let other = d.path().join("other.key");
    let out = trainer().args(["keygen", "--out"]).arg(&other).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let id = trusted(d.path(), "other").id.to_string();
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), format!("key id {id}"));
}

#[test]
fn a_blob_signed_by_the_trainer_verifies_on_the_device_code_path() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    let lab = trusted(d.path(), "lab");
    let state = Some(d.path().join("state"));
    let signer =
        BlobSigner::load(&SignOptions { key: key.clone(), state_dir: state.clone(), ..SignOptions::default() })
            .unwrap();
    assert_eq!(signer.key_id(), lab.id);
    let (signed, rec) = signer.sign(TINY).unwrap();
    assert_eq!((rec.serial, rec.key_id.as_str(), rec.allow_rollback), (1, lab.id.to_string().as_str(), false));
    // The device's path: open the trailer, look the key up, verify with the firmware's verifier.
    let Envelope::Signed(s) = container::open(&signed).unwrap() else { panic!("no trailer") };
    assert_eq!(s.blob, TINY, "the blob before the trailer is the unsigned blob, byte for byte");
    assert_eq!(signature::verify(&s, &[lab]), Ok(()));
    // The blob still decodes as before (host use of signed blobs).
    assert_eq!(fbg_shared::blob::decode::<2>(&signed).unwrap(), fbg_shared::blob::decode::<2>(TINY).unwrap());
    // One payload bit flipped after signing: refused.
    let mut t = signed.clone();
    t[40] ^= 0x08;
    let Envelope::Signed(s) = container::open(&t).unwrap() else { panic!() };
    assert_eq!(signature::verify(&s, &[lab]), Err(SignatureError::BadSignature));
    // Re-signing replaces the signature (the trailer is not stacked).
    let (again, rec2) = signer.sign(&signed).unwrap();
    assert_eq!(again.len(), signed.len());
    assert_eq!(rec2.serial, 2);
    // A rollback is signed with the serial it replaces (a version-2 trailer), below the last
    // serial issued, which it leaves alone.
    let rb = SignOptions {
        key: key.clone(),
        serial: Some(1),
        allow_rollback: true,
        replaces: Some(2),
        state_dir: state.clone(),
    };
    let (down, rec3) = BlobSigner::load(&rb).unwrap().sign(TINY).unwrap();
    assert_eq!((rec3.serial, rec3.allow_rollback, rec3.replaces), (1, true, Some(2)));
    let Envelope::Signed(s) = container::open(&down).unwrap() else { panic!() };
    assert!(s.head.flags.contains(SignFlags::ALLOW_ROLLBACK));
    assert_eq!((s.head.replaces, s.head.rollback_of()), (Some(2), Some(2)));
    assert_eq!(down.len(), TINY.len() + signature::TRAILER_V2_LEN);
    assert_eq!(signature::verify(&s, &[lab]), Ok(()));
    assert_eq!(signer.sign(TINY).unwrap().1.serial, 3, "the rollback did not move the ledger");
    // A rollback must name a released serial above its own, and not come without one.
    let e = |o: SignOptions| match BlobSigner::load(&o).and_then(|s| s.sign(TINY)) {
        Ok(_) => panic!("{o:?} signed"),
        Err(e) => e.to_string(),
    };
    assert!(e(SignOptions { replaces: Some(1), ..rb.clone() }).contains("must be above"));
    assert!(e(SignOptions { replaces: Some(9), ..rb.clone() }).contains("no such serial was issued"));
    assert!(e(SignOptions { replaces: None, ..rb.clone() }).contains("--replaces"));
    assert!(e(SignOptions { serial: None, ..rb.clone() }).contains("--serial"));
}

/// Serials belong to the key id, not the key file: a copy of the key file
/// (another name, another directory) continues the serials, through the library and the
/// command; the ledger earlier versions kept beside the key is still honoured.
#[test]
fn a_copied_key_file_continues_the_serials_of_its_key_id() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    let state = d.path().join("state");
    std::fs::create_dir(d.path().join("elsewhere")).unwrap();
    let copy = d.path().join("elsewhere/copy-of-lab.key");
    std::fs::copy(&key, &copy).unwrap();
    let issue = |k: &Path| {
        let o = SignOptions { key: k.to_path_buf(), state_dir: Some(state.clone()), ..SignOptions::default() };
        BlobSigner::load(&o).unwrap().issue_serial().unwrap()
    };
    assert_eq!(issue(&key), 1);
    assert_eq!(issue(&key), 2);
    assert_eq!(issue(&copy), 3, "the copy continues the key id's serials");
    assert_eq!(issue(&key), 4);
    let id = BlobSigner::load(&SignOptions { key: key.clone(), ..SignOptions::default() }).unwrap().key_id();
    assert!(state.join(format!("{id}.serial")).exists(), "the ledger is named by the key id");
    // The command, through the environment variable, on the copy.
    let model = d.path().join("tiny.fbgm");
    std::fs::write(&model, TINY).unwrap();
    let out = trainer()
        .args(["sign", "--json", "--model"])
        .arg(&model)
        .arg("--out")
        .arg(d.path().join("s.fbgm"))
        .arg("--sign")
        .arg(&copy)
        .env(sign::STATE_DIR_ENV, &state)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["serial"], 5, "{v}");
    // A serial below the key id's last one is refused for the copy too.
    let o =
        SignOptions { key: copy.clone(), serial: Some(2), state_dir: Some(state.clone()), ..SignOptions::default() };
    let e = BlobSigner::load(&o).unwrap().issue_serial().unwrap_err().to_string();
    assert!(e.contains("below the last serial issued"), "{e}");
    // A legacy ledger beside the key file (earlier versions) counts as well.
    std::fs::write(
        d.path().join("elsewhere/copy-of-lab.key.serial"),
        format!("{{\"format\": \"{}\", \"key_id\": \"{id}\", \"last_serial\": 40}}", sign::STATE_FORMAT),
    )
    .unwrap();
    assert_eq!(issue(&copy), 41);
    assert_eq!(issue(&key), 42, "and the ledger now carries it for every copy");
}

/// A trailer of a version this build does not read, or with a reserved
/// byte set, is reported as such by `inspect` and whatever reads the model, not as bytes after
/// the payload.
#[test]
fn an_unreadable_trailer_is_named_not_counted_as_extra_bytes() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    let o = SignOptions { key, state_dir: Some(d.path().join("state")), ..SignOptions::default() };
    let (signed, _) = BlobSigner::load(&o).unwrap().sign(TINY).unwrap();
    let at = TINY.len();
    for (what, byte, value, want) in [
        ("version 3", 4, 3u8, "signature trailer version 3 not supported"),
        ("version 255", 4, 255, "signature trailer version 255 not supported"),
        ("reserved byte", 6, 1, "reserved byte set"),
        ("other reserved byte", 7, 0x80, "reserved byte set"),
    ] {
        let mut bad = signed.clone();
        bad[at + byte] = value;
        let file = d.path().join("bad.fbgm");
        std::fs::write(&file, &bad).unwrap();
        let e = fbg_trainer::export::read_blob(&file).unwrap_err().to_string();
        assert!(e.contains(want) && !e.contains("unexpected bytes"), "{what}: {e}");
        let out = trainer().arg("inspect").arg(&file).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(want) && !err.contains("unexpected bytes"), "{what}: {err}");
    }
}

#[test]
fn serials_grow_per_key_even_when_signers_race() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    let opts = SignOptions { key: key.clone(), state_dir: Some(d.path().join("state")), ..SignOptions::default() };
    let serials: Vec<u64> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..4)
            .map(|_| {
                let opts = opts.clone();
                s.spawn(move || {
                    let signer = BlobSigner::load(&opts).unwrap();
                    (0..10).map(|_| signer.issue_serial().unwrap()).collect::<Vec<_>>()
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().unwrap()).collect()
    });
    let mut sorted = serials.clone();
    sorted.sort();
    assert_eq!(sorted, (1..=40).collect::<Vec<u64>>(), "every serial issued once");
    // A given serial may repeat the last (one release for many groups) but never go below it.
    let at = |n| BlobSigner::load(&SignOptions { serial: Some(n), ..opts.clone() }).unwrap().issue_serial();
    assert_eq!(at(40).unwrap(), 40);
    let e = at(39).unwrap_err().to_string();
    assert!(e.contains("below the last serial issued"), "{e}");
    assert_eq!(at(100).unwrap(), 100);
    assert_eq!(BlobSigner::load(&opts).unwrap().issue_serial().unwrap(), 101);
}

#[test]
fn sign_and_inspect_pubkey_commands() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    sign::keygen(&d.path().join("other.key")).unwrap();
    let model = d.path().join("tiny.fbgm");
    std::fs::write(&model, TINY).unwrap();
    let signed = d.path().join("tiny-signed.fbgm");
    let out = trainer()
        .args(["sign", "--model"])
        .arg(&model)
        .arg("--out")
        .arg(&signed)
        .arg("--sign")
        .arg(&key)
        .args(["--serial", "7"])
        .env(sign::STATE_DIR_ENV, d.path().join("state"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let lab = trusted(d.path(), "lab");

    let inspect = |file: &Path, pubkey: &str| {
        trainer().arg("inspect").arg(file).arg("--pubkey").arg(d.path().join(pubkey)).output().unwrap()
    };
    let ok = inspect(&signed, "lab.pub");
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let text = String::from_utf8_lossy(&ok.stdout);
    assert!(text.contains(&format!("key id {}, serial 7", lab.id)) && text.contains("verifies with"), "{text}");
    // Against another key, and an unsigned blob: reported, and a failure exit.
    let bad = inspect(&signed, "other.pub.hex");
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stdout).contains("does NOT verify"));
    let unsigned = inspect(&model, "lab.pub");
    assert!(!unsigned.status.success());
    assert!(String::from_utf8_lossy(&unsigned.stdout).contains("signature: none"));
    // JSON view.
    let j = trainer().arg("inspect").arg(&signed).arg("--json").output().unwrap();
    let v: serde_json::Value = serde_json::from_slice(&j.stdout).unwrap();
    assert_eq!(v["signature"]["record"]["serial"], 7);
    assert_eq!(v["signature"]["record"]["key_id"], lab.id.to_string());
    assert_eq!(v["blob_bytes"].as_u64().unwrap() as usize, TINY.len());
}

/// `compensate` and `evaluate` (through `HostTrust`): a signed model that does not verify is
/// named, and refused with `--require-signature`; a changed trailer cannot pass unnoticed.
#[test]
fn a_model_used_on_the_host_has_its_signature_named() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    sign::keygen(&d.path().join("other.key")).unwrap();
    let o = SignOptions { key, serial: Some(7), state_dir: Some(d.path().join("state")), ..SignOptions::default() };
    let (signed, _) = BlobSigner::load(&o).unwrap().sign(TINY).unwrap();
    let path = Path::new("m.fbgm");
    let lab = || vec![d.path().join("lab.pub")];
    let check = |bytes: &[u8], keys: Vec<std::path::PathBuf>, require: bool| {
        sign::HostTrust::load(&keys, require).unwrap().check(path, bytes)
    };
    // Verified, or unsigned and not required: nothing to say.
    assert_eq!(check(&signed, lab(), false).unwrap(), None);
    assert_eq!(check(&signed, lab(), true).unwrap(), None);
    assert_eq!(check(TINY, vec![], false).unwrap(), None);
    // Signed but no key to check it: said, since a changed trailer would look the same.
    let w = check(&signed, vec![], false).unwrap().unwrap();
    assert!(w.starts_with("m.fbgm: signed by key") && w.contains("serial 7") && w.contains("--pubkey"), "{w}");
    assert!(check(&signed, vec![], true).unwrap_err().to_string().contains("--require-signature"));
    // The serial, a signature byte, the blob changed after signing; another key.
    let at = TINY.len();
    for (what, byte) in [("serial", at + 8), ("signature", signed.len() - 40), ("blob", 20)] {
        let mut bad = signed.clone();
        bad[byte] ^= 1;
        let w = check(&bad, lab(), false).unwrap().unwrap();
        assert!(w.contains("does not verify"), "{what}: {w}");
        let e = check(&bad, lab(), true).unwrap_err().to_string();
        assert!(e.contains("does not verify") && e.contains("refused (--require-signature)"), "{what}: {e}");
    }
    let w = check(&signed, vec![d.path().join("other.pub.hex")], false).unwrap().unwrap();
    assert!(w.contains("not trusted"), "{w}");
    let e = check(TINY, lab(), true).unwrap_err().to_string();
    assert!(e.contains("not signed") && e.contains("--require-signature"), "{e}");
    // A key file that is not a key is an error, whatever the model.
    std::fs::write(d.path().join("junk.pub"), b"junk").unwrap();
    assert!(sign::HostTrust::load(&[d.path().join("junk.pub")], false).is_err());
}
