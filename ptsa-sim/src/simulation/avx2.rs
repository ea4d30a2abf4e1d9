//! Eight lanes of the core's tick in AVX2 registers: [`Avx2`], a [`ptsa_core::LaneOps`]
//! whose 32-bit lanes are one `ymm` register, whose 64-bit lanes are two (lanes 0–3 and
//! 4–7) and whose flags are a `ymm` of 32-bit masks (all ones where set), for the CPUs
//! without AVX-512. AVX2 has no 64-bit arithmetic shift, no 64-to-32-bit narrowing and no
//! mask registers: the shift is a logical one between two sign flips, the narrowing a
//! permutation of each half and a join, and "any lane" one `vpmovmskb`. The tick itself is
//! `ptsa_core`'s one definition (`Ptsa::tick_regs`); each operation here does in every
//! lane what [`ptsa_core::Each`]'s does in its array element (the tests in
//! `lane_tests` hold the two equal on drawn values and the tick equal to `Ptsa::tick`).
//!
//! The intrinsics come from `pulp`'s safe wrappers, callable only with a [`V3`] token, which
//! exists only on a CPU that has AVX2 and FMA ([`Avx2::new`]).

#![allow(
    clippy::inline_always,
    reason = "the tick path: every operation inlined into the kernel compiled for AVX2"
)]

use core::arch::x86_64::__m256i;

use ptsa_core::LaneOps;

use super::simd::{Registers, ymm_i32_ops};
use pulp::x86::V3;

/// Eight lanes in AVX2 registers (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(super) struct Avx2(pub(super) V3);

impl Avx2 {
    /// The lanes, on a CPU that has AVX2 and FMA; `None` elsewhere.
    pub(super) fn new() -> Option<Self> {
        V3::try_new().map(Self)
    }

    /// The 32-bit lanes `a` sign-extended to 64 bits: lanes 0–3, 4–7.
    #[inline(always)]
    fn widen(self, a: __m256i) -> [__m256i; 2] {
        let v = self.0;
        [
            v.avx2
                ._mm256_cvtepi32_epi64(v.avx._mm256_castsi256_si128(a)),
            v.avx2
                ._mm256_cvtepi32_epi64(v.avx2._mm256_extracti128_si256::<1>(a)),
        ]
    }

    /// The low 32 bits of each 64-bit lane of `a`, as one register of eight.
    #[inline(always)]
    fn narrow(self, a: [__m256i; 2]) -> __m256i {
        let v = self.0;
        // Each half's even 32-bit words to its low 128 bits, then the two low halves joined.
        let even = v.avx._mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
        let lo = v.avx2._mm256_permutevar8x32_epi32(a[0], even);
        let hi = v.avx2._mm256_permutevar8x32_epi32(a[1], even);
        v.avx2._mm256_permute2x128_si256::<0x20>(lo, hi)
    }

    /// `f` of each half.
    #[inline(always)]
    fn halves(
        a: [__m256i; 2],
        b: [__m256i; 2],
        f: impl Fn(__m256i, __m256i) -> __m256i,
    ) -> [__m256i; 2] {
        [f(a[0], b[0]), f(a[1], b[1])]
    }
}

impl Registers for Avx2 {
    type Simd = V3;

    fn simd(self) -> V3 {
        self.0
    }
}

impl LaneOps<8> for Avx2 {
    type I32 = __m256i;
    type I64 = [__m256i; 2];
    type Mask = __m256i;

    ymm_i32_ops!();

    #[inline(always)]
    fn load64(self, a: [i64; 8]) -> [__m256i; 2] {
        pulp::cast(a)
    }
    #[inline(always)]
    fn store64(self, v: [__m256i; 2]) -> [i64; 8] {
        pulp::cast(v)
    }
    #[inline(always)]
    fn load_mask(self, a: [bool; 8]) -> __m256i {
        pulp::cast(a.map(|b| -i32::from(b)))
    }
    #[inline(always)]
    fn store_mask(self, m: __m256i) -> [bool; 8] {
        pulp::cast::<_, [i32; 8]>(m).map(|x| x != 0)
    }
    #[inline(always)]
    fn mask64(self, m: __m256i) -> [u64; 8] {
        pulp::cast(self.widen(m))
    }

    #[inline(always)]
    fn splat64(self, a: i64) -> [__m256i; 2] {
        let v = self.0.avx._mm256_set1_epi64x(a);
        [v, v]
    }
    #[inline(always)]
    fn lt(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_cmpgt_epi32(b, a)
    }
    #[inline(always)]
    fn gt(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_cmpgt_epi32(a, b)
    }
    #[inline(always)]
    fn eq(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_cmpeq_epi32(a, b)
    }
    #[inline(always)]
    fn select(self, m: __m256i, a: __m256i, b: __m256i) -> __m256i {
        // The blend takes its second operand where the mask's bytes have their top bit set.
        self.0.avx2._mm256_blendv_epi8(b, a, m)
    }
    #[inline(always)]
    fn count(self, c: __m256i, m: __m256i) -> __m256i {
        // A set mask lane is −1.
        self.sub(c, m)
    }

    #[inline(always)]
    fn mul_wide(self, a: __m256i, b: i32) -> [__m256i; 2] {
        // The signed product of the low 32 bits of each 64-bit lane: exact.
        let (v, b) = (self.0, self.0.avx._mm256_set1_epi64x(i64::from(b)));
        let h = self.widen(a);
        [
            v.avx2._mm256_mul_epi32(h[0], b),
            v.avx2._mm256_mul_epi32(h[1], b),
        ]
    }
    #[inline(always)]
    fn add64(self, a: [__m256i; 2], b: [__m256i; 2]) -> [__m256i; 2] {
        let v = self.0;
        Self::halves(a, b, |x, y| v.avx2._mm256_add_epi64(x, y))
    }
    #[inline(always)]
    fn sub64(self, a: [__m256i; 2], b: [__m256i; 2]) -> [__m256i; 2] {
        let v = self.0;
        Self::halves(a, b, |x, y| v.avx2._mm256_sub_epi64(x, y))
    }
    #[inline(always)]
    fn xor64(self, a: [__m256i; 2], b: [__m256i; 2]) -> [__m256i; 2] {
        let v = self.0;
        Self::halves(a, b, |x, y| v.avx2._mm256_xor_si256(x, y))
    }
    #[inline(always)]
    fn sra64<const N: u32>(self, a: [__m256i; 2]) -> [__m256i; 2] {
        // `x >> N` = `!((!x) >> N)` for negative `x`, the inner shift a logical one.
        let v = self.0;
        let (zero, n) = (
            v.avx._mm256_setzero_si256(),
            v.avx._mm256_set1_epi64x(i64::from(N)),
        );
        let shift = |x| {
            let s = v.avx2._mm256_cmpgt_epi64(zero, x);
            let flipped = v.avx2._mm256_xor_si256(x, s);
            v.avx2
                ._mm256_xor_si256(v.avx2._mm256_srlv_epi64(flipped, n), s)
        };
        // Called directly, not through `array::map`, which the compiler may leave out of
        // line, and the intrinsics with it, outside the kernel's target features.
        [shift(a[0]), shift(a[1])]
    }
    #[inline(always)]
    fn low32(self, a: [__m256i; 2]) -> __m256i {
        self.narrow(a)
    }
    #[inline(always)]
    fn lt64(self, a: [__m256i; 2], b: [__m256i; 2]) -> __m256i {
        let v = self.0;
        self.narrow(Self::halves(a, b, |x, y| v.avx2._mm256_cmpgt_epi64(y, x)))
    }
    #[inline(always)]
    fn gt64(self, a: [__m256i; 2], b: [__m256i; 2]) -> __m256i {
        let v = self.0;
        self.narrow(Self::halves(a, b, |x, y| v.avx2._mm256_cmpgt_epi64(x, y)))
    }
    #[inline(always)]
    fn select64(self, m: __m256i, a: [__m256i; 2], b: [__m256i; 2]) -> [__m256i; 2] {
        let (v, m) = (self.0, self.widen(m));
        [
            v.avx2._mm256_blendv_epi8(b[0], a[0], m[0]),
            v.avx2._mm256_blendv_epi8(b[1], a[1], m[1]),
        ]
    }

    #[inline(always)]
    fn and_mask(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_and_si256(a, b)
    }
    #[inline(always)]
    fn or_mask(self, a: __m256i, b: __m256i) -> __m256i {
        self.0.avx2._mm256_or_si256(a, b)
    }
    #[inline(always)]
    fn and_not_mask(self, a: __m256i, b: __m256i) -> __m256i {
        // `_mm256_andnot_si256(x, y)` is `!x & y`.
        self.0.avx2._mm256_andnot_si256(b, a)
    }
    #[inline(always)]
    fn not_mask(self, a: __m256i) -> __m256i {
        self.0.avx2._mm256_xor_si256(a, self.splat(-1))
    }
    #[inline(always)]
    fn any(self, m: __m256i) -> bool {
        self.0.avx2._mm256_movemask_epi8(m) != 0
    }
}
