//! The board's front end (issue 23, item 1): `[board]` in the instrument file, the shipped
//! Discovery board file, the host loop's quantization with it, `ptsa design`'s board, the
//! refusals of a bad `[board]`, and the firmware's generated constants checked for
//! freshness against `ptsa design --firmware-constants`.

mod common;

use std::path::{Path, PathBuf};

use common::{assert_clean_of, ptsa_in, refused_in_folder, stderr, stdout};

/// The repository root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

const BOARD_FILE: &str = "data/kearfott-2401-discovery.toml";

fn board_text() -> String {
    std::fs::read_to_string(root().join(BOARD_FILE)).unwrap()
}

/// `ptsa args --json` in the repository root, parsed.
fn json(args: &[&str]) -> serde_json::Value {
    let o = ptsa_in(&root(), args);
    assert!(o.status.success(), "ptsa {args:?}: {}", stderr(&o));
    serde_json::from_str(&stdout(&o)).unwrap()
}

/// CI's freshness check of the firmware's constants: `firmware/src/constants.rs` must be
/// what `ptsa design --firmware-constants` makes of the board's instrument file.
#[test]
fn the_firmware_constants_are_what_the_board_file_gives() {
    let o = ptsa_in(
        &root(),
        &["--instrument", BOARD_FILE, "design", "--firmware-constants"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let generated = stdout(&o);
    let on_disk = std::fs::read_to_string(root().join("firmware/src/constants.rs")).unwrap();
    assert!(
        on_disk == generated,
        "firmware/src/constants.rs is stale (not what {BOARD_FILE} gives): run `cargo xtask \
         constants` and commit it; expected:\n{generated}"
    );
    // It holds the designed loop (the shipped file's, bit for bit) and the board's ADC.
    assert!(
        generated.contains("b0: Coef::from_bits(362_602_752)"),
        "{generated}"
    );
    assert!(generated.contains("AdcFormat::new(12, Coding::OffsetBinary, Alignment::Left)"));
    assert!(generated.contains("pub const TICK_HZ: u32 = 64_000;"));
}

/// The board file is the shipped instrument file plus `[board]`: every other line the same.
#[test]
fn the_board_file_is_the_shipped_instrument_with_a_board() {
    let shipped = std::fs::read_to_string(root().join("data/kearfott-2401.toml")).unwrap();
    let strip = |t: &str| -> String {
        let t = &t[t.find("[pendulum]").unwrap()..];
        let (before, rest) = t.split_at(t.find("[board]").unwrap_or(t.len()));
        let after = rest.find("\n[stops]").map_or("", |i| &rest[i + 1..]);
        format!("{before}{after}")
    };
    let board = board_text();
    assert!(board.contains("[board]"));
    assert_eq!(strip(&board), strip(&shipped));
}

/// `ptsa design` prints the board and the same compensator as the shipped file (the front
/// end gives the designed loop gain); a board whose gain differs gets its own design.
#[test]
fn design_prints_the_board_and_its_loop() {
    let o = ptsa_in(&root(), &["--instrument", BOARD_FILE, "design"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for needle in [
        "board ([board]): STM32F4DISCOVERY",
        "12 bits, offset binary, 0..V_REF, left-aligned, V_REF 3.3 V",
        "full scale       = ±2.500000 V",
        "step             = 16 units of the 16-bit sample = 1.2207 mV",
        "1.2207 µrad of pendulum angle",
        "const DEFAULT_B0_BITS: i32 = 362_602_752;",
        "phase margin 112.4 deg, gain margin 26.3 dB",
    ] {
        assert!(out.contains(needle), "`{needle}` not in:\n{out}");
    }
    // A front end without the 0.66 gain: the converter's ±1.65 V is the full scale, the
    // loop gain 2.5/1.65 = 1.52 times the shipped design's, so the compensator is designed
    // again (a smaller b0) for it.
    let tmp = tempfile::tempdir().unwrap();
    let unity = board_text()
        .replace("front_end_gain = 0.66", "front_end_gain = 1.0")
        .replace("adc_full_scale_v = 2.5", "adc_full_scale_v = 1.65");
    std::fs::write(tmp.path().join("unity.toml"), unity).unwrap();
    let o = ptsa_in(tmp.path(), &["--instrument", "unity.toml", "design"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let b0 = out
        .lines()
        .find_map(|l| l.strip_prefix("const DEFAULT_B0_BITS: i32 = "))
        .unwrap()
        .trim_end_matches(';')
        .replace('_', "")
        .parse::<f64>()
        .unwrap();
    let ratio = 362_602_752.0 / b0;
    assert!((ratio - 2.5 / 1.65).abs() < 1e-3, "b0 ratio {ratio}");
}

/// A `[board]` that describes the design's own converter (16 bits, two's complement, ±2.5 V
/// at unity gain) is the board-less loop bit for bit; the Discovery's 12-bit converter
/// delivers only every 16th sample value.
#[test]
fn a_board_quantizes_as_its_converter() {
    let tmp = tempfile::tempdir().unwrap();
    let design = board_text()
        .replace("adc_bits = 12", "adc_bits = 16")
        .replace("adc_reference_v = 3.3", "adc_reference_v = 5.0")
        .replace(
            "adc_coding = \"offset_binary\"",
            "adc_coding = \"twos_complement\"",
        )
        .replace("front_end_gain = 0.66", "front_end_gain = 1.0")
        .replace("front_end_offset_v = 1.65", "front_end_offset_v = 0.0");
    std::fs::write(tmp.path().join("design.toml"), design).unwrap();
    let design = tmp.path().join("design.toml");
    let design = design.to_str().unwrap();
    let accels = "-15000,-1000,0,2500,17000";
    let args = |instr: &str| {
        json(&[
            "--instrument",
            instr,
            "static",
            "--accel-cm-s2",
            accels,
            "--seconds",
            "0.25",
            "--json",
        ])
    };
    assert_eq!(args(design), args("data/kearfott-2401.toml"));

    let trace = tmp.path().join("t.txt");
    let o = ptsa_in(
        &root(),
        &[
            "--instrument",
            BOARD_FILE,
            "static",
            "--accel-cm-s2",
            "1234.5",
            "--seconds",
            "0.05",
            "--warmup-s",
            "0",
            "--trace",
            trace.to_str().unwrap(),
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let codes: Vec<i32> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .filter_map(|l| l.trim().parse().ok())
        .collect();
    assert!(codes.len() >= 3200, "{}", codes.len());
    assert!(
        codes.iter().all(|c| (c + 32768) % 16 == 0),
        "a code off the 12-bit grid"
    );
    assert!(
        codes.iter().any(|&c| c != codes[0]),
        "the trace does not move"
    );
}

/// A bad `[board]` is refused at its line and column, saying what was expected.
#[test]
fn a_bad_board_is_refused_at_its_position() {
    let text = board_text();
    let line_of = |needle: &str| {
        text.lines()
            .position(|l| l.starts_with(needle))
            .map(|i| i + 1)
            .unwrap()
    };
    let cases: [(&str, &str, String, &str); 7] = [
        (
            "adc_bits = 12",
            "adc_bits = 12.5",
            format!("b.toml:{}:12: board.adc_bits = 12.5", line_of("adc_bits")),
            "expected a whole number of bits from 1 to 16",
        ),
        (
            "adc_bits = 12",
            "adc_bits = 17",
            format!("b.toml:{}:12: board.adc_bits = 17", line_of("adc_bits")),
            "from 1 to 16",
        ),
        (
            "adc_coding = \"offset_binary\"",
            "adc_coding = \"gray\"",
            format!(
                "b.toml:{}:14: board.adc_coding = \"gray\"",
                line_of("adc_coding")
            ),
            "expected one of \"offset_binary\", \"twos_complement\"",
        ),
        (
            "adc_alignment = \"left\"",
            "adc_alignment = \"middle\"",
            format!("b.toml:{}:17:", line_of("adc_alignment")),
            "expected one of \"left\", \"right\"",
        ),
        (
            "front_end_gain = 0.66",
            "front_end_gain = -0.66",
            format!(
                "b.toml:{}:18: board.front_end_gain = -0.66",
                line_of("front_end_gain")
            ),
            "expected a gain > 0 V/V",
        ),
        (
            "front_end_offset_v = 1.65",
            "front_end_offset_v = 4.0",
            format!("b.toml:{}:22:", line_of("front_end_offset_v")),
            "|offset| < board.adc_reference_v",
        ),
        (
            "front_end_gain = 0.66",
            "front_end_gain = 1.0",
            format!(
                "b.toml:{}:20: electronics.adc_full_scale_v = 2.5 V disagrees with [board]",
                line_of("adc_full_scale_v")
            ),
            "expected them equal",
        ),
    ];
    for (from, to, at, expected) in &cases {
        let bad = text.replace(from, to);
        assert_ne!(bad, text, "{from}");
        let err = refused_in_folder(
            &[("b.toml", bad.as_bytes())],
            &["--instrument", "{dir}/b.toml", "design"],
            1,
            &[at, expected],
            &[],
        );
        assert_clean_of(&err, &[]);
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}

/// `ptsa static --pil-params`: the parameters of one noiseless run, every line the image
/// reads; refused with noise, with several accelerations, over an existing file without
/// `--force`.
#[test]
fn pil_params_are_written_for_one_noiseless_run_only() {
    let quiet = board_text().replace(
        "noise_uv_rms = { value = 0.5,",
        "noise_uv_rms = { value = 0.0,",
    );
    assert_ne!(quiet, board_text());
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("q.toml"), &quiet).unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "--instrument",
            "q.toml",
            "static",
            "--accel-cm-s2",
            "1000",
            "--seconds",
            "0.1",
            "--warmup-s",
            "0.05",
            "--pil-params",
            "p.txt",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).is_empty());
    let p = std::fs::read_to_string(tmp.path().join("p.txt")).unwrap();
    for key in [
        "config 362602752 -360827191 64262 224131 64 0",
        "adc ",
        " 65520\n",
        "stop ",
        "phi0 0 ",
        "phi2 3 ",
        "add0 0 ",
        "add2 1 ",
        "x0 ",
        "run 3200 6400",
    ] {
        assert!(p.contains(key), "`{key}` not in:\n{p}");
    }
    // Every f64 as 16 hexadecimal digits: the ADC's gain is the board's codes per rad.
    let gain = p
        .lines()
        .find_map(|l| l.strip_prefix("adc "))
        .and_then(|l| l.split_whitespace().next())
        .map(|h| f64::from_bits(u64::from_str_radix(h, 16).unwrap()))
        .unwrap();
    assert!(
        (gain - 10.0 * 100.0 / (2.5 / 32768.0)).abs() < 1e-6 * gain,
        "{gain}"
    );

    let before = std::fs::read(tmp.path().join("p.txt")).unwrap();
    let base = [
        "--instrument",
        "{dir}/q.toml",
        "static",
        "--accel-cm-s2",
        "1000",
        "--pil-params",
        "{dir}/p.txt",
    ];
    refused_in_folder(
        &[("q.toml", quiet.as_bytes()), ("p.txt", &before)],
        &base,
        1,
        &["p.txt", "exists"],
        &[],
    );
    let several = base.map(|a| if a == "1000" { "1000,2000" } else { a });
    refused_in_folder(
        &[("q.toml", quiet.as_bytes())],
        &several,
        1,
        &[
            "--pil-params writes the parameters of one run; expected one --accel-cm-s2 value with it, not 2",
        ],
        &[],
    );
    // With the board's noise: the generator's state and its whole table.
    let noisy = ptsa_in(
        tmp.path(),
        &[
            "--instrument",
            &root().join(BOARD_FILE).to_string_lossy(),
            "static",
            "--accel-cm-s2",
            "1000",
            "--pil-params",
            "n.txt",
        ],
    );
    assert!(noisy.status.success(), "{}", stderr(&noisy));
    let n = std::fs::read_to_string(tmp.path().join("n.txt")).unwrap();
    assert!(n.contains("\nnoise ") && n.contains("\nntab 511 "), "{n}");
    assert!(!n.contains("\nntab 512 "), "{n}");
}

/// The run of the moving-input tests: 1234.5 cm/s², 0.1 s after 0.05 s.
const MOVING_BASE: [&str; 7] = [
    "static",
    "--accel-cm-s2",
    "1234.5",
    "--seconds",
    "0.1",
    "--warmup-s",
    "0.05",
];

/// `ptsa static --record`: with a constant input, gates that add up to the counts of
/// `--json`; a sine's and a step's records and parameters (the phasors, the step's plant
/// inputs).
#[test]
fn moving_inputs_give_records_and_pil_params() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| ptsa_in(tmp.path(), args);
    let base = MOVING_BASE;
    let json = run(&[&base[..], &["--json"]].concat());
    assert!(json.status.success(), "{}", stderr(&json));
    let v: serde_json::Value = serde_json::from_str(&stdout(&json)).unwrap();
    let one = run(&[&base[..], &["--gate-s", "0.05", "--record", "two.csv"]].concat());
    assert!(one.status.success(), "{}", stderr(&one));
    let rec = std::fs::read_to_string(tmp.path().join("two.csv")).unwrap();
    let gates: Vec<(u64, u64)> = rec
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("time_s"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[1].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect();
    assert_eq!(gates.len(), 2, "{rec}");
    assert!(rec.contains("\n0.05,"), "{rec}");
    assert_eq!(
        gates.iter().map(|g| g.0).sum::<u64>(),
        v["pulses"].as_u64().unwrap(),
        "{rec} against {v}"
    );
    assert_eq!(
        gates.iter().map(|g| g.1).sum::<u64>(),
        v["ticks"].as_u64().unwrap()
    );

    let sine = [
        "--sine-hz",
        "50",
        "--sine-cm-s2",
        "3000",
        "--gate-s",
        "0.005",
    ];
    let o = run(&[&base[..], &sine, &["--pil-params", "s.txt"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let p = std::fs::read_to_string(tmp.path().join("s.txt")).unwrap();
    for key in [
        "\nrun 3200 6400 320\n",
        "\nsine ",
        "\ngu2 ",
        "\ngd0 ",
        "\nstoptorque ",
        "\nphasor 2 ",
    ] {
        assert!(p.contains(key), "`{key}` not in:\n{p}");
    }
    assert!(!p.contains("\nphasor 3 "), "{p}");
    let o = run(&[&base[..], &sine, &["--record", "s.csv"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let rec = std::fs::read_to_string(tmp.path().join("s.csv")).unwrap();
    assert_eq!(
        rec.lines().filter(|l| l.ends_with(",320")).count(),
        20,
        "{rec}"
    );

    let step = [
        "--step-cm-s2",
        "-2000",
        "--step-at-s",
        "0.07",
        "--gate-s",
        "0.01",
    ];
    let o = run(&[&base[..], &step, &["--pil-params", "t.txt"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let p = std::fs::read_to_string(tmp.path().join("t.txt")).unwrap();
    assert!(
        p.contains("\nstep 4480\n") && p.contains("\nstepadd2 1 "),
        "{p}"
    );
}

/// Moving inputs refused without --pil-params or --record, or without --gate-s; a gate that
/// does not divide the run; a step after its end. Nothing is written.
#[test]
fn moving_inputs_are_refused_outside_a_record() {
    let tmp = tempfile::tempdir().unwrap();
    let base = MOVING_BASE;
    for (args, needle) in [
        (
            vec!["--sine-hz", "50", "--sine-cm-s2", "3000"],
            "describe a run for --pil-params or --record",
        ),
        (
            vec![
                "--sine-hz",
                "50",
                "--sine-cm-s2",
                "3000",
                "--record",
                "x.csv",
            ],
            "need --gate-s",
        ),
        (
            vec!["--gate-s", "0.003", "--record", "x.csv"],
            "does not divide the settling",
        ),
        (
            vec![
                "--step-cm-s2",
                "1",
                "--step-at-s",
                "9",
                "--gate-s",
                "0.005",
                "--record",
                "x.csv",
            ],
            "expected it inside the run",
        ),
    ] {
        let o = ptsa_in(tmp.path(), &[&base[..], &args].concat());
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    assert!(!tmp.path().join("x.csv").exists());
}
