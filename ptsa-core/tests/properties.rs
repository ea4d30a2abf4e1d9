//! Properties of the PTSA loop that must hold for every input, checked with proptest.

use proptest::prelude::*;
use ptsa_core::{Coef, Config, Lanes, Level, Polarity, Pole, Ptsa, RAMP_AMPLITUDE, State, Tick};

/// A loop whose compensator is a pure gain: `u = gain·x` exactly (no lead, no integrator).
fn open_loop(n: u16, gain: i32, shaping: bool) -> Ptsa {
    Config {
        ticks_per_cycle: n,
        b0: Coef::from_num(gain),
        b1: Coef::ZERO,
        a1: Pole::ZERO,
        ki: Coef::ZERO,
        gate_ticks: 1 << 20,
        noise_shaping: shaping,
    }
    .build()
    .expect("valid open-loop configuration")
}

/// Positive-tick counts of `cycles` whole cycles for a constant sample `x`.
fn cycle_counts(p: &Ptsa, x: i16, cycles: usize) -> Vec<u16> {
    let mut s = p.initial_state();
    let n = usize::from(p.config().ticks_per_cycle);
    (0..n * cycles)
        .filter_map(|_| p.tick(&mut s, x).cycle_pulses)
        .collect()
}

/// Full-torque rate of the toy pendulum, 2^-16 LSB per tick (63.5 LSB).
const STEP: i32 = 4_161_536;

/// The pickoff sample of the toy pendulum's angle `theta` (2^-16 LSB), saturated to `i16`.
fn pickoff(theta: i64) -> i16 {
    i16::try_from(theta >> 16).unwrap_or(if theta < 0 { i16::MIN } else { i16::MAX })
}

fn ticks_per_cycle() -> impl Strategy<Value = u16> {
    (1u32..=12).prop_map(|k| 1u16 << k)
}

/// Any configuration that `Config::build` accepts (rejections are filtered out).
fn valid_config() -> impl Strategy<Value = Config> {
    (
        ticks_per_cycle(),
        any::<i32>(),
        any::<i32>(),
        -(1i32 << 16) - 8..(1 << 16) + 8,
        0..i32::MAX,
        1u32..5000,
        any::<bool>(),
        0u32..28,
    )
        .prop_map(|(n, b0, b1, a1, ki, gate, shaping, shift)| Config {
            ticks_per_cycle: n,
            // Shift the gains down by a random amount so that small, realistic gains are
            // as likely as huge ones.
            b0: Coef::from_bits(b0 >> shift),
            b1: Coef::from_bits(b1 >> shift),
            a1: Pole::from_bits(a1),
            ki: Coef::from_bits(ki >> shift),
            gate_ticks: gate,
            noise_shaping: shaping,
        })
        .prop_filter("configuration accepted by build()", |c| c.build().is_ok())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Open loop, constant level: every cycle's count is exactly the documented
    /// quantization formula, and the count is monotone in the input.
    #[test]
    fn duty_is_the_documented_formula_and_monotone(
        n in ticks_per_cycle(), x in any::<i16>(), dx in 1i16..2000
    ) {
        let gain = RAMP_AMPLITUDE / 32_768; // the i16 range spans exactly ±full scale
        let p = open_loop(n, gain, false);
        let u = Level::from_bits(gain * i32::from(x));
        let want = p.config().positive_ticks_for(u);
        for got in cycle_counts(&p, x, 3) {
            prop_assert_eq!(got, want);
        }
        let y = x.saturating_add(dx);
        let higher = cycle_counts(&p, y, 1)[0];
        prop_assert!(higher >= want, "n({y}) = {higher} < n({x}) = {want}");
    }

    /// With noise shaping, the mean count over M cycles of a constant level in range is
    /// within 1/(N·M) of the ideal linear duty (1 + u/R)/2.
    #[test]
    fn noise_shaped_mean_duty_is_exact_to_one_tick(
        n in ticks_per_cycle(), permille in -999i32..999, m in 1u16..200
    ) {
        let p = open_loop(n, 1 << 10, true);
        let h = RAMP_AMPLITUDE / i32::from(n);
        // A sample whose level u = 1024·x stays inside [−R + h, R − h].
        let x = i16::try_from(permille * ((RAMP_AMPLITUDE - h) / 1024) / 1000)
            .expect("|x| < 2^14");
        let u = 1024.0 * f64::from(x);
        let counts = cycle_counts(&p, x, usize::from(m));
        let mean =
            counts.iter().map(|&c| f64::from(c)).sum::<f64>() / (f64::from(m) * f64::from(n));
        let ideal = f64::midpoint(1.0, u / f64::from(RAMP_AMPLITUDE));
        prop_assert!(
            (mean - ideal).abs() <= 1.0 / (f64::from(n) * f64::from(m)),
            "mean {mean} ideal {ideal} (N={n}, M={m})"
        );
    }

    /// Closed loop with a toy integrating pendulum: the gated pulse count balances a
    /// constant input across ±95% of full scale.
    ///
    /// The toy plant conserves charge exactly, so a gate's count differs from the ideal
    /// `T·(1 + a)/2` by exactly the charge the pendulum stored over the gate, `−Δθ/(2·step)`.
    /// The loop keeps θ at cycle boundaries in a band of under 4 steps (measured: 3.7 at
    /// worst over a fine grid of inputs), so each gate is within 2 pulses of ideal, and the
    /// error does not accumulate: the total over all gates is within 2 pulses as well.
    #[test]
    fn charge_balance_with_an_integrating_plant(
        accel in -STEP / 20 * 19..STEP / 20 * 19
    ) {
        let gate = 6400u32; // 100 limit cycles
        let p = Config { gate_ticks: gate, ..Config::DEFAULT }.build().unwrap();
        let mut s = p.initial_state();
        let a = f64::from(accel) / f64::from(STEP); // ±0.95 of full torque
        let (step, accel) = (i64::from(STEP), i64::from(accel));
        let mut theta = 0i64;
        let mut pol = Polarity::Positive;
        let mut gates = Vec::new();
        let mut theta_at_gate = Vec::new();
        for _ in 0..gate * 8 {
            theta += accel - i64::from(pol.sign()) * step;
            let x = pickoff(theta);
            let t = p.tick(&mut s, x);
            pol = t.polarity;
            if let Some(g) = t.gate {
                gates.push(g);
                theta_at_gate.push(theta);
            }
        }
        let duty = f64::midpoint(1.0, a);
        // Skip the first two gates (settling from rest).
        let (mut total, mut ideal_total) = (0.0, 0.0);
        for (i, g) in gates.iter().enumerate().skip(2) {
            let ideal = f64::from(g.ticks) * duty;
            prop_assert!(
                (f64::from(g.pulses) - ideal).abs() < 2.0,
                "input {a}: {} pulses, ideal {ideal}", g.pulses
            );
            // The exact charge identity of the toy plant (checks the counts are honest).
            let moved = i32::try_from(theta_at_gate[i] - theta_at_gate[i - 1])
                .expect("θ moves by less than 2^31 over a gate");
            let stored = f64::from(moved) / (2.0 * f64::from(STEP));
            prop_assert!((f64::from(g.pulses) - ideal + stored).abs() < 1e-6);
            total += f64::from(g.pulses);
            ideal_total += ideal;
        }
        prop_assert!((total - ideal_total).abs() < 2.0, "drift {}", total - ideal_total);
    }

    /// Any valid configuration, any input stream: no panic (overflow checks and debug
    /// assertions are on in tests, so the lead section's proven bound is asserted every tick), the same input gives the same output,
    /// and reset returns the initial state.
    #[test]
    fn no_panic_no_overflow_deterministic(
        c in valid_config(), xs in proptest::collection::vec(any::<i16>(), 0..3000)
    ) {
        let p = c.build().unwrap();
        let run = || {
            let mut s = p.initial_state();
            let out: Vec<Tick> = xs.iter().map(|&x| p.tick(&mut s, x)).collect();
            (out, s)
        };
        let (a, mut s) = run();
        let (b, s2) = run();
        prop_assert_eq!(&a, &b);
        prop_assert_eq!(s, s2);
        s.reset();
        prop_assert_eq!(s, p.initial_state());
        prop_assert_eq!(s.digest(), State::INITIAL.digest());
    }

    /// The block form is the tick sample by sample, for any split into blocks.
    #[test]
    fn tick_and_block_forms_agree(
        c in valid_config(),
        xs in proptest::collection::vec(any::<i16>(), 0..3000),
        splits in proptest::collection::vec(0usize..3000, 0..6),
    ) {
        let p = c.build().unwrap();
        let mut s1 = p.initial_state();
        let per_tick: Vec<Tick> = xs.iter().map(|&x| p.tick(&mut s1, x)).collect();
        let mut s2 = p.initial_state();
        let mut block = vec![per_tick.first().copied().unwrap_or(Tick {
            polarity: Polarity::Negative, cycle_pulses: None, gate: None
        }); xs.len()];
        let mut cuts: Vec<usize> = splits.into_iter().map(|k| k.min(xs.len())).collect();
        cuts.push(0);
        cuts.push(xs.len());
        cuts.sort_unstable();
        for w in cuts.windows(2) {
            p.process_block(&mut s2, &xs[w[0]..w[1]], &mut block[w[0]..w[1]]);
        }
        prop_assert_eq!(per_tick, block);
        prop_assert_eq!(s1.digest(), s2.digest());
        prop_assert_eq!(s1, s2);
    }
}

/// `L` loops through [`Ptsa::tick_lanes`] against each through [`Ptsa::tick`]: every lane's
/// tick and state, bit for bit. Each lane first runs alone for its own number of ticks, so
/// the lanes are out of step (their cycles, gates, switches and clamps fall on different
/// ticks) and the rare paths run for some lanes and not others.
fn lanes_agree<const L: usize>(
    p: &Ptsa,
    lead_in: &[usize],
    xs: &[i16],
) -> Result<(), TestCaseError> {
    let mut single = [p.initial_state(); L];
    for (l, s) in single.iter_mut().enumerate() {
        for i in 0..lead_in[l % lead_in.len()] {
            p.tick(s, xs[(i * 7 + l) % xs.len()]);
        }
    }
    let mut lanes = Lanes::new(&single);
    for (i, chunk) in xs.chunks_exact(L).enumerate() {
        let x: [i16; L] = chunk.try_into().unwrap();
        let t = p.tick_lanes(&mut lanes, &x);
        for (l, s) in single.iter_mut().enumerate() {
            prop_assert_eq!(t.get(l), p.tick(s, x[l]), "tick {} lane {}", i, l);
        }
    }
    for (l, s) in single.iter().enumerate() {
        prop_assert_eq!(lanes.get(l), *s, "lane {}", l);
    }
    Ok(())
}

proptest! {
    /// The lane form is the tick, lane by lane, for 4 and 8 lanes out of step, any
    /// configuration (short gates included, so that gates close often) and any input.
    #[test]
    fn lanes_are_the_tick_lane_by_lane(
        c in valid_config(),
        gate_ticks in prop_oneof![Just(None), (1u32..300).prop_map(Some)],
        lead_in in proptest::collection::vec(0usize..300, 1..8),
        xs in proptest::collection::vec(any::<i16>(), 8..2000),
    ) {
        let c = Config { gate_ticks: gate_ticks.unwrap_or(c.gate_ticks), ..c };
        let Ok(p) = c.build() else { return Ok(()) };
        lanes_agree::<4>(&p, &lead_in, &xs)?;
        lanes_agree::<8>(&p, &lead_in, &xs)?;
    }
}

/// The block form refuses slices of different lengths (debug assertions are on in tests).
#[test]
#[cfg(debug_assertions)]
#[should_panic(expected = "slices differ in length")]
fn block_form_refuses_unequal_slices() {
    let p = Config::DEFAULT.build().unwrap();
    let mut s = p.initial_state();
    let tick = Tick {
        polarity: Polarity::Positive,
        cycle_pulses: None,
        gate: None,
    };
    p.process_block(&mut s, &[0; 3], &mut [tick; 4]);
}

/// `From<bool>` and `!` agree with the polarity's sign.
#[test]
fn polarity_from_bool_and_not() {
    for positive in [false, true] {
        let p = Polarity::from(positive);
        assert_eq!(p == Polarity::Positive, positive);
        assert_eq!(!p, Polarity::from(!positive));
        assert_eq!((!p).sign(), -p.sign());
        assert_eq!(!!p, p);
    }
}

/// The counts span 0..=N across the input range, and the endpoints are where
/// ARITHMETIC.md says.
#[test]
fn duty_spans_zero_to_n() {
    for n in [2u16, 8, 64, 4096] {
        let gain = RAMP_AMPLITUDE / 32_768;
        let p = open_loop(n, gain, false);
        assert_eq!(cycle_counts(&p, i16::MIN, 2), [0, 0]);
        assert_eq!(cycle_counts(&p, i16::MAX, 2), [n, n]);
        assert_eq!(cycle_counts(&p, 0, 2), [n / 2, n / 2]);
    }
}

/// Exactly two current reversals per cycle whenever 0 < n < N.
#[test]
fn two_reversals_per_cycle_in_range() {
    let p = open_loop(64, RAMP_AMPLITUDE / 32_768, false);
    for x in (-32_000i16..32_000).step_by(997) {
        let mut s = p.initial_state();
        let pols: Vec<Polarity> = (0..64 * 4).map(|_| p.tick(&mut s, x).polarity).collect();
        let reversals = pols.windows(2).filter(|w| w[0] != w[1]).count();
        let n = p
            .config()
            .positive_ticks_for(Level::from_bits(512 * i32::from(x)));
        if n > 0 && n < 64 {
            // 4 cycles: 2 inside each, 3 at the boundaries between them.
            assert_eq!(reversals, 4 + 3, "x = {x}, n = {n}");
        }
    }
}

/// Configurations that must be refused, each with its own error.
#[test]
fn bad_configurations_are_refused_not_panicked() {
    use ptsa_core::ConfigError as E;
    let d = Config::DEFAULT;
    let cases = [
        (
            Config {
                ticks_per_cycle: 48,
                ..d
            },
            "TicksPerCycle",
        ),
        (
            Config {
                ticks_per_cycle: 8192,
                ..d
            },
            "TicksPerCycle",
        ),
        (
            Config {
                ticks_per_cycle: 1,
                ..d
            },
            "TicksPerCycle",
        ),
        (
            Config {
                a1: Pole::from_bits(1 << 16),
                ..d
            },
            "UnstableLead",
        ),
        (
            Config {
                a1: Pole::from_bits(i32::MIN),
                ..d
            },
            "UnstableLead",
        ),
        (
            Config {
                ki: Coef::from_bits(-1),
                ..d
            },
            "WrongSign",
        ),
        (
            Config {
                b0: Coef::from_num(-1),
                b1: Coef::ZERO,
                ..d
            },
            "WrongSign",
        ),
        (
            Config {
                b0: Coef::MAX,
                b1: Coef::ZERO,
                a1: Pole::from_num(0.5),
                ..d
            },
            "LeadOverflow",
        ),
        // Exactly at the limit: (2^15 − 2^-16)·2^15 + ½ rounds up to 2^30: still accepted.
        (
            Config {
                b0: Coef::from_num(16_384),
                b1: Coef::ZERO,
                a1: Pole::ZERO,
                ki: Coef::ZERO,
                ..d
            },
            "accepted",
        ),
        (Config { gate_ticks: 0, ..d }, "EmptyGate"),
    ];
    for (c, want) in cases {
        if want == "accepted" {
            assert!(c.build().is_ok(), "{c:?}");
            continue;
        }
        let e = c.build().expect_err(want);
        let got = match e {
            E::TicksPerCycle(_) => "TicksPerCycle",
            E::UnstableLead => "UnstableLead",
            E::WrongSign => "WrongSign",
            E::LeadOverflow { .. } => "LeadOverflow",
            E::EmptyGate => "EmptyGate",
            // `ConfigError` is non-exhaustive.
            _ => "another error",
        };
        assert_eq!(got, want, "{c:?}");
        assert!(!e.to_string().is_empty());
    }
    assert!(Config::DEFAULT.build().is_ok());
}

/// `Config::lead_bound` is the l1 norm of the lead section's impulse response times the
/// largest input (plus rounding), computed here independently by summing the response.
#[test]
fn lead_bound_is_the_impulse_response_l1_norm() {
    for c in [
        Config::DEFAULT,
        Config {
            a1: Pole::from_num(-0.75),
            b1: Coef::from_num(-3000),
            ..Config::DEFAULT
        },
        Config {
            a1: Pole::from_num(0.999),
            ..Config::DEFAULT
        },
    ] {
        let (b0, b1, a) = (
            c.b0.to_num::<f64>(),
            c.b1.to_num::<f64>(),
            c.a1.to_num::<f64>(),
        );
        let mut l1 = b0.abs();
        let mut h = b0 * a + b1;
        for _ in 0..200_000 {
            l1 += h.abs();
            h *= a;
        }
        let estimate = 32_768.0 * l1 + 0.5 / (1.0 - a.abs());
        let bound = c.lead_bound().unwrap();
        let bound = f64::from(u32::try_from(bound).expect("these bounds are below 2^32"));
        assert!(bound >= estimate - 1e-6 * estimate, "{bound} < {estimate}");
        assert!(
            (bound - estimate).abs() / estimate < 1e-6,
            "{bound} vs {estimate}"
        );
    }
}

/// Anti-windup: after a long over-range input (1.5 × full scale) the closed loop (toy
/// pendulum with stops at ±2 mrad) returns to balance within 50 limit cycles (measured: 21 to
/// 39), and the integrator has been held at its clamp.
#[test]
fn recovers_after_over_range() {
    let p = Config::DEFAULT.build().unwrap();
    let step = i64::from(STEP);
    // Accelerations in tenths of full torque.
    for (over, after) in [(15, 3), (-15, 3), (15, -9), (-15, 9)] {
        let mut s = p.initial_state();
        let mut theta = 0i64;
        let mut pol = Polarity::Positive;
        let mut last_bad_cycle = 0;
        let mut cycle = 0;
        for t in 0..64 * 400 {
            let a = if t < 64 * 200 { over } else { after };
            theta += step * a / 10 - i64::from(pol.sign()) * step;
            // Mechanical stops at ±2 mrad = ±26 214 LSB.
            theta = theta.clamp(-26_214 << 16, 26_214 << 16);
            let x = pickoff(theta);
            let tk = p.tick(&mut s, x);
            pol = tk.polarity;
            if tk.cycle_pulses.is_some() {
                cycle += 1;
                // Balanced: the pickoff back inside the normal ripple band (< 1500 LSB).
                if cycle > 200 && i32::from(x).abs() > 1500 {
                    last_bad_cycle = cycle - 200;
                }
            }
        }
        assert!(
            s.saturations().integrator > 0,
            "over-range must hit the clamp"
        );
        assert!(
            last_bad_cycle <= 50,
            "{over}/10 -> {after}/10 of full torque: pickoff still out of band \
             {last_bad_cycle} cycles after"
        );
        println!(
            "{over}/10 -> {after}/10 of full torque: back in band within {last_bad_cycle} \
             limit cycles"
        );
    }
}

proptest! {
    /// The gate FIFO never loses a count: for any interleaving of pushes (from the tick
    /// interrupt) and pops (from the reporting loop), what was pushed equals what was
    /// popped plus what is still queued, gate for gate and pulse for pulse, in order.
    #[test]
    fn gate_fifo_loses_no_count(ops in proptest::collection::vec((any::<bool>(), 0u32..1000), 0..400)) {
        use ptsa_core::{Gate, GateFifo};
        let mut q: GateFifo<4> = GateFifo::new();
        let (mut pushed_p, mut pushed_t, mut pushed_g) = (0u64, 0u64, 0u64);
        let (mut popped_p, mut popped_t, mut popped_g) = (0u64, 0u64, 0u64);
        for (push, p) in ops {
            if push {
                q.push(Gate { pulses: p, ticks: 1000 });
                pushed_p += u64::from(p);
                pushed_t += 1000;
                pushed_g += 1;
            } else if let Some(c) = q.pop() {
                prop_assert_eq!(c.ticks, 1000 * u64::from(c.gates));
                // The entry follows the last one popped: its gates are numbered on from
                // the last one's, its ticks end where the last one's did plus its own.
                prop_assert_eq!(c.seq, popped_g + u64::from(c.gates));
                prop_assert_eq!(c.end_tick, popped_t + c.ticks);
                popped_p += c.pulses;
                popped_t += c.ticks;
                popped_g += u64::from(c.gates);
            }
            prop_assert!(q.len() <= 4);
        }
        while let Some(c) = q.pop() {
            popped_p += c.pulses;
            popped_t += c.ticks;
            popped_g += u64::from(c.gates);
        }
        prop_assert_eq!((pushed_p, pushed_t, pushed_g), (popped_p, popped_t, popped_g));
    }
}
