//! The device's signature verifier (`fbg_shared::signature`, as the firmware runs it) built for
//! the host: the RFC 8032 Ed25519 test vectors (section 7.1), strictness, and the trailer of
//! a signed blob end to end.

use fbg_shared::blob;
use fbg_shared::container::{open, Envelope};
use fbg_shared::signature::{
    key_id, verify, verify_message, KeyId, SignFlags, SignatureError, TrailerHead, TrustedKey, SIGNATURE_LEN,
    TRAILER_LEN,
};

fn hex(s: &str) -> Vec<u8> {
    let s: String = s.split_whitespace().collect();
    (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
}

fn arr<const N: usize>(v: &[u8]) -> [u8; N] {
    v.try_into().unwrap()
}

/// RFC 8032, section 7.1: (secret key, public key, message, signature).
const RFC8032: [(&str, &str, &str, &str); 4] = [
    (
        // TEST 1
        "9d61b19deffd5a60ba844af492ec2cc44449c5697b326919703bac031cae7f60",
        "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a",
        "",
        "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b",
    ),
    (
        // TEST 2
        "4ccd089b28ff96da9db6c346ec114e0f5b8a319f35aba624da8cf6ed4fb8a6fb",
        "3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c",
        "72",
        "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da085ac1e43e15996e458f3613d0f11d8c387b2eaeb4302aeeb00d291612bb0c00",
    ),
    (
        // TEST 3
        "c5aa8df43f9f837bedb7442f31dcb7b166d38535076f094b85ce3a2e0b4458f7",
        "fc51cd8e6218a1a38da47ed00230f0580816ed13ba3303ac5deb911548908025",
        "af82",
        "6291d657deec24024827e69c3abe01a30ce548a284743a445e3680d7db5ac3ac18ff9b538d16f290ae67f760984dc6594a7c15e9716ed28dc027beceea1ec40a",
    ),
    (
        // TEST SHA(abc)
        "833fe62409237b9d62ec77587520911e9a759cec1d19755b7da901b96dca3d42",
        "ec172b93ad5e563bf4932c70e1245034c35467ef2efd4d64ebf819683467e2bf",
        "ddaf35a193617abacc417349ae20413112e6fa4e89a97ea20a9eeee64b55d39a2192992a274fc1a836ba3c23a3feebbd454d4423643ce80e2a9ac94fa54ca49f",
        "dc2a4459e7369633a52b1bf277839a00201009a3efbf3ecb69bea2186c26b58909351fc9ac90b3ecfdfbc7c66431e0303dca179c138ac17ad9bef1177331a704",
    ),
];

#[test]
fn rfc8032_test_vectors_verify_and_any_flipped_bit_is_refused() {
    for (i, (_, pk, msg, sig)) in RFC8032.iter().enumerate() {
        let (pk, msg, sig) = (arr::<32>(&hex(pk)), hex(msg), arr::<64>(&hex(sig)));
        assert_eq!(verify_message(&msg, &sig, &pk), Ok(()), "RFC 8032 vector {i}");
        for bit in [0, 7, 255, 256, 511] {
            let mut bad = sig;
            bad[bit / 8] ^= 1 << (bit % 8);
            assert_eq!(verify_message(&msg, &bad, &pk), Err(SignatureError::BadSignature), "vector {i}, bit {bit}");
        }
        let mut other = msg.clone();
        other.push(0);
        assert_eq!(verify_message(&other, &sig, &pk), Err(SignatureError::BadSignature), "vector {i}, longer message");
        let mut wrong_key = pk;
        wrong_key[3] ^= 0x10;
        assert_eq!(verify_message(&msg, &sig, &wrong_key), Err(SignatureError::BadSignature), "vector {i}, other key");
    }
}

/// The verifier is the strict kind: S + L (the same signature, non-canonical) is refused, so a
/// signature cannot be altered into another valid one.
#[test]
fn a_non_canonical_s_is_refused() {
    let (_, pk, msg, sig) = RFC8032[0];
    let (pk, msg, mut sig) = (arr::<32>(&hex(pk)), hex(msg), arr::<64>(&hex(sig)));
    // L = 2^252 + 27742317777372353535851937790883648493, little-endian.
    let l = hex("edd3f55c1a631258d69cf7a2def9de1400000000000000000000000000000010");
    let mut carry = 0u16;
    for k in 0..32 {
        let v = sig[32 + k] as u16 + l[k] as u16 + carry;
        sig[32 + k] = v as u8;
        carry = v >> 8;
    }
    assert_eq!(carry, 0);
    assert_eq!(verify_message(&msg, &sig, &pk), Err(SignatureError::BadSignature));
}

#[test]
fn key_id_is_the_first_8_bytes_of_sha256() {
    let pk = arr::<32>(&hex(RFC8032[0].1));
    // `printf d75a…511a | xxd -r -p | sha256sum | cut -c1-16`
    assert_eq!(key_id(&pk).to_string(), "21fe31dfa154a261");
}

fn tiny_blob() -> Vec<u8> {
    std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/tiny_v7.fbgm")).unwrap()
}

/// Sign `blob` as the trainer does: the message is the blob and the trailer's head; the file is
/// the message and the signature.
fn sign(blob: &[u8], seed: [u8; 32], serial: u64, flags: SignFlags) -> (Vec<u8>, TrustedKey) {
    let kp = ed25519_compact::KeyPair::from_seed(ed25519_compact::Seed::new(seed));
    let public: [u8; 32] = *kp.pk;
    let id = key_id(&public);
    let mut out = blob.to_vec();
    out.extend_from_slice(&TrailerHead { flags, serial, key_id: id, replaces: None }.to_bytes());
    let sig = kp.sk.sign(&out, None);
    out.extend_from_slice(&sig[..]);
    (out, TrustedKey { id, public })
}

#[test]
fn a_signed_blob_decodes_verifies_and_fails_when_touched() {
    let blob = tiny_blob();
    let (signed, key) = sign(&blob, [5; 32], 42, SignFlags::NONE);
    assert_eq!(signed.len(), blob.len() + TRAILER_LEN);
    // Decoding skips the trailer: the same model as the unsigned blob.
    assert_eq!(blob::decode::<8>(&signed).unwrap(), blob::decode::<8>(&blob).unwrap());
    let Envelope::Signed(s) = open(&signed).unwrap() else { panic!("a trailer was expected") };
    assert_eq!((s.head.serial, s.head.key_id, s.head.flags), (42, key.id, SignFlags::NONE));
    assert_eq!(verify(&s, &[key]), Ok(()));
    // Another trusted key only: unknown.
    let (_, other) = sign(&blob, [6; 32], 1, SignFlags::NONE);
    assert_eq!(verify(&s, &[other]), Err(SignatureError::UnknownKey { key_id: key.id }));
    // A trusted key whose id is right but whose public part is another key's: bad signature.
    assert_eq!(verify(&s, &[TrustedKey { id: key.id, public: other.public }]), Err(SignatureError::BadSignature));

    // Every byte of the message is covered: blob header, payload, CRC, serial, flags, key id.
    for at in [0, 5, 16, blob.len() / 2, blob.len() - 1, blob.len() + 8, blob.len() + 16, blob.len() + 23] {
        let mut t = signed.clone();
        t[at] ^= 0x01;
        let got = match open(&t) {
            Ok(Envelope::Signed(s)) => verify(&s, &[key]),
            Ok(Envelope::Unsigned(_)) => Err(SignatureError::Unsigned),
            Err(e) => Err(e),
        };
        let flipped_key_id = (blob.len() + 16..blob.len() + 24).contains(&at);
        let want = if flipped_key_id {
            let mut id = key.id;
            id.0[at - blob.len() - 16] ^= 1;
            SignatureError::UnknownKey { key_id: id }
        } else {
            SignatureError::BadSignature
        };
        assert_eq!(got, Err(want), "byte {at} flipped");
    }
    // The signature itself.
    let mut t = signed.clone();
    let n = t.len();
    t[n - SIGNATURE_LEN / 2] ^= 0x80;
    let Ok(Envelope::Signed(s)) = open(&t) else { panic!() };
    assert_eq!(verify(&s, &[key]), Err(SignatureError::BadSignature));
    // The unsigned blob is unsigned.
    assert_eq!(open(&blob), Ok(Envelope::Unsigned(&blob[..])));
}

#[test]
fn the_allow_rollback_flag_is_signed() {
    let blob = tiny_blob();
    let (signed, key) = sign(&blob, [5; 32], 3, SignFlags::ALLOW_ROLLBACK);
    let Envelope::Signed(s) = open(&signed).unwrap() else { panic!() };
    assert!(s.head.flags.contains(SignFlags::ALLOW_ROLLBACK));
    assert_eq!(verify(&s, &[key]), Ok(()));
    // Clearing the flag (or setting it on a model signed without it) breaks the signature.
    let mut t = signed.clone();
    t[blob.len() + 5] = 0;
    let Envelope::Signed(s) = open(&t).unwrap() else { panic!() };
    assert_eq!(verify(&s, &[key]), Err(SignatureError::BadSignature));
    let _ = KeyId::default();
}
