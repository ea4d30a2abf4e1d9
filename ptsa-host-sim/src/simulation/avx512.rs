//! Eight lanes of the core's tick in AVX-512 registers: [`Avx512`], a
//! [`ptsa_core::LaneOps`] whose 32-bit lanes are one `ymm` register, whose 64-bit lanes are
//! one `zmm` register and whose flags are one mask register (`k`), so that the tick's range
//! tests, selects and "any lane" tests are one instruction each. The tick itself is
//! `ptsa_core`'s one definition (`Ptsa::tick_regs`); each operation here does in every lane
//! what [`ptsa_core::Each`]'s does in its array element (the tests below hold the two equal
//! on drawn values, and the batch tests hold the whole loop equal to the single loop).
//!
//! The intrinsics come from `pulp`'s safe wrappers, callable only with a [`V4`] token, which
//! exists only on a CPU that has AVX-512 F, BW, CD, DQ and VL ([`Avx512::new`]); the code
//! is compiled with those instructions inside [`V4::vectorize`].

#![allow(
    clippy::inline_always,
    reason = "the tick path: every operation inlined into the kernel compiled for AVX-512"
)]

use core::arch::x86_64::{__m256i, __m512i};

use ptsa_core::LaneOps;
use pulp::x86::V4;

/// Eight lanes in AVX-512 registers (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(super) struct Avx512(pub(super) V4);

impl Avx512 {
    /// The lanes, on a CPU that has AVX-512 (F, BW, CD, DQ, VL); `None` elsewhere.
    pub(super) fn new() -> Option<Self> {
        V4::try_new().map(Self)
    }
}

impl LaneOps<8> for Avx512 {
    type I32 = __m256i;
    type I64 = __m512i;
    type Mask = u8;

    #[inline(always)]
    fn load(self, a: [i32; 8]) -> __m256i {
        pulp::cast(a)
    }
    #[inline(always)]
    fn store(self, v: __m256i) -> [i32; 8] {
        pulp::cast(v)
    }
    #[inline(always)]
    fn load64(self, a: [i64; 8]) -> __m512i {
        pulp::cast(a)
    }
    #[inline(always)]
    fn store64(self, v: __m512i) -> [i64; 8] {
        pulp::cast(v)
    }
    #[inline(always)]
    fn load_mask(self, a: [bool; 8]) -> u8 {
        a.iter()
            .enumerate()
            .fold(0, |m, (l, &b)| m | (u8::from(b) << l))
    }
    #[inline(always)]
    fn store_mask(self, m: u8) -> [bool; 8] {
        std::array::from_fn(|l| (m >> l) & 1 != 0)
    }
    #[inline(always)]
    fn mask64(self, m: u8) -> [u64; 8] {
        pulp::cast(self.0.avx512dq._mm512_movm_epi64(m))
    }

    #[inline(always)]
    fn splat(self, a: i32) -> __m256i {
        self.0.avx._mm256_set1_epi32(a)
    }
    #[inline(always)]
    fn splat64(self, a: i64) -> __m512i {
        self.0.avx512f._mm512_set1_epi64(a)
    }
    #[inline(always)]
    fn add(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_add_epi32(a, b)
    }
    #[inline(always)]
    fn sub(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_sub_epi32(a, b)
    }
    #[inline(always)]
    fn mul(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_mullo_epi32(a, b)
    }
    #[inline(always)]
    fn and(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_and_si256(a, b)
    }
    #[inline(always)]
    fn xor(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_xor_si256(a, b)
    }
    #[inline(always)]
    fn sra<const N: i32>(self, a: __m256i) -> __m256i {
        self.0.avx2._mm256_srai_epi32::<N>(a)
    }
    #[inline(always)]
    fn max(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_max_epi32(a, b)
    }
    #[inline(always)]
    fn min(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_min_epi32(a, b)
    }
    #[inline(always)]
    fn lt(self, a: __m256i, b: __m256i) -> u8 {
        self.0.avx512f._mm256_cmplt_epi32_mask(a, b)
    }
    #[inline(always)]
    fn gt(self, a: __m256i, b: __m256i) -> u8 {
        self.0.avx512f._mm256_cmpgt_epi32_mask(a, b)
    }
    #[inline(always)]
    fn eq(self, a: __m256i, b: __m256i) -> u8 {
        self.0.avx512f._mm256_cmpeq_epi32_mask(a, b)
    }
    #[inline(always)]
    fn select(self, m: u8, a: __m256i, b: __m256i) -> __m256i {
        // The blend takes its second operand where the mask is set.
        self.0.avx512f._mm256_mask_blend_epi32(m, b, a)
    }
    #[inline(always)]
    fn count(self, c: __m256i, m: u8) -> __m256i {
        self.0.avx512f._mm256_mask_add_epi32(c, m, c, self.splat(1))
    }

    #[inline(always)]
    fn mul_wide(self, a: __m256i, b: i32) -> __m512i {
        // The signed product of the low 32 bits of each 64-bit lane: exact.
        let a = self.0.avx512f._mm512_cvtepi32_epi64(a);
        self.0
            .avx512f
            ._mm512_mul_epi32(a, self.splat64(i64::from(b)))
    }
    #[inline(always)]
    fn add64(self, a: __m512i, b: __m512i) -> __m512i {
        self.0.avx512f._mm512_add_epi64(a, b)
    }
    #[inline(always)]
    fn sub64(self, a: __m512i, b: __m512i) -> __m512i {
        self.0.avx512f._mm512_sub_epi64(a, b)
    }
    #[inline(always)]
    fn xor64(self, a: __m512i, b: __m512i) -> __m512i {
        self.0.avx512f._mm512_xor_si512(a, b)
    }
    #[inline(always)]
    fn sra64<const N: u32>(self, a: __m512i) -> __m512i {
        self.0.avx512f._mm512_srai_epi64::<N>(a)
    }
    #[inline(always)]
    fn low32(self, a: __m512i) -> __m256i {
        self.0.avx512f._mm512_cvtepi64_epi32(a)
    }
    #[inline(always)]
    fn lt64(self, a: __m512i, b: __m512i) -> u8 {
        self.0.avx512f._mm512_cmplt_epi64_mask(a, b)
    }
    #[inline(always)]
    fn gt64(self, a: __m512i, b: __m512i) -> u8 {
        self.0.avx512f._mm512_cmpgt_epi64_mask(a, b)
    }
    #[inline(always)]
    fn select64(self, m: u8, a: __m512i, b: __m512i) -> __m512i {
        self.0.avx512f._mm512_mask_blend_epi64(m, b, a)
    }

    #[inline(always)]
    fn and_mask(self, a: u8, b: u8) -> u8 {
        a & b
    }
    #[inline(always)]
    fn or_mask(self, a: u8, b: u8) -> u8 {
        a | b
    }
    #[inline(always)]
    fn and_not_mask(self, a: u8, b: u8) -> u8 {
        a & !b
    }
    #[inline(always)]
    fn not_mask(self, a: u8) -> u8 {
        !a
    }
    #[inline(always)]
    fn any(self, m: u8) -> bool {
        m != 0
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;
    use ptsa_core::{Config, Each, LaneOps, Lanes, Regs, State};

    use super::Avx512;

    /// The lanes, or `None` with a note on a CPU without AVX-512 (the batch engine then
    /// runs the plain lanes, which the batch tests check).
    fn avx512() -> Option<Avx512> {
        let o = Avx512::new();
        if o.is_none() {
            eprintln!("skipped: this CPU has no AVX-512 (F, BW, CD, DQ, VL)");
        }
        o
    }

    /// A pickoff sample: mostly near null, some anywhere (full-scale codes saturate the
    /// integrator and the junction).
    fn sample() -> impl Strategy<Value = i16> {
        prop_oneof![4 => -400i16..400, 1 => any::<i16>()]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

        /// Every operation, on drawn values, gives in each lane what the plain lanes give.
        #[test]
        fn every_operation_is_the_plain_lanes(
            a in any::<[i32; 8]>(),
            b in any::<[i32; 8]>(),
            w in any::<[i64; 8]>(),
            v in any::<[i64; 8]>(),
            m in any::<[bool; 8]>(),
            n in any::<[bool; 8]>(),
            c in any::<i32>(),
        ) {
            let Some(o) = avx512() else { return Ok(()) };
            let e = Each::<8>;
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
            prop_assert_eq!(o.store64(o.select64(vm, vw, vv)), e.select64(m, w, v));
            prop_assert_eq!(o.store_mask(o.and_mask(vm, vn)), e.and_mask(m, n));
            prop_assert_eq!(o.store_mask(o.or_mask(vm, vn)), e.or_mask(m, n));
            prop_assert_eq!(o.store_mask(o.and_not_mask(vm, vn)), e.and_not_mask(m, n));
            prop_assert_eq!(o.store_mask(o.not_mask(vm)), e.not_mask(m));
            prop_assert_eq!(o.any(vm), e.any(m));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// The core's tick on eight lanes in AVX-512 registers against each lane through
        /// `Ptsa::tick`: every decision and the whole state, tick by tick, with the lanes
        /// at drawn phases of their cycles and gates, with and without noise shaping,
        /// through the integrator's and the junction's clamps (a lane pushed by a constant
        /// full-scale input reaches the integrator's limit in about 150 ticks).
        #[test]
        fn the_tick_in_registers_is_the_single_tick(
            n_log2 in 3u32..8,
            gate_cycles in 1u32..6,
            shaping in any::<bool>(),
            lead_in in prop::collection::vec(prop::collection::vec(sample(), 0..300), 8),
            push in prop::array::uniform8(
                prop_oneof![Just(0i16), Just(i16::MAX), Just(i16::MIN), -3000i16..3000]
            ),
            xs in prop::collection::vec(prop::array::uniform8(sample()), 1..400),
        ) {
            let Some(o) = avx512() else { return Ok(()) };
            let n = 1u16 << n_log2;
            let ptsa = Config {
                ticks_per_cycle: n,
                gate_ticks: u32::from(n) * gate_cycles,
                noise_shaping: shaping,
                ..Config::DEFAULT
            }
            .build()
            .expect("a valid configuration");
            // Each lane at its own phase: its own lead-in of ticks.
            let mut single: [State; 8] = [ptsa.initial_state(); 8];
            for (s, lead) in single.iter_mut().zip(&lead_in) {
                for &x in lead {
                    ptsa.tick(s, x);
                }
            }
            let mut regs = Regs::load(o, &Lanes::new(&single));
            for x in &xs {
                let x: [i16; 8] = std::array::from_fn(|l| x[l].saturating_add(push[l]));
                let t = ptsa.tick_regs(o, &mut regs, o.load(x.map(i32::from))).lanes(o);
                for l in 0..8 {
                    let want = ptsa.tick(&mut single[l], x[l]);
                    prop_assert_eq!(t.get(l), want, "lane {}", l);
                }
                let got = regs.store(o);
                for (l, s) in single.iter().enumerate() {
                    prop_assert_eq!(got.get(l), *s, "lane {}", l);
                }
            }
        }
    }
}
