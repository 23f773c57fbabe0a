//! Build script of the device crate: the signature policy compiled into every board's
//! images, written as `trust.rs` in its `OUT_DIR` (`fbg_firmware_device::trust`): the trusted
//! public keys (`FBG_TRUSTED_KEYS`), whether a bounded rollback is accepted
//! (`FBG_ALLOW_ROLLBACK`) and whether the embedded model must be signed
//! (`FBG_REQUIRE_SIGNED_DEFAULT`). One place, so that every board trusts the same keys; key
//! files named relative to `firmware/`.

// A build script runs on the host at build time: a bad environment stops the build with a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::env;
use std::fs;
use std::path::PathBuf;

/// The committed QEMU test key (its private half is in the repository: never for production).
const TEST_KEY: &str = "keys/qemu-test.pub";

fn flag(var: &str, default: bool) -> bool {
    println!("cargo:rerun-if-env-changed={var}");
    match env::var(var) {
        Err(_) => default,
        Ok(v) => match v.trim() {
            "1" | "true" | "yes" => true,
            "0" | "false" | "no" => false,
            other => panic!("{var} must be 0 or 1, got `{other}`"),
        },
    }
}

/// The public keys of one file: raw 32-byte keys back to back, or their hex (whitespace and
/// line breaks ignored).
fn keys_of(path: &std::path::Path) -> Vec<[u8; 32]> {
    let bytes = fs::read(path).unwrap_or_else(|e| panic!("FBG_TRUSTED_KEYS: cannot read {}: {e}", path.display()));
    let text: Option<String> = std::str::from_utf8(&bytes)
        .ok()
        .map(|t| t.chars().filter(|c| !c.is_whitespace()).collect())
        .filter(|t: &String| !t.is_empty() && t.len().is_multiple_of(64) && t.chars().all(|c| c.is_ascii_hexdigit()));
    let raw: Vec<u8> = match text {
        Some(hex) => {
            (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(&hex[i..i + 2], 16).expect("hex digits")).collect()
        }
        None => bytes,
    };
    assert!(
        !raw.is_empty() && raw.len().is_multiple_of(32),
        "FBG_TRUSTED_KEYS: {} holds {} bytes; expected raw 32-byte Ed25519 public keys (lab.pub) or their hex",
        path.display(),
        raw.len()
    );
    raw.chunks_exact(32).map(|c| c.try_into().expect("32 bytes")).collect()
}

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let crate_dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    println!("cargo:rerun-if-changed=build.rs");
    write_trust(&crate_dir.join(".."), &out);
}

/// Write `trust.rs` into `out`; `manifest` is the `firmware/` directory (the test key and
/// relative `FBG_TRUSTED_KEYS` entries are found from there).
fn write_trust(manifest: &std::path::Path, out: &std::path::Path) {
    println!("cargo:rerun-if-env-changed=FBG_TRUSTED_KEYS");
    let spec = env::var("FBG_TRUSTED_KEYS").unwrap_or_default();
    let files: Vec<PathBuf> = if spec.trim().is_empty() {
        vec![manifest.join(TEST_KEY)]
    } else {
        spec.split(',').map(|p| manifest.join(p.trim())).collect()
    };
    let test_key = keys_of(&manifest.join(TEST_KEY));
    let mut keys = Vec::new();
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
        keys.extend(keys_of(f));
    }
    let allow_rollback = flag("FBG_ALLOW_ROLLBACK", false);
    let require_signed_default = flag("FBG_REQUIRE_SIGNED_DEFAULT", false);
    let only_test_key = keys.iter().all(|k| test_key.contains(k));
    let mut src = String::from(
        "// Written by build.rs from FBG_TRUSTED_KEYS, FBG_ALLOW_ROLLBACK and FBG_REQUIRE_SIGNED_DEFAULT.\n\
         /// The public keys whose signatures this image accepts.\n\
         pub static TRUSTED_KEYS: &[fbg_shared::signature::TrustedKey] = &[\n",
    );
    for k in &keys {
        let id = fbg_shared::signature::key_id(k);
        src.push_str(&format!(
            "    fbg_shared::signature::TrustedKey {{ id: fbg_shared::signature::KeyId({:?}), public: {:?} }}, // {id}\n",
            id.0, k
        ));
    }
    src.push_str("];\n");
    src.push_str(&format!(
        "/// A rollback signed for the running serial is accepted (`FBG_ALLOW_ROLLBACK`).\n\
         pub const ALLOW_ROLLBACK: bool = {allow_rollback};\n\
         /// The embedded model must be signed by a trusted key (`FBG_REQUIRE_SIGNED_DEFAULT`).\n\
         pub const REQUIRE_SIGNED_DEFAULT: bool = {require_signed_default};\n\
         /// Only the committed QEMU TEST key is trusted: not a production image.\n\
         pub const TEST_KEY_ONLY: bool = {only_test_key};\n"
    ));
    fs::write(out.join("trust.rs"), src).expect("write trust.rs");
}
