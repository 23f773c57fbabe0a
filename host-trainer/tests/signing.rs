//! Signing keys and signed blobs: `keygen` (mode 0600, never overwrites), serials per key,
//! a blob signed by the trainer (ed25519-dalek) verified on the device's code path
//! (`fbg_shared::signature::verify`, the verifier the firmware links), and the `sign` and
//! `inspect --pubkey` commands.

use std::path::Path;
use std::process::Command;

use fbg_shared::signature::{self, key_id, Envelope, SignFlags, SignatureError, TrustedKey};
use fbg_trainer::sign::{self, BlobSigner, SignOptions};

const TINY: &[u8] = include_bytes!("../../shared/tests/golden/tiny_v4.fbgm");

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
    let signer = BlobSigner::load(&SignOptions { key: key.clone(), ..SignOptions::default() }).unwrap();
    assert_eq!(signer.key_id(), lab.id);
    let (signed, rec) = signer.sign(TINY).unwrap();
    assert_eq!((rec.serial, rec.key_id.as_str(), rec.allow_rollback), (1, lab.id.to_string().as_str(), false));
    // The device's path: open the trailer, look the key up, verify with the firmware's verifier.
    let Envelope::Signed(s) = signature::open(&signed).unwrap() else { panic!("no trailer") };
    assert_eq!(s.blob, TINY, "the blob before the trailer is the unsigned blob, byte for byte");
    assert_eq!(signature::verify(&s, &[lab]), Ok(()));
    // The blob still decodes as before (host use of signed blobs).
    assert_eq!(fbg_shared::blob::decode::<2>(&signed).unwrap(), fbg_shared::blob::decode::<2>(TINY).unwrap());
    // One payload bit flipped after signing: refused.
    let mut t = signed.clone();
    t[40] ^= 0x08;
    let Envelope::Signed(s) = signature::open(&t).unwrap() else { panic!() };
    assert_eq!(signature::verify(&s, &[lab]), Err(SignatureError::BadSignature));
    // Re-signing replaces the signature (the trailer is not stacked).
    let (again, rec2) = signer.sign(&signed).unwrap();
    assert_eq!(again.len(), signed.len());
    assert_eq!(rec2.serial, 2);
    // Allow-rollback is a signed flag.
    let rb = BlobSigner::load(&SignOptions { key, serial: Some(2), allow_rollback: true }).unwrap();
    let (down, rec3) = rb.sign(TINY).unwrap();
    assert_eq!((rec3.serial, rec3.allow_rollback), (2, true));
    let Envelope::Signed(s) = signature::open(&down).unwrap() else { panic!() };
    assert!(s.head.flags.contains(SignFlags::ALLOW_ROLLBACK));
    assert_eq!(signature::verify(&s, &[lab]), Ok(()));
}

#[test]
fn serials_grow_per_key_even_when_signers_race() {
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("lab.key");
    sign::keygen(&key).unwrap();
    let opts = SignOptions { key: key.clone(), ..SignOptions::default() };
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
