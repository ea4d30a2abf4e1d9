//! The ADC's conversion from a voltage to the tick's pickoff sample, and from the word a
//! converter's data register holds to that sample: the one definition that the host
//! simulator, the firmware and its processor-in-the-loop image share (`ARITHMETIC.md`,
//! "The ADC").
//!
//! The tick reads an `i16` sample whose full scale is the converter's input range, whatever
//! its resolution: an `n`-bit converter delivers every `2^(16−n)`-th value of the `i16`
//! range (a 12-bit one: steps of 16). The loop's gain is therefore set by the analogue
//! front end, not by the number of bits.

/// How a converter writes a signed quantity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Coding {
    /// Offset binary over a unipolar input range `0..V_REF`: code 0 at 0 V, `2^(n−1)` at
    /// mid-scale (the STM32F4's ADC).
    OffsetBinary,
    /// Two's complement over a bipolar input range `−V_REF/2..V_REF/2`: code 0 at 0 V.
    TwosComplement,
}

/// Where an `n`-bit code sits in the 16-bit data word.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Alignment {
    /// In bits `15..16−n` (the low bits zero).
    Left,
    /// In bits `n−1..0`.
    Right,
}

/// A converter's format: resolution, coding and alignment.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdcFormat {
    bits: u8,
    coding: Coding,
    alignment: Alignment,
}

/// `pos as u16` (the floor clamped to `0..=65535`, NaN to 0) by float arithmetic alone, so
/// that lanes of it run as SIMD instructions ([`AdcFormat::sample_lanes`]): clamped, `pos`
/// lies in `[0, 65535]`, where adding `2^52` rounds it to the nearest integer `r`, held in
/// the low bits of the sum; the floor is `r`, less one where `r > pos`. (`f64::max` takes
/// the number when one side is NaN, so NaN clamps to 0 as the cast has it.)
#[allow(clippy::inline_always, reason = "per-tick path of the host's lanes")]
#[inline(always)]
#[allow(
    clippy::manual_clamp,
    reason = "clamp returns NaN for NaN, where this needs 0 as the cast gives"
)]
fn floor_u16(pos: f64) -> u16 {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    let p = pos.max(0.0).min(65535.0);
    let sum = p + TWO_52;
    #[allow(
        clippy::cast_possible_truncation,
        reason = "the low 16 bits of the sum's bits are r"
    )]
    let r = sum.to_bits() as u16;
    r.wrapping_sub(u16::from(sum - TWO_52 > p))
}

impl AdcFormat {
    /// The converter the compensator is designed for (`ARITHMETIC.md`, "Pickoff scale"): a
    /// signed 16-bit code.
    pub const SIGNED_16: AdcFormat = AdcFormat {
        bits: 16,
        coding: Coding::TwosComplement,
        alignment: Alignment::Left,
    };

    /// A format of `bits` (1 to 16) bits; `None` for another number.
    #[must_use]
    pub const fn new(bits: u8, coding: Coding, alignment: Alignment) -> Option<Self> {
        if bits == 0 || bits > 16 {
            return None;
        }
        Some(Self {
            bits,
            coding,
            alignment,
        })
    }

    /// Resolution, bits.
    #[must_use]
    pub const fn bits(self) -> u8 {
        self.bits
    }

    /// Coding.
    #[must_use]
    pub const fn coding(self) -> Coding {
        self.coding
    }

    /// Alignment.
    #[must_use]
    pub const fn alignment(self) -> Alignment {
        self.alignment
    }

    /// `16 − bits`: the shift from a code to its place in the `i16` sample.
    const fn shift(self) -> u32 {
        16 - self.bits as u32
    }

    /// The bits of the `i16` sample (as `u16`) that the converter can set: the top `bits`.
    #[must_use]
    pub const fn mask(self) -> u16 {
        u16::MAX << self.shift()
    }

    /// One step of the converter in units of the `i16` sample, `2^(16−bits)`.
    #[must_use]
    pub const fn step(self) -> u32 {
        1 << self.shift()
    }

    /// The sample of an input at `pos`: the input's distance from the bottom of the
    /// converter's range (0 V for offset binary, `−V_REF/2` for two's complement) in units
    /// of `V_REF / 2^16`, **plus half a step** of the converter (`2^(15−bits)`, the
    /// rounding). The code is `floor(pos / step)` clamped to `0..=2^bits − 1` (transitions
    /// half a step above each code's nominal voltage, the ideal transfer curve), and the
    /// sample is that code's place in the `i16` range (`code·step − 2^15`). NaN gives the
    /// bottom code.
    ///
    /// No `libm` call: the truncating, saturating `as u16` is the floor and the clamp for
    /// every `pos` (negative to 0, beyond the range to the top), and the mask drops the
    /// bits below the converter's step.
    #[allow(
        clippy::inline_always,
        reason = "per-tick path of the host and the PIL image"
    )]
    #[inline(always)]
    #[must_use]
    pub fn sample_at(self, pos: f64) -> i16 {
        Self::sample_masked(self.mask(), pos)
    }

    /// [`AdcFormat::sample_at`] with the format's [`AdcFormat::mask`] given (lanes of
    /// different formats keep it per lane).
    #[allow(
        clippy::inline_always,
        reason = "per-tick path of the host and the PIL image"
    )]
    #[inline(always)]
    #[must_use]
    pub fn sample_masked(mask: u16, pos: f64) -> i16 {
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "the saturating cast is the floor and the clamp"
        )]
        let z = pos as u16;
        #[allow(
            clippy::cast_possible_wrap,
            reason = "offset binary to two's complement"
        )]
        let s = ((z & mask) ^ 0x8000) as i16;
        s
    }

    /// [`AdcFormat::sample_masked`] of `L` lanes: lane `l` is `sample_masked(mask[l],
    /// pos[l])`, bit for bit.
    ///
    /// One lane takes `sample_masked`'s own saturating `as u16`. With more, the compiler
    /// turns that cast into one scalar conversion per lane (there is no SIMD instruction
    /// for a saturating float-to-integer conversion), so the lanes take the same floor and
    /// clamp by float arithmetic instead (adding 2^52 and correcting the rounding), which
    /// runs on SIMD lanes: on the host's batch engine, 8 lanes with AVX-512 ran at 357
    /// against 316 Mticks/s the other way, while the single loop, whose tick waits on this
    /// conversion, ran 7 % slower with the float form (`ptsa bench --batch 16 --lanes 8`).
    /// The tests check the two forms against each other for every kind of `f64`.
    #[allow(clippy::inline_always, reason = "per-tick path of the host's lanes")]
    #[inline(always)]
    #[must_use]
    pub fn sample_lanes<const L: usize>(mask: &[u16; L], pos: &[f64; L]) -> [i16; L] {
        let mut s = [0i16; L];
        if L == 1 {
            s[0] = Self::sample_masked(mask[0], pos[0]);
        } else {
            for l in 0..L {
                #[allow(
                    clippy::cast_possible_wrap,
                    reason = "offset binary to two's complement"
                )]
                let v = ((floor_u16(pos[l]) & mask[l]) ^ 0x8000) as i16;
                s[l] = v;
            }
        }
        s
    }

    /// The sample of a voltage `v` at the converter's input pin for the reference
    /// `reference_v` (the width of the input range, V): [`AdcFormat::sample_at`] of
    /// `(v − bottom) / reference_v · 2^16 + 2^(15−bits)`.
    #[must_use]
    pub fn sample_of_volts(self, v: f64, reference_v: f64) -> i16 {
        let bottom = match self.coding {
            Coding::OffsetBinary => 0.0,
            Coding::TwosComplement => -0.5 * reference_v,
        };
        self.sample_at((v - bottom) / reference_v * 65536.0 + f64::from(self.step()) / 2.0)
    }

    /// The sample of the word read from the converter's data register (bits above 15
    /// ignored): the code moved to the top of the word (right alignment), then offset
    /// binary made two's complement. For the STM32F4's left-aligned offset-binary word
    /// this is `word ^ 0x8000`.
    #[allow(clippy::inline_always, reason = "tick path: inside the TIM2 handler")]
    #[inline(always)]
    #[must_use]
    pub const fn sample_of_word(self, word: u32) -> i16 {
        let top = match self.alignment {
            Alignment::Left => word,
            Alignment::Right => word << self.shift(),
        };
        let flip = match self.coding {
            Coding::OffsetBinary => 0x8000,
            Coding::TwosComplement => 0,
        };
        #[allow(clippy::cast_possible_truncation, clippy::cast_possible_wrap)]
        let s = ((top as u16) ^ flip) as i16;
        s
    }

    /// The data-register word whose sample is `sample` (its bits below the converter's
    /// step dropped): the inverse of [`AdcFormat::sample_of_word`], for test images that
    /// put a word where the converter would. A right-aligned two's-complement code keeps
    /// only its `bits` bits, as a converter delivers it.
    #[must_use]
    pub const fn word_of_sample(self, sample: i16) -> u32 {
        #[allow(clippy::cast_sign_loss)]
        let s = (sample as u16) & self.mask();
        let top = match self.coding {
            Coding::OffsetBinary => s ^ 0x8000,
            Coding::TwosComplement => s,
        } as u32;
        match self.alignment {
            Alignment::Left => top,
            Alignment::Right => top >> self.shift(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const STM32: AdcFormat = AdcFormat {
        bits: 12,
        coding: Coding::OffsetBinary,
        alignment: Alignment::Left,
    };

    #[test]
    fn the_16_bit_format_is_the_hosts_historic_conversion() {
        // The host's quantizer before this module: ((pos as u16) ^ 0x8000) as i16.
        for pos in [
            -1e9, -0.5, 0.0, 0.49, 0.5, 1.0, 32768.0, 32768.5, 65535.9, 65536.0, 1e9,
        ] {
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            #[allow(clippy::cast_possible_wrap)]
            let old = ((pos as u16) ^ 0x8000) as i16;
            assert_eq!(AdcFormat::SIGNED_16.sample_at(pos), old, "{pos}");
        }
        assert_eq!(AdcFormat::SIGNED_16.sample_at(f64::NAN), i16::MIN);
    }

    #[test]
    fn codes_change_at_the_half_steps_and_clip_at_the_ends() {
        // 12 bits: a step is 16 units; sample_at adds nothing, the caller adds half a step.
        let f = STM32;
        assert_eq!(f.step(), 16);
        assert_eq!(f.mask(), 0xFFF0);
        assert_eq!(f.sample_at(0.0), -32768);
        assert_eq!(f.sample_at(15.999), -32768);
        assert_eq!(f.sample_at(16.0), -32752);
        assert_eq!(f.sample_at(32768.0), 0);
        assert_eq!(f.sample_at(32767.99), -16);
        assert_eq!(f.sample_at(65520.0), 32752);
        assert_eq!(f.sample_at(1e12), 32752);
        assert_eq!(f.sample_at(-3.0), -32768);
        // In volts at 3.3 V: one code is 3.3/4096 = 805.7 µV; the first transition is at half
        // of it, mid-scale (code 2048 = sample 0) from 1.65 V − half a code.
        let lsb = 3.3 / 4096.0;
        assert_eq!(f.sample_of_volts(0.0, 3.3), -32768);
        assert_eq!(f.sample_of_volts(0.49 * lsb, 3.3), -32768);
        assert_eq!(f.sample_of_volts(0.51 * lsb, 3.3), -32752);
        assert_eq!(f.sample_of_volts(1.65 - 0.49 * lsb, 3.3), 0);
        assert_eq!(f.sample_of_volts(1.65 - 0.51 * lsb, 3.3), -16);
        assert_eq!(f.sample_of_volts(3.3, 3.3), 32752);
        assert_eq!(f.sample_of_volts(-1.0, 3.3), -32768);
        // Bipolar: 0 V is code 0, the ends ±V_REF/2.
        let b = AdcFormat::new(12, Coding::TwosComplement, Alignment::Right).unwrap();
        assert_eq!(b.sample_of_volts(0.0, 5.0), 0);
        assert_eq!(b.sample_of_volts(-2.5, 5.0), -32768);
        assert_eq!(b.sample_of_volts(2.5, 5.0), 32752);
    }

    #[test]
    fn data_register_words() {
        // STM32F4, left-aligned offset binary: 0 V reads 0x0000, V_REF 0xFFF0.
        assert_eq!(STM32.sample_of_word(0x0000), -32768);
        assert_eq!(STM32.sample_of_word(0x8000), 0);
        assert_eq!(STM32.sample_of_word(0xFFF0), 32752);
        assert_eq!(STM32.word_of_sample(0), 0x8000);
        assert_eq!(STM32.word_of_sample(-1), 0x7FF0);
        let right = AdcFormat::new(12, Coding::OffsetBinary, Alignment::Right).unwrap();
        assert_eq!(right.sample_of_word(0x0FFF), 32752);
        assert_eq!(right.sample_of_word(0x0800), 0);
        let twos = AdcFormat::new(12, Coding::TwosComplement, Alignment::Right).unwrap();
        assert_eq!(twos.sample_of_word(0x0FFF), -16);
        assert_eq!(twos.word_of_sample(-16), 0x0FFF);
        assert_eq!(twos.sample_of_word(0x0800), -32768);
        assert!(AdcFormat::new(0, Coding::OffsetBinary, Alignment::Left).is_none());
        assert!(AdcFormat::new(17, Coding::OffsetBinary, Alignment::Left).is_none());
    }

    /// `pos as u16`, the cast [`floor_u16`] stands for.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn cast(pos: f64) -> u16 {
        pos as u16
    }

    #[test]
    fn the_lanes_floor_is_the_cast_at_every_code_and_its_neighbours() {
        // Every integer from below the range to above it, each with its neighbouring
        // doubles, the half-way points and their neighbours: where a floor goes wrong.
        for k in -3i32..=65_538 {
            let x = f64::from(k);
            for pos in [
                x,
                x.next_down(),
                x.next_up(),
                x + 0.5,
                (x + 0.5).next_down(),
                (x + 0.5).next_up(),
                x - 0.5,
                x + 0.999_999_9,
            ] {
                assert_eq!(floor_u16(pos), cast(pos), "{pos:e}");
            }
        }
        for pos in [
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            f64::MIN,
            4_503_599_627_370_496.0,
            1e300,
        ] {
            assert_eq!(floor_u16(pos), cast(pos), "{pos:e}");
        }
    }

    #[test]
    fn lanes_of_samples_are_the_samples() {
        let pos = [-1.0, 0.0, 16.5, 32768.0, 32767.99, 65520.0, 1e12, f64::NAN];
        let mask = [
            0xFFF0, 0xFFFF, 0xFFF0, 0xFFFF, 0xFFF0, 0xFFF0, 0xFFFF, 0xFFF0,
        ];
        let eight = AdcFormat::sample_lanes(&mask, &pos);
        for l in 0..8 {
            assert_eq!(eight[l], AdcFormat::sample_masked(mask[l], pos[l]), "{l}");
            assert_eq!(
                AdcFormat::sample_lanes(&[mask[l]], &[pos[l]])[0],
                eight[l],
                "{l}"
            );
        }
    }

    fn format() -> impl Strategy<Value = AdcFormat> {
        (1u8..=16, any::<bool>(), any::<bool>()).prop_map(|(bits, twos, right)| {
            AdcFormat::new(
                bits,
                if twos {
                    Coding::TwosComplement
                } else {
                    Coding::OffsetBinary
                },
                if right {
                    Alignment::Right
                } else {
                    Alignment::Left
                },
            )
            .unwrap()
        })
    }

    proptest! {
        /// The lanes' floor is the cast for doubles of every kind (`any::<f64>()` draws
        /// NaN, infinities, subnormals and both signs) and for doubles inside the range
        /// (where the floor matters).
        #[test]
        fn the_lanes_floor_is_the_cast(wild in any::<f64>(), inside in -2.0f64..65_538.0) {
            prop_assert_eq!(floor_u16(wild), cast(wild));
            prop_assert_eq!(floor_u16(inside), cast(inside));
        }
    }

    proptest! {
        /// Every sample is a multiple of the step, monotonic in the input, and within
        /// half a step of the input inside the range; the word round-trips.
        #[test]
        fn samples_are_the_nearest_code(f in format(), pos in -1e5f64..2e5, d in 0.0f64..1e4) {
            let s = f.sample_at(pos);
            let step = i64::from(f.step());
            prop_assert_eq!((i64::from(s) + 32768) % step, 0);
            prop_assert!(f.sample_at(pos + d) >= s);
            #[allow(clippy::cast_precision_loss)]
            let half = step as f64 / 2.0;
            // `pos` carries the caller's half step: the ideal value is pos − half.
            let ideal = pos - half - 32768.0;
            #[allow(clippy::cast_precision_loss)]
            let top = (32768 - step) as f64;
            if ideal >= -32768.0 && ideal <= top {
                #[allow(clippy::cast_precision_loss)]
                let err = f64::from(s) - ideal;
                prop_assert!(err > -half - 1e-9 && err <= half + 1e-9, "{err}");
            }
            prop_assert_eq!(f.sample_of_word(f.word_of_sample(s)), s);
            prop_assert!(f.word_of_sample(s) <= 0xFFFF);
        }
    }
}
