//! The host's lane operations against the plain ones: every operation on drawn values, and
//! the core's tick on eight lanes against each lane through `Ptsa::tick`, for each
//! implementation this CPU can run (`avx512`, `avx2`; one that it cannot is skipped with a
//! note, and the batch engine does not use it there either).

use proptest::prelude::*;
use ptsa_core::{Config, Each, LaneOps, Lanes, Regs, State};

use super::avx2::Avx2;
use super::avx512::Avx512;

/// `o`, or `None` with a note when this CPU cannot run it: on stderr and, when the
/// environment variable `PTSA_SKIPPED` names a file (`cargo xtask ci` sets it), a line
/// there too, which the run's summary lists as not run.
fn or_skip<O>(o: Option<O>, what: &str) -> Option<O> {
    if o.is_none() {
        let line = format!("the {what} lane tests: this CPU has no {what}");
        eprintln!("skipped: {line}");
        if let Some(path) = std::env::var_os("PTSA_SKIPPED") {
            use std::io::Write as _;
            let file = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(path);
            if let Ok(mut f) = file {
                let _ = writeln!(f, "{line}");
            }
        }
    }
    o
}

/// Drawn lanes for [`operations`].
#[derive(Clone, Debug)]
struct Values {
    a: [i32; 8],
    b: [i32; 8],
    w: [i64; 8],
    v: [i64; 8],
    m: [bool; 8],
    n: [bool; 8],
    c: i32,
}

fn values() -> impl Strategy<Value = Values> {
    (
        any::<[i32; 8]>(),
        any::<[i32; 8]>(),
        any::<[i64; 8]>(),
        any::<[i64; 8]>(),
        any::<[bool; 8]>(),
        any::<[bool; 8]>(),
        any::<i32>(),
    )
        .prop_map(|(a, b, w, v, m, n, c)| Values {
            a,
            b,
            w,
            v,
            m,
            n,
            c,
        })
}

/// Every operation of `o` on `x` against [`Each`]'s.
#[allow(clippy::needless_pass_by_value, reason = "a drawn case")]
fn operations<O: LaneOps<8>>(o: O, x: Values) -> Result<(), TestCaseError> {
    let e = Each::<8>;
    let Values {
        a,
        b,
        w,
        v,
        m,
        n,
        c,
    } = x;
    let (va, vb, vw, vv) = (o.load(a), o.load(b), o.load64(w), o.load64(v));
    let (vm, vn) = (o.load_mask(m), o.load_mask(n));
    prop_assert_eq!(o.store(va), a);
    prop_assert_eq!(o.store64(vw), w);
    prop_assert_eq!(o.store_mask(vm), m);
    prop_assert_eq!(o.mask64(vm), e.mask64(m));
    prop_assert_eq!(o.store(o.splat(c)), e.splat(c));
    prop_assert_eq!(o.store64(o.splat64(w[0])), e.splat64(w[0]));
    prop_assert_eq!(o.store(o.add(va, vb)), e.add(a, b));
    prop_assert_eq!(o.store(o.sub(va, vb)), e.sub(a, b));
    prop_assert_eq!(o.store(o.mul(va, vb)), e.mul(a, b));
    prop_assert_eq!(o.store(o.and(va, vb)), e.and(a, b));
    prop_assert_eq!(o.store(o.xor(va, vb)), e.xor(a, b));
    prop_assert_eq!(o.store(o.sra::<31>(va)), e.sra::<31>(a));
    prop_assert_eq!(o.store(o.sra::<5>(va)), e.sra::<5>(a));
    prop_assert_eq!(o.store(o.max(va, vb)), e.max(a, b));
    prop_assert_eq!(o.store(o.min(va, vb)), e.min(a, b));
    prop_assert_eq!(o.store_mask(o.lt(va, vb)), e.lt(a, b));
    prop_assert_eq!(o.store_mask(o.gt(va, vb)), e.gt(a, b));
    prop_assert_eq!(o.store_mask(o.eq(va, vb)), e.eq(a, b));
    prop_assert_eq!(o.store_mask(o.eq(va, va)), e.eq(a, a));
    prop_assert_eq!(o.store(o.select(vm, va, vb)), e.select(m, a, b));
    prop_assert_eq!(o.store(o.count(va, vm)), e.count(a, m));
    prop_assert_eq!(o.store64(o.mul_wide(va, c)), e.mul_wide(a, c));
    prop_assert_eq!(o.store64(o.add64(vw, vv)), e.add64(w, v));
    prop_assert_eq!(o.store64(o.sub64(vw, vv)), e.sub64(w, v));
    prop_assert_eq!(o.store64(o.xor64(vw, vv)), e.xor64(w, v));
    prop_assert_eq!(o.store64(o.sra64::<16>(vw)), e.sra64::<16>(w));
    prop_assert_eq!(o.store64(o.sra64::<63>(vw)), e.sra64::<63>(w));
    prop_assert_eq!(o.store(o.low32(vw)), e.low32(w));
    prop_assert_eq!(o.store_mask(o.lt64(vw, vv)), e.lt64(w, v));
    prop_assert_eq!(o.store_mask(o.gt64(vw, vv)), e.gt64(w, v));
    prop_assert_eq!(o.store_mask(o.lt64(vw, vw)), e.lt64(w, w));
    prop_assert_eq!(o.store64(o.select64(vm, vw, vv)), e.select64(m, w, v));
    prop_assert_eq!(o.store_mask(o.and_mask(vm, vn)), e.and_mask(m, n));
    prop_assert_eq!(o.store_mask(o.or_mask(vm, vn)), e.or_mask(m, n));
    prop_assert_eq!(o.store_mask(o.and_not_mask(vm, vn)), e.and_not_mask(m, n));
    prop_assert_eq!(o.store_mask(o.not_mask(vm)), e.not_mask(m));
    prop_assert_eq!(o.any(vm), e.any(m));
    Ok(())
}

/// A pickoff sample: mostly near null, some anywhere (full-scale codes saturate the
/// integrator and the junction).
fn sample() -> impl Strategy<Value = i16> {
    prop_oneof![4 => -400i16..400, 1 => any::<i16>()]
}

/// A drawn run for [`tick`]: the cycle (2^`n_log2` ticks) and the gate, noise shaping, each
/// lane's own lead-in of ticks (its phase), a constant added to each lane's samples, and
/// the samples.
#[derive(Clone, Debug)]
struct Run {
    n_log2: u32,
    gate_cycles: u32,
    shaping: bool,
    lead_in: Vec<Vec<i16>>,
    push: [i16; 8],
    xs: Vec<[i16; 8]>,
}

fn run() -> impl Strategy<Value = Run> {
    (
        3u32..8,
        1u32..6,
        any::<bool>(),
        prop::collection::vec(prop::collection::vec(sample(), 0..300), 8),
        prop::array::uniform8(prop_oneof![
            Just(0i16),
            Just(i16::MAX),
            Just(i16::MIN),
            -3000i16..3000
        ]),
        prop::collection::vec(prop::array::uniform8(sample()), 1..400),
    )
        .prop_map(|(n_log2, gate_cycles, shaping, lead_in, push, xs)| Run {
            n_log2,
            gate_cycles,
            shaping,
            lead_in,
            push,
            xs,
        })
}

/// The core's tick on eight lanes of `o` against each lane through `Ptsa::tick`: every
/// decision and the whole state, tick by tick, the lanes at drawn phases of their cycles
/// and gates, with and without noise shaping, through the integrator's and the junction's
/// clamps (a lane pushed by a constant full-scale input reaches the integrator's limit in
/// about 150 ticks).
#[allow(clippy::needless_pass_by_value, reason = "a drawn case")]
fn tick<O: LaneOps<8>>(o: O, r: Run) -> Result<(), TestCaseError> {
    let n = 1u16 << r.n_log2;
    let ptsa = Config {
        ticks_per_cycle: n,
        gate_ticks: u32::from(n) * r.gate_cycles,
        noise_shaping: r.shaping,
        ..Config::DEFAULT
    }
    .build()
    .expect("a valid configuration");
    let mut single: [State; 8] = [ptsa.initial_state(); 8];
    for (s, lead) in single.iter_mut().zip(&r.lead_in) {
        for &x in lead {
            ptsa.tick(s, x);
        }
    }
    let mut regs = Regs::load(o, &Lanes::new(&single));
    for x in &r.xs {
        let x: [i16; 8] = std::array::from_fn(|l| x[l].saturating_add(r.push[l]));
        let t = ptsa
            .tick_regs(o, &mut regs, o.load(x.map(i32::from)))
            .lanes(o);
        for l in 0..8 {
            let want = ptsa.tick(&mut single[l], x[l]);
            prop_assert_eq!(t.get(l), want, "lane {}", l);
        }
        let got = regs.store(o);
        for (l, s) in single.iter().enumerate() {
            prop_assert_eq!(got.get(l), *s, "lane {}", l);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn avx512_operations_are_the_plain_lanes(x in values()) {
        if let Some(o) = or_skip(Avx512::new(), "AVX-512 (F, BW, CD, DQ, VL)") {
            operations(o, x)?;
        }
    }

    #[test]
    fn avx2_operations_are_the_plain_lanes(x in values()) {
        if let Some(o) = or_skip(Avx2::new(), "AVX2") {
            operations(o, x)?;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn the_tick_in_avx512_registers_is_the_single_tick(r in run()) {
        if let Some(o) = or_skip(Avx512::new(), "AVX-512 (F, BW, CD, DQ, VL)") {
            tick(o, r)?;
        }
    }

    #[test]
    fn the_tick_in_avx2_registers_is_the_single_tick(r in run()) {
        if let Some(o) = or_skip(Avx2::new(), "AVX2") {
            tick(o, r)?;
        }
    }
}
