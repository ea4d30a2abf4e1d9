//! Eight lanes of the core's tick in AVX-512 registers: [`Avx512`], a
//! [`ptsa_core::LaneOps`] whose 32-bit lanes are one `ymm` register, whose 64-bit lanes are
//! one `zmm` register and whose flags are one mask register (`k`), so that the tick's range
//! tests, selects and "any lane" tests are one instruction each. The tick itself is
//! `ptsa_core`'s one definition (`Ptsa::tick_regs`); each operation here does in every lane
//! what [`ptsa_core::Each`]'s does in its array element (the tests in `lane_tests` hold the
//! two equal on drawn values and the tick equal to `Ptsa::tick`; the batch tests hold the
//! whole loop equal to the single loop).
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

use super::simd::{Registers, ymm_i32_ops};
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

impl Registers for Avx512 {
    type Simd = V4;

    fn simd(self) -> V4 {
        self.0
    }
}

impl LaneOps<8> for Avx512 {
    type I32 = __m256i;
    type I64 = __m512i;
    type Mask = u8;

    ymm_i32_ops!();

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
    fn splat64(self, a: i64) -> __m512i {
        self.0.avx512f._mm512_set1_epi64(a)
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
