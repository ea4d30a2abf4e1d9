//! `ptsa discover --data STREAM --plan PLAN` on one axis's raw stream (issue 44, items 2
//! and 4): a tumble logged as samples (a MEMS part's LSB) or as the loop's gates (pulses
//! and ticks), cut into its still intervals, the plan's rows filled in order, written
//! for a person and analysed; a stream with a position missing refused with the place.
//!
//! The streams are written here from the equations (the reading `g·s·(K_0 + a_IA)` plus
//! white noise; a gate's pulses `⌊T·d + c⌋` with the charge `c` carried from gate to gate,
//! `d = (1 + u/SF)/2`), with nothing of `ptsa_host_sim`.

use std::fmt::Write as _;
use std::path::Path;

use rand::SeedableRng as _;
use rand_distr::Distribution as _;

mod common;
use common::{assert_clean_of, json_in, ptsa_in, stderr, stdout};

/// A CSV line's cells (a quoted cell may hold commas).
fn cells(line: &str) -> Vec<String> {
    let (mut out, mut cell, mut quoted) = (Vec::new(), String::new(), false);
    for ch in line.chars() {
        match ch {
            '"' => quoted = !quoted,
            ',' if !quoted => out.push(std::mem::take(&mut cell)),
            c => cell.push(c),
        }
    }
    out.push(cell);
    out
}

/// The plan's header and rows, each row's cells.
fn table(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head = cells(lines.next().unwrap());
    (head, lines.map(cells).collect())
}

/// A plan's row: its label, `g_ia`, `g_pa`.
type PlanRow = (String, f64, f64);

/// The plan's rows.
fn plan_rows(text: &str) -> Vec<PlanRow> {
    let (head, rows) = table(text);
    let at = |c: &str| head.iter().position(|h| h == c).unwrap();
    let (l, i, p) = (at("label"), at("g_ia"), at("g_pa"));
    rows.iter()
        .map(|c| {
            let num = |k: usize| c[k].parse::<f64>().unwrap_or(0.0);
            (c[l].clone(), num(i), num(p))
        })
        .collect()
}

/// The tumble angle of each row, rad, and the angle at each sample of a stream at `rate`
/// Hz: a rest of 15 s at the first, then each next reached by a 2 s turn (the share
/// `(1 − cos πτ)/2` of the shortest way) and held `hold_s(i)` s; the holds' spans, s.
fn angles(
    rows: &[PlanRow],
    rate: f64,
    hold_s: &dyn Fn(usize) -> f64,
) -> (Vec<f64>, Vec<(f64, f64)>) {
    let theta: Vec<f64> = rows.iter().map(|r| r.2.atan2(r.1)).collect();
    let mut out = Vec::new();
    let mut spans = Vec::new();
    #[allow(clippy::cast_precision_loss)]
    let mut hold = |th: f64, secs: f64, out: &mut Vec<f64>| {
        let t0 = out.len() as f64 / rate;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let n = (secs * rate).round() as usize;
        out.extend(std::iter::repeat_n(th, n));
        spans.push((t0, (out.len() - 1) as f64 / rate));
    };
    hold(theta[0], 15.0, &mut out);
    for i in 1..theta.len() {
        let (a, b) = (theta[i - 1], theta[i]);
        let d =
            (b - a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let m = (2.0 * rate) as usize;
        for k in 0..m {
            #[allow(clippy::cast_precision_loss)]
            let tau = (k as f64 + 0.5) / m as f64;
            out.push(a + d * 0.5 * (1.0 - (std::f64::consts::PI * tau).cos()));
        }
        hold(b, hold_s(i), &mut out);
    }
    (out, spans)
}

/// The MEMS tumble's truth: `K_0` (g), the scale over nominal, the noise per sample
/// (cm/s²).
const MEMS: (f64, f64, f64) = (0.05, 1.01, 2.0);

/// A MEMS part's 12-position tumble planned in `dir` (plan.csv) and logged at 100 Hz in
/// LSB into `name`, the samples of `skip` (s) left out: the plan's rows and the holds'
/// spans.
fn mems_tumble(dir: &Path, name: &str, skip: Option<usize>) -> (Vec<PlanRow>, Vec<(f64, f64)>) {
    let o = ptsa_in(
        dir,
        &[
            "--instrument",
            "mems",
            "plan",
            "tumble",
            "--positions",
            "12",
            "--output",
            "plan.csv",
            "--force",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = plan_rows(&std::fs::read_to_string(dir.join("plan.csv")).unwrap());
    assert_eq!(rows.len(), 12);
    let (k0_g, scale, sigma) = MEMS;
    let (g, per_lsb) = (980.665, 980.665 / 16384.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    let noise = rand_distr::Normal::new(0.0, sigma).unwrap();
    #[allow(clippy::cast_precision_loss)]
    let hold = |i: usize| 4.0 + (i % 3) as f64;
    let (theta, spans) = angles(&rows, 100.0, &hold);
    // A hold left out with the turn before it (a gap in time is allowed; a position
    // missing is not).
    let gone = skip.map(|i| (spans[i].0 - 2.0, spans[i].1));
    let mut s = String::from("time_s,reading\n");
    for (k, th) in theta.iter().enumerate() {
        #[allow(clippy::cast_precision_loss)]
        let t = k as f64 / 100.0;
        let u = g * scale * (k0_g + th.cos()) + noise.sample(&mut rng);
        if gone.is_some_and(|(a, b)| t >= a && t <= b) {
            continue;
        }
        let _ = writeln!(s, "{t},{}", (u / per_lsb).round());
    }
    std::fs::write(dir.join(name), s).unwrap();
    (rows, spans)
}

/// A MEMS part tumbled through 12 positions, logged at 100 Hz in LSB: the plan filled from
/// the stream, `K_0` within 4 σ of the truth; the filled plan written with each row's
/// interval.
#[test]
fn a_tumble_logged_in_lsb_fills_its_plan_and_is_calibrated() {
    let tmp = tempfile::tempdir().unwrap();
    let (rows, _) = mems_tumble(tmp.path(), "s.csv", None);
    let v = json_in(
        tmp.path(),
        &[
            "--instrument",
            "mems",
            "discover",
            "--data",
            "s.csv",
            "--plan",
            "plan.csv",
            "--positions-out",
            "filled.csv",
            "--json",
            "--no-plots",
        ],
    );
    let k0 = v["calibration"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["symbol"] == "K_0")
        .unwrap();
    let (value, sd) = (k0["value"].as_f64().unwrap(), k0["sigma"].as_f64().unwrap());
    assert!(
        (value - MEMS.0 * 1e6).abs() < 4.0 * sd,
        "K_0 {value} ± {sd} µg"
    );
    let filled = std::fs::read_to_string(tmp.path().join("filled.csv")).unwrap();
    assert!(
        filled.contains("the plan plan.csv filled from the stream s.csv"),
        "{filled}"
    );
    assert_eq!(plan_rows(&filled).len(), 12);
    assert!(filled.contains(&format!("# {}: 0–", rows[0].0)), "{filled}");
}

/// The 5th hold left out: refused at the interval that reads another row's value, with
/// its time and lines; nothing on stdout.
#[test]
fn a_position_missing_from_the_stream_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    mems_tumble(tmp.path(), "missing.csv", Some(4));
    let o = ptsa_in(
        tmp.path(),
        &[
            "--instrument",
            "mems",
            "discover",
            "--data",
            "missing.csv",
            "--plan",
            "plan.csv",
            "--no-plots",
        ],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("11 still intervals for the 12 positions of plan.csv: interval 5 (")
            && err.contains("a position missing before it"),
        "{err}"
    );
    assert!(o.stdout.is_empty());
    assert_clean_of(&err, &[]);
}

/// The loop's counter record of a tumble (10 ms gates at 64 kHz), as `ptsa record` writes
/// it: each row's pulses and ticks are the sums over its interval's gates, so each row's
/// reading is within 5 of its counting errors of the truth with the gate record's default
/// trim; without a trim a turn's gentle start enters the sums, more than 10 errors off.
#[test]
fn a_tumble_counted_in_gates_fills_its_plan_with_summed_counts() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ptsa_in(
        tmp.path(),
        &[
            "plan",
            "tumble",
            "--positions",
            "8",
            "--count-columns",
            "--output",
            "plan.csv",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rows = plan_rows(&std::fs::read_to_string(tmp.path().join("plan.csv")).unwrap());
    let sf = ptsa_host_sim::Instrument::kearfott_2401().sf_cm_s2;
    let (g, bias) = (980.4, 25.0);
    let ticks = 640.0;
    let (theta, _) = angles(&rows, 100.0, &|_| 10.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    let mut carry: f64 = rand_distr::Uniform::new(0.0, 1.0).unwrap().sample(&mut rng);
    let mut s = String::from("# a tumble counted by the loop\ntime_s,pulses,ticks\n");
    for (k, th) in theta.iter().enumerate() {
        let u = bias + g * th.cos();
        let charge = ticks * (1.0 + u / sf) / 2.0 + carry;
        let p = charge.floor();
        carry = charge - p;
        #[allow(clippy::cast_precision_loss)]
        let t = k as f64 * 0.01;
        let _ = writeln!(s, "{t},{p},{ticks}");
    }
    std::fs::write(tmp.path().join("g.csv"), s).unwrap();
    // Each row's reading against the truth, in counting σ (its counting error over the
    // summed gate), with the default trim and with none.
    let off = |trim: &[&str]| -> Vec<f64> {
        let mut args = vec![
            "discover",
            "--data",
            "g.csv",
            "--plan",
            "plan.csv",
            "--positions-out",
            "filled.csv",
            "--analytic",
            "--no-plots",
            "--force",
        ];
        args.extend_from_slice(trim);
        let o = ptsa_in(tmp.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stdout(&o).contains("stream g.csv: "), "{}", stdout(&o));
        let filled = std::fs::read_to_string(tmp.path().join("filled.csv")).unwrap();
        let (head, filled_rows) = table(&filled);
        let at = |c: &str| head.iter().position(|h| h == c).unwrap();
        assert_eq!(filled_rows.len(), 8);
        filled_rows
            .iter()
            .zip(&rows)
            .map(|(row, (_, gia, _))| {
                let num = |c: &str| row[at(c)].parse::<f64>().unwrap();
                let (p, t) = (num("pulses"), num("ticks"));
                assert!(t >= 640.0 * 700.0 && (t / 640.0).fract() == 0.0, "{row:?}");
                let u = sf * (2.0 * p / t - 1.0);
                let counting = 2.0 * sf / t * (1.0f64 / 6.0).sqrt();
                (u - (bias + g * gia)) / counting
            })
            .collect()
    };
    let trimmed = off(&[]);
    assert!(trimmed.iter().all(|z| z.abs() < 5.0), "{trimmed:?}");
    let untrimmed = off(&["--static-trim-s", "0"]);
    eprintln!("rows off the truth, counting σ: trimmed {trimmed:.1?}; untrimmed {untrimmed:.1?}");
    assert!(untrimmed.iter().any(|z| z.abs() > 10.0), "{untrimmed:?}");
}

/// A stream without its plan, a plan without a stream: refused with what to give.
#[test]
fn a_stream_needs_its_plan() {
    let tmp = tempfile::tempdir().unwrap();
    let mut s = String::from("time_s,measured_cm_s2\n");
    for k in 0..3000 {
        let _ = writeln!(s, "{},{}", f64::from(k) * 0.01, 980.0 + f64::from(k % 3));
    }
    std::fs::write(tmp.path().join("s.csv"), &s).unwrap();
    std::fs::write(
        tmp.path().join("c.csv"),
        "label,kind,g_ia,measured_cm_s2\nup,absolute,1,980\n",
    )
    .unwrap();
    for (args, needle) in [
        (&["--data", "s.csv"][..], "expected --plan FILE"),
        (
            &["--data", "c.csv", "--plan", "c.csv"][..],
            "--plan c.csv applies to one axis's raw stream",
        ),
    ] {
        let mut a = vec!["discover", "--no-plots"];
        a.extend_from_slice(args);
        let o = ptsa_in(tmp.path(), &a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
