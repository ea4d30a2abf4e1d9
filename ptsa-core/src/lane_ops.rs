//! The integer operations the tick is written in, for `L` loops side by side.
//!
//! [`Ptsa::tick_regs`](crate::Ptsa::tick_regs) is the loop's per-tick arithmetic written once
//! over a [`LaneOps`]: a value of `L` lanes of 32-bit integers ([`LaneOps::I32`]), of 64-bit
//! integers ([`LaneOps::I64`]) and of flags ([`LaneOps::Mask`]), and the few operations the
//! tick needs on them. [`Each`] is the plain form, one array element per lane and each
//! operation a loop over the lanes: the firmware runs it with one lane ([`Ptsa::tick`] is
//! [`Ptsa::tick_lanes`] with `L = 1`), and a host may run it with any `L`, leaving the
//! vectorisation to the compiler. A host that wants the lanes in SIMD registers, with the
//! flags as a CPU's mask registers, implements `LaneOps` on its own vector types
//! (`ptsa-sim` does for AVX-512 and AVX2) and gets the same tick, bit for bit: every
//! operation's meaning is given here as what `Each` does lane by lane.
//!
//! Overflow policy: `I32` arithmetic wraps (the counters are `u32` read as `i32` bits; the
//! signed quantities are proven never to overflow, ARITHMETIC.md's "Bounds"); `I64` likewise.
//!
//! [`Ptsa::tick`]: crate::Ptsa::tick
//! [`Ptsa::tick_lanes`]: crate::Ptsa::tick_lanes

#![allow(
    clippy::needless_range_loop,
    reason = "a lane index walks several arrays in step: the structure of arrays"
)]
#![allow(
    clippy::needless_bitwise_bool,
    reason = "branch-free on purpose: `&` on lanes vectorises, `&&` would branch"
)]
#![allow(
    clippy::inline_always,
    reason = "the tick path: every operation is inlined into the firmware's TIM2 handler and \
              the host's lanes"
)]

/// `L` lanes of integers and flags and the operations of the tick on them. Each method
/// does, in every lane, what [`Each`]'s does in its array element.
pub trait LaneOps<const L: usize>: Copy {
    /// 32-bit integers, one per lane (signed values, and counters as their `u32` bits).
    type I32: Copy;
    /// 64-bit signed integers, one per lane.
    type I64: Copy;
    /// One flag per lane.
    type Mask: Copy;

    /// The lanes of `a`.
    fn load(self, a: [i32; L]) -> Self::I32;
    /// The lanes of `v` as an array.
    fn store(self, v: Self::I32) -> [i32; L];
    /// The lanes of `a`.
    fn load64(self, a: [i64; L]) -> Self::I64;
    /// The lanes of `v` as an array.
    fn store64(self, v: Self::I64) -> [i64; L];
    /// The flags of `a`.
    fn load_mask(self, a: [bool; L]) -> Self::Mask;
    /// The flags of `m` as an array.
    fn store_mask(self, m: Self::Mask) -> [bool; L];
    /// The flags of `m` as 64-bit masks: all ones where set, else zero.
    fn mask64(self, m: Self::Mask) -> [u64; L];

    /// `a` in every lane.
    fn splat(self, a: i32) -> Self::I32;
    /// `a` in every lane.
    fn splat64(self, a: i64) -> Self::I64;
    /// `a + b`, wrapping.
    fn add(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a − b`, wrapping.
    fn sub(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a · b`, wrapping.
    fn mul(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a & b`.
    fn and(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a ^ b`.
    fn xor(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a >> N`, arithmetic (`0 <= N < 32`; an `i32` as the x86 instruction's immediate is
    /// typed, so that an implementation can pass it on).
    fn sra<const N: i32>(self, a: Self::I32) -> Self::I32;
    /// The greater of `a` and `b`.
    fn max(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// The lesser of `a` and `b`.
    fn min(self, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `a < b`.
    fn lt(self, a: Self::I32, b: Self::I32) -> Self::Mask;
    /// `a > b`.
    fn gt(self, a: Self::I32, b: Self::I32) -> Self::Mask;
    /// `a == b`.
    fn eq(self, a: Self::I32, b: Self::I32) -> Self::Mask;
    /// `a` where `m`, else `b`.
    fn select(self, m: Self::Mask, a: Self::I32, b: Self::I32) -> Self::I32;
    /// `c + 1` (wrapping) where `m`, else `c`: a count of the ticks in which `m` held.
    fn count(self, c: Self::I32, m: Self::Mask) -> Self::I32;

    /// `i64::from(a) · i64::from(b)`, exact.
    fn mul_wide(self, a: Self::I32, b: i32) -> Self::I64;
    /// `a + b`, wrapping.
    fn add64(self, a: Self::I64, b: Self::I64) -> Self::I64;
    /// `a − b`, wrapping.
    fn sub64(self, a: Self::I64, b: Self::I64) -> Self::I64;
    /// `a ^ b`.
    fn xor64(self, a: Self::I64, b: Self::I64) -> Self::I64;
    /// `a >> N`, arithmetic (`N < 64`).
    fn sra64<const N: u32>(self, a: Self::I64) -> Self::I64;
    /// The low 32 bits of `a` (`a as i32`).
    fn low32(self, a: Self::I64) -> Self::I32;
    /// `a < b`.
    fn lt64(self, a: Self::I64, b: Self::I64) -> Self::Mask;
    /// `a > b`.
    fn gt64(self, a: Self::I64, b: Self::I64) -> Self::Mask;
    /// `a` where `m`, else `b`.
    fn select64(self, m: Self::Mask, a: Self::I64, b: Self::I64) -> Self::I64;

    /// `a & b`.
    fn and_mask(self, a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `a | b`.
    fn or_mask(self, a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `a & !b`.
    fn and_not_mask(self, a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// `!a`.
    fn not_mask(self, a: Self::Mask) -> Self::Mask;
    /// Whether any lane of `m` is set.
    fn any(self, m: Self::Mask) -> bool;
}

/// The plain [`LaneOps`]: one array element per lane, every operation a loop over them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Each<const L: usize>;

/// `f` of each lane.
#[inline(always)]
fn each<T: Copy + Default, const L: usize>(f: impl Fn(usize) -> T) -> [T; L] {
    let mut r = [T::default(); L];
    for l in 0..L {
        r[l] = f(l);
    }
    r
}

impl<const L: usize> LaneOps<L> for Each<L> {
    type I32 = [i32; L];
    type I64 = [i64; L];
    type Mask = [bool; L];

    #[inline(always)]
    fn load(self, a: [i32; L]) -> Self::I32 {
        a
    }
    #[inline(always)]
    fn store(self, v: Self::I32) -> [i32; L] {
        v
    }
    #[inline(always)]
    fn load64(self, a: [i64; L]) -> Self::I64 {
        a
    }
    #[inline(always)]
    fn store64(self, v: Self::I64) -> [i64; L] {
        v
    }
    #[inline(always)]
    fn load_mask(self, a: [bool; L]) -> Self::Mask {
        a
    }
    #[inline(always)]
    fn store_mask(self, m: Self::Mask) -> [bool; L] {
        m
    }
    #[inline(always)]
    fn mask64(self, m: Self::Mask) -> [u64; L] {
        each(|l| u64::from(m[l]).wrapping_neg())
    }

    #[inline(always)]
    fn splat(self, a: i32) -> Self::I32 {
        [a; L]
    }
    #[inline(always)]
    fn splat64(self, a: i64) -> Self::I64 {
        [a; L]
    }
    #[inline(always)]
    fn add(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l].wrapping_add(b[l]))
    }
    #[inline(always)]
    fn sub(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l].wrapping_sub(b[l]))
    }
    #[inline(always)]
    fn mul(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l].wrapping_mul(b[l]))
    }
    #[inline(always)]
    fn and(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l] & b[l])
    }
    #[inline(always)]
    fn xor(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l] ^ b[l])
    }
    #[inline(always)]
    fn sra<const N: i32>(self, a: Self::I32) -> Self::I32 {
        each(|l| a[l] >> N)
    }
    #[inline(always)]
    fn max(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l].max(b[l]))
    }
    #[inline(always)]
    fn min(self, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| a[l].min(b[l]))
    }
    #[inline(always)]
    fn lt(self, a: Self::I32, b: Self::I32) -> Self::Mask {
        each(|l| a[l] < b[l])
    }
    #[inline(always)]
    fn gt(self, a: Self::I32, b: Self::I32) -> Self::Mask {
        each(|l| a[l] > b[l])
    }
    #[inline(always)]
    fn eq(self, a: Self::I32, b: Self::I32) -> Self::Mask {
        each(|l| a[l] == b[l])
    }
    #[inline(always)]
    fn select(self, m: Self::Mask, a: Self::I32, b: Self::I32) -> Self::I32 {
        each(|l| if m[l] { a[l] } else { b[l] })
    }
    #[inline(always)]
    fn count(self, c: Self::I32, m: Self::Mask) -> Self::I32 {
        each(|l| c[l].wrapping_add(i32::from(m[l])))
    }

    #[inline(always)]
    fn mul_wide(self, a: Self::I32, b: i32) -> Self::I64 {
        each(|l| i64::from(a[l]) * i64::from(b))
    }
    #[inline(always)]
    fn add64(self, a: Self::I64, b: Self::I64) -> Self::I64 {
        each(|l| a[l].wrapping_add(b[l]))
    }
    #[inline(always)]
    fn sub64(self, a: Self::I64, b: Self::I64) -> Self::I64 {
        each(|l| a[l].wrapping_sub(b[l]))
    }
    #[inline(always)]
    fn xor64(self, a: Self::I64, b: Self::I64) -> Self::I64 {
        each(|l| a[l] ^ b[l])
    }
    #[inline(always)]
    fn sra64<const N: u32>(self, a: Self::I64) -> Self::I64 {
        each(|l| a[l] >> N)
    }
    #[inline(always)]
    fn low32(self, a: Self::I64) -> Self::I32 {
        #[allow(
            clippy::cast_possible_truncation,
            reason = "the low 32 bits, as documented"
        )]
        each(|l| a[l] as i32)
    }
    #[inline(always)]
    fn lt64(self, a: Self::I64, b: Self::I64) -> Self::Mask {
        each(|l| a[l] < b[l])
    }
    #[inline(always)]
    fn gt64(self, a: Self::I64, b: Self::I64) -> Self::Mask {
        each(|l| a[l] > b[l])
    }
    #[inline(always)]
    fn select64(self, m: Self::Mask, a: Self::I64, b: Self::I64) -> Self::I64 {
        each(|l| if m[l] { a[l] } else { b[l] })
    }

    #[inline(always)]
    fn and_mask(self, a: Self::Mask, b: Self::Mask) -> Self::Mask {
        each(|l| a[l] & b[l])
    }
    #[inline(always)]
    fn or_mask(self, a: Self::Mask, b: Self::Mask) -> Self::Mask {
        each(|l| a[l] | b[l])
    }
    #[inline(always)]
    fn and_not_mask(self, a: Self::Mask, b: Self::Mask) -> Self::Mask {
        each(|l| a[l] & !b[l])
    }
    #[inline(always)]
    fn not_mask(self, a: Self::Mask) -> Self::Mask {
        each(|l| !a[l])
    }
    #[inline(always)]
    fn any(self, m: Self::Mask) -> bool {
        m.iter().fold(false, |a, &b| a | b)
    }
}
