//! Which SIMD instructions the batch engine's kernels use: the best this CPU has, or fewer
//! when the environment variable `PTSA_SIMD` asks for them (`avx512`, `avx2`, `sse2`), so
//! that the paths can be compared on one machine (`PTSA_SIMD=avx2 ptsa bench --batch 16`
//! runs what a CPU without AVX-512 runs). Every path gives the same results bit for bit;
//! only the speed differs.
//!
//! A kernel of eight lanes runs the core's tick in the registers of the level
//! (`simulation/avx512.rs`, `simulation/avx2.rs`); other kernels, and the dynamic kernels at
//! `sse2`, run it on arrays (`ptsa_core::Each`) compiled for the level's instructions. At
//! `sse2` static lanes run one after the other (the single loop's fast path), which is
//! faster there than any kernel on arrays.

use std::sync::OnceLock;

/// The instruction sets the kernels may use, in increasing order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SimdLevel {
    /// x86-64's baseline (SSE2), or no SIMD at all on another architecture.
    Sse2,
    /// AVX2 and FMA (`pulp`'s `V3`; FMA is never used: Rust does not contract `a·b + c`).
    Avx2,
    /// AVX-512 F, BW, CD, DQ and VL (`pulp`'s `V4`).
    Avx512,
}

impl SimdLevel {
    /// The name `PTSA_SIMD` takes.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Sse2 => "sse2",
            Self::Avx2 => "avx2",
            Self::Avx512 => "avx512",
        }
    }

    /// The best level this CPU has.
    #[must_use]
    pub fn of_cpu() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if pulp::x86::V4::try_new().is_some() {
                return Self::Avx512;
            }
            if pulp::x86::V3::try_new().is_some() {
                return Self::Avx2;
            }
        }
        Self::Sse2
    }

    /// The level `PTSA_SIMD` asks for: `Ok(None)` when it is not set, `Err` with what was
    /// expected when it is set to anything else than a level's name.
    ///
    /// # Errors
    /// When the variable is set but not `avx512`, `avx2` or `sse2`.
    pub fn from_env() -> Result<Option<Self>, String> {
        let Some(v) = std::env::var_os("PTSA_SIMD") else {
            return Ok(None);
        };
        let s = v.to_string_lossy();
        [Self::Avx512, Self::Avx2, Self::Sse2]
            .into_iter()
            .find(|l| l.name() == s.trim())
            .map(Some)
            .ok_or_else(|| {
                format!(
                    "PTSA_SIMD={s}: expected avx512, avx2 or sse2 (the most the batch engine's \
                     kernels may use); using the CPU's best, {}",
                    Self::of_cpu().name()
                )
            })
    }

    /// The level the kernels use: the CPU's best, or less if `PTSA_SIMD` asks for less
    /// (read once; a value that is not a level's name is ignored, and the `ptsa` binary
    /// warns about it at its start).
    #[must_use]
    pub fn current() -> Self {
        static LEVEL: OnceLock<SimdLevel> = OnceLock::new();
        *LEVEL.get_or_init(|| {
            let cpu = Self::of_cpu();
            match Self::from_env() {
                Ok(Some(asked)) => asked.min(cpu),
                Ok(None) | Err(_) => cpu,
            }
        })
    }

    /// Whether static lanes run side by side in kernels at this level: not at `sse2`,
    /// where the kernels on arrays ran slower than one lane after the other
    /// (`PTSA_SIMD=sse2 ptsa bench --batch 16`: 0.70 of the single loop with 8 lanes,
    /// against 1.05-1.08 for `--lanes 1` on the same machine).
    #[must_use]
    pub fn static_kernels(self) -> bool {
        self != Self::Sse2
    }

    /// What a kernel of eight lanes holds the core's tick in, for a user: "AVX-512
    /// registers", "AVX2 registers", or "arrays".
    #[must_use]
    pub fn lanes_of_eight(self) -> &'static str {
        match self {
            Self::Avx512 => "AVX-512 registers",
            Self::Avx2 => "AVX2 registers",
            Self::Sse2 => "arrays",
        }
    }
}

/// Run `f` compiled with the instructions of [`SimdLevel::current`] for everything inlined
/// into it. `f`'s `with_simd` and the functions on the tick path are `#[inline(always)]` so
/// that they are compiled inside.
#[inline]
pub(super) fn dispatch<F: pulp::WithSimd>(f: F) -> F::Output {
    #[cfg(target_arch = "x86_64")]
    match SimdLevel::current() {
        SimdLevel::Avx512 => {
            if let Some(v4) = pulp::x86::V4::try_new() {
                return pulp::Simd::vectorize(v4, f);
            }
        }
        SimdLevel::Avx2 => {
            if let Some(v3) = pulp::x86::V3::try_new() {
                return pulp::Simd::vectorize(v3, f);
            }
        }
        SimdLevel::Sse2 => {}
    }
    pulp::Simd::vectorize(pulp::Scalar::new(), f)
}

/// Lane operations held in a CPU's registers, with the `pulp` token that compiles a kernel
/// for their instructions (`simulation/avx512.rs`, `simulation/avx2.rs`).
#[cfg(target_arch = "x86_64")]
pub(super) trait Registers: ptsa_core::LaneOps<8> {
    /// The instruction set's token.
    type Simd: pulp::Simd;
    /// The token, for `pulp::Simd::vectorize`.
    fn simd(self) -> Self::Simd;
}

/// The operations on 32-bit lanes that the AVX-512 and the AVX2 lanes share, written once:
/// eight lanes in one `ymm` register, AVX2's instructions (both tokens have them, as the
/// field `avx2`; `avx` for the splat). Expanded inside each `impl LaneOps<8>`.
#[cfg(target_arch = "x86_64")]
macro_rules! ymm_i32_ops {
    () => {
        #[inline(always)]
        fn load(self, a: [i32; 8]) -> __m256i {
            pulp::cast(a)
        }
        #[inline(always)]
        fn store(self, v: __m256i) -> [i32; 8] {
            pulp::cast(v)
        }
        #[inline(always)]
        fn splat(self, a: i32) -> __m256i {
            self.0.avx._mm256_set1_epi32(a)
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
    };
}
#[cfg(target_arch = "x86_64")]
pub(super) use ymm_i32_ops;
