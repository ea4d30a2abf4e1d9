//! The bit-exactness contract: every `tests/golden/*.in` run through ptsa-core must give its
//! `.out` exactly, line for line (one line per tick, then the state digest).

use std::fs;
use std::path::PathBuf;

use ptsa_core::trace::GoldenRunner;
use ptsa_tests::{first_difference, golden_cases};

fn run(input: &[u8], chunk: usize) -> String {
    let mut out = String::new();
    let mut r = GoldenRunner::new();
    for part in input.chunks(chunk) {
        r.feed(part, &mut out).expect("golden input parses");
    }
    r.finish(&mut out).expect("golden input parses");
    out
}

fn cases() -> Vec<(String, PathBuf, PathBuf)> {
    let cases = golden_cases();
    assert!(
        cases.len() >= 15,
        "expected the golden set in tests/golden, found {} cases",
        cases.len()
    );
    cases
}

#[test]
fn every_golden_vector_matches_bit_for_bit() {
    let mut failures = Vec::new();
    for (name, input, expected) in cases() {
        let input = fs::read(&input).expect("read .in");
        let expected = fs::read_to_string(&expected).expect("read .out");
        // Odd chunk sizes also check that the runner's line assembly is split-invariant.
        for chunk in [usize::MAX, 7] {
            let got = run(&input, chunk.min(input.len().max(1)));
            if let Some(d) = first_difference(&expected, &got) {
                failures.push(format!("{name} (chunks of {chunk}): {d}"));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "golden mismatches:\n{}",
        failures.join("\n")
    );
}

#[test]
fn one_flipped_bit_in_any_expected_file_is_caught() {
    for (name, input, expected) in cases() {
        let got = run(&fs::read(&input).expect("read .in"), usize::MAX);
        let mut bytes = fs::read(&expected).expect("read .out");
        // Flip the lowest bit of a byte in the middle and of the digest's last digit.
        for at in [bytes.len() / 2, bytes.len() - 2] {
            bytes[at] ^= 1;
            let mutated = String::from_utf8_lossy(&bytes).into_owned();
            assert!(
                first_difference(&mutated, &got).is_some(),
                "{name}: flipping bit 0 of byte {at} went unnoticed"
            );
            bytes[at] ^= 1;
        }
    }
}

#[test]
fn one_lsb_change_in_any_input_changes_the_output() {
    for (name, input, _) in cases() {
        let text = fs::read_to_string(&input).expect("read .in");
        let base = run(text.as_bytes(), usize::MAX);
        // Change the last sample by one LSB: the state digest (which holds e[n-1]) must move.
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let last = lines
            .iter()
            .rposition(|l| l.parse::<i16>().is_ok())
            .expect("a sample");
        let x: i16 = lines[last].parse().expect("sample");
        lines[last] = if x == i16::MAX { x - 1 } else { x + 1 }.to_string();
        let changed = run(lines.join("\n").as_bytes(), usize::MAX);
        assert_ne!(
            base, changed,
            "{name}: a one-LSB input change left the output unchanged"
        );
    }
}

/// Vectors recorded from the host's closed loop carry the polarities the host decided in
/// `# host` comment lines: the expected output must have exactly those polarities.
#[test]
fn host_closed_loop_vectors_have_the_host_polarities() {
    let mut checked = 0;
    for (name, input, expected) in cases() {
        let text = fs::read_to_string(&input).expect("read .in");
        let host: String = text
            .lines()
            .filter_map(|l| l.strip_prefix("# host "))
            .collect();
        if host.is_empty() {
            continue;
        }
        let out = fs::read_to_string(&expected).expect("read .out");
        let golden: String = out
            .lines()
            .filter(|l| !l.starts_with("end"))
            .filter_map(|l| l.chars().next())
            .collect();
        assert_eq!(host.len(), golden.len(), "{name}: tick counts differ");
        if let Some(i) = host.chars().zip(golden.chars()).position(|(a, b)| a != b) {
            panic!(
                "{name}: tick {} decided differently by the host and by the golden output",
                i + 1
            );
        }
        checked += 1;
    }
    assert!(checked >= 1, "no host closed-loop vector in tests/golden");
}
