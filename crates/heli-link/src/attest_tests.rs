//! The attestation: signed, checked, and judged against what flies.

use super::*;

fn key(byte: u8) -> Key {
    let mut bytes = [0u8; 32];
    for (i, b) in bytes.iter_mut().enumerate() {
        *b = byte.wrapping_add(u8::try_from(i).unwrap().wrapping_mul(37));
    }
    Key::new(bytes)
}

fn table() -> ParamTable {
    heli_table()
}

/// A table like the vehicle's (two of its parameters).
fn heli_table() -> ParamTable {
    ParamTable::new(&SPECS)
}

const SPECS: [crate::params::ParamSpec; 3] = [
    crate::params::ParamSpec {
        name: "HOV_MAX_CLIMB",
        what: "",
        min: 0.2,
        max: 3.0,
        default: 1.5,
    },
    crate::params::ParamSpec {
        name: "YAW_RATE_I",
        what: "",
        min: 0.0,
        max: 1.0,
        default: 0.1,
    },
    crate::params::ParamSpec {
        name: "HOV_VEL_P",
        what: "",
        min: 0.1,
        max: 5.0,
        default: 1.4,
    },
];

fn body(identity: Identity) -> Body {
    Body {
        format: FORMAT,
        identity,
        certified_unix_s: 1_795_000_000,
        certified_by: "heli test".into(),
        replays: vec![ReplayEvidence {
            flight: "hover.mcap".into(),
            flight_sha256: "00".repeat(32),
            recorded: 1200,
            paired: 1200,
            out_of_tolerance: 0,
            largest_difference_us: 0,
            ran_through: true,
        }],
        suite: SuiteEvidence {
            dir: "campaigns/robustness".into(),
            flights: 800,
            pass: 795,
            crash: 0,
            error: 0,
            min_pass_permille: 990,
        },
    }
}

fn judged(identity: &Identity, text: &str, key: &Key) -> Verdict {
    judge(identity, Path::new("a.json"), Ok(Some(text)), Some(key))
}

#[test]
fn hmac_sha256_is_rfc_4231s() {
    // RFC 4231 test case 2 needs a 4-byte key; case 1's 20-byte key, zero-padded to 32
    // bytes, is the same HMAC key (HMAC pads short keys with zeros).
    let mut bytes = [0u8; 32];
    bytes[..20].copy_from_slice(&[0x0b; 20]);
    let mac = Key::new(bytes).hmac_sha256(b"Hi There");
    assert_eq!(
        hex(&mac),
        "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7"
    );
}

#[test]
fn a_signed_attestation_verifies_and_any_change_or_another_key_does_not() {
    let identity = Identity::new("ab".repeat(32), &table());
    let k = key(1);
    let text = to_text(&sign(body(identity.clone()), &k).unwrap()).unwrap();
    assert_eq!(verify(&text, &k).unwrap().identity, identity);
    assert_eq!(verify(&text, &key(2)), Err(AttestError::Signature));
    // One value edited: the signature no longer holds.
    let edited = text.replace("\"pass\": 795", "\"pass\": 800");
    assert_ne!(edited, text);
    assert_eq!(verify(&edited, &k), Err(AttestError::Signature));
    // Spacing is not a value.
    let compact =
        serde_json::to_string(&serde_json::from_str::<Attestation>(&text).unwrap()).unwrap();
    assert!(verify(&compact, &k).is_ok());
    assert!(matches!(verify("{}", &k), Err(AttestError::Unreadable(_))));
}

#[test]
fn the_same_build_and_parameters_are_lab_tested() {
    let identity = Identity::new("ab".repeat(32), &table());
    let k = key(3);
    let text = to_text(&sign(body(identity.clone()), &k).unwrap()).unwrap();
    let verdict = judged(&identity, &text, &k);
    assert_eq!(verdict.tested(), Tested::LabTested, "{}", verdict.line());
    let line = verdict.line();
    assert!(line.starts_with("lab-tested: build abababab"), "{line}");
    assert!(line.contains("robustness suite 795 of 800"), "{line}");
}

#[test]
fn a_changed_gain_or_build_is_not_lab_tested_and_says_what_changed() {
    let tested = Identity::new("ab".repeat(32), &table());
    let k = key(4);
    let text = to_text(&sign(body(tested.clone()), &k).unwrap()).unwrap();
    let mut changed = table();
    changed.set("HOV_MAX_CLIMB", 0.5).unwrap();
    let verdict = judged(&Identity::new("ab".repeat(32), &changed), &text, &k);
    assert_eq!(verdict.tested(), Tested::NotTested);
    let line = verdict.line();
    assert!(
        line.starts_with("NOT lab-tested: parameters changed since the lab's tests: HOV_MAX_CLIMB 0.5 (tested 1.5)"),
        "{line}"
    );
    let verdict = judged(&Identity::new("cd".repeat(32), &table()), &text, &k);
    let line = verdict.line();
    assert!(
        line.contains("the build changed (this flight software cdcdcdcd, the lab tested abababab)"),
        "{line}"
    );
    assert!(!line.contains("parameters"), "{line}");
}

#[test]
fn no_key_no_file_a_bad_file_or_failed_tests_are_not_lab_tested() {
    let identity = Identity::new("ab".repeat(32), &table());
    let k = key(5);
    let path = Path::new("/vehicle/attestation.json");
    let line = |v: Verdict| {
        assert_eq!(v.tested(), Tested::NotTested);
        v.line()
    };
    let text = to_text(&sign(body(identity.clone()), &k).unwrap()).unwrap();
    assert!(line(judge(&identity, path, Ok(Some(&text)), None)).contains("no key"));
    assert!(
        line(judge(&identity, path, Ok(None), Some(&k)))
            .contains("no lab attestation at /vehicle/attestation.json")
    );
    assert!(
        line(judge(&identity, path, Err("permission denied"), Some(&k)))
            .contains("cannot be read: permission denied")
    );
    assert!(
        line(judge(&identity, path, Ok(Some("garbage")), Some(&k))).contains("not an attestation")
    );
    let mut failed = body(identity.clone());
    failed.suite.crash = 1;
    let text = to_text(&sign(failed, &k).unwrap()).unwrap();
    assert!(line(judged(&identity, &text, &k)).contains("did not pass"));
    let mut other_format = body(identity.clone());
    other_format.format = 2;
    let text = to_text(&sign(other_format, &k).unwrap()).unwrap();
    assert!(line(judged(&identity, &text, &k)).contains("format 2"));
}

#[test]
fn a_replay_is_accepted_only_whole_and_the_suite_only_at_its_rate() {
    let b = body(Identity::new(String::new(), &table()));
    let mut r = b.replays[0].clone();
    assert!(r.accepted());
    r.paired -= 1;
    assert!(!r.accepted());
    r.paired = r.recorded;
    r.ran_through = false;
    assert!(!r.accepted());
    r.ran_through = true;
    r.recorded = 0;
    r.paired = 0;
    assert!(!r.accepted(), "nothing compared is nothing accepted");
    // A changed command is no refusal: the thesis's replay certifies acceptance.
    let mut r = b.replays[0].clone();
    r.out_of_tolerance = 900;
    assert!(r.accepted());
    let mut s = b.suite.clone();
    assert!(s.passed());
    s.pass = 791;
    assert!(!s.passed(), "98.875 % < 99 %");
    s.pass = 792;
    assert!(s.passed(), "99.0 %");
    s.error = 1;
    assert!(!s.passed());
    s.error = 0;
    s.flights = 0;
    s.pass = 0;
    assert!(!s.passed());
}

#[test]
fn the_parameter_hash_covers_every_value_and_the_file_hash_its_bytes() {
    let a = Identity::new(String::new(), &table());
    let mut t = table();
    t.set("YAW_RATE_I", 0.11).unwrap();
    let b = Identity::new(String::new(), &t);
    assert_ne!(a.params_sha256, b.params_sha256);
    assert_eq!(a.params.len(), SPECS.len());
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("prog");
    std::fs::write(&f, b"abc").unwrap();
    assert_eq!(
        file_sha256(&f).unwrap(),
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    );
    assert!(file_sha256(&dir.path().join("none")).is_err());
}

#[test]
fn dates_are_utc() {
    assert_eq!(utc_text(0), "1970-01-01 00:00 UTC");
    assert_eq!(utc_text(951_782_400), "2000-02-29 00:00 UTC");
    assert_eq!(utc_text(1_795_000_000), "2026-11-18 11:06 UTC");
    assert_eq!(short("0123456789"), "01234567");
    assert_eq!(short("01"), "01");
}
