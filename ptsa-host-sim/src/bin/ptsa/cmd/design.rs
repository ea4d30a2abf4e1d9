//! `ptsa design`: the compensator designed for the instrument file, the loop's margins and
//! the ptsa-core constants, with the loop check's verdict. It runs for a loop the simulator
//! refuses too (printing the design, then the refusal).

use std::fmt::Write as _;
use std::io::Write;

use anyhow::{Result, bail};
use clap::Args;
use ptsa_core::adc::{AdcFormat, Alignment, Coding};
use ptsa_host_sim::Instrument;
use ptsa_host_sim::model::design::{Design, LoopCheck, underscore};
use ptsa_host_sim::model::instrument::Board;
use ptsa_host_sim::report::experiments::design;

use super::Ctx;

/// Arguments of `ptsa design`.
#[derive(Args, Debug, Clone)]
pub struct DesignArgs {
    /// Print only the four DEFAULT_*_BITS constants of ptsa-core/src/config.rs.
    #[arg(long, conflicts_with = "firmware_constants")]
    pub print_core_constants: bool,
    /// Print the firmware's constants file (firmware/src/constants.rs: the loop's
    /// configuration, the tick in Hz, the board's converter) for this instrument file;
    /// `cargo xtask constants` writes it. Refused for a loop the check refuses.
    #[arg(long)]
    pub firmware_constants: bool,
}

/// What to print.
pub enum Request {
    /// The design's text, the core constants and the verdict.
    All,
    /// Only the core constants.
    CoreConstants,
    /// The firmware's constants file.
    FirmwareConstants,
}

impl DesignArgs {
    /// The request (nothing to check).
    pub fn request(&self) -> Request {
        if self.print_core_constants {
            Request::CoreConstants
        } else if self.firmware_constants {
            Request::FirmwareConstants
        } else {
            Request::All
        }
    }
}

/// Print the design; then the verdict, or the loop check's refusal as the error.
///
/// # Errors
/// The loop check refuses the loop; stdout cannot be written.
pub fn run(ctx: &Ctx, req: &Request, out: &mut dyn Write) -> Result<()> {
    let d = Design::for_instrument(&ctx.instr);
    match req {
        Request::CoreConstants => write!(out, "{}", d.core_constants())?,
        Request::FirmwareConstants => {
            ctx.require_loop()?;
            let checked = match &ctx.checked {
                Ok(c) => c,
                Err(e) => bail!(
                    "{}: {e}; no firmware constants for a loop the check refuses",
                    ctx.name
                ),
            };
            write!(out, "{}", firmware_constants(ctx, checked)?)?;
            return Ok(());
        }
        Request::All => {
            write!(out, "{}", design::text(&ctx.instr))?;
            if let Some(b) = &ctx.instr.board {
                write!(out, "{}", board_text(&ctx.instr, b))?;
            }
            writeln!(out, "\n// ptsa-core/src/config.rs\n{}", d.core_constants())?;
        }
    }
    match &ctx.checked {
        Ok(c) => {
            if let Request::All = req {
                writeln!(
                    out,
                    "verdict: the loop is accepted (limit cycle {:.1} Hz)",
                    c.limit_cycle_hz
                )?;
            }
            Ok(())
        }
        Err(e) => bail!("{}: {e}", ctx.name),
    }
}

/// The board's front end as `ptsa design` prints it: the converter, the front end, the
/// full scale and step at the amplifier's output and in pendulum angle, the loop gain
/// against the design's 16-bit converter.
fn board_text(instr: &Instrument, b: &Board) -> String {
    let f = b.adc;
    let coding = match f.coding() {
        Coding::OffsetBinary => "offset binary, 0..V_REF",
        Coding::TwosComplement => "two's complement, ±V_REF/2",
    };
    let align = match f.alignment() {
        Alignment::Left => "left-aligned",
        Alignment::Right => "right-aligned",
    };
    let fs = b.full_scale_v();
    let step_v = fs / 32768.0 * f64::from(f.step());
    let step_rad = instr.theta_lsb_rad() * f64::from(f.step());
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\nboard ([board]): {}",
        b.name.as_deref().unwrap_or("(no name)")
    );
    let _ = writeln!(
        s,
        "  converter        = {} bits, {coding}, {align}, V_REF {} V",
        f.bits(),
        b.reference_v
    );
    let _ = writeln!(
        s,
        "  front end        = {} V/V and {} V from the amplifier's output to the pin",
        b.front_end_gain, b.front_end_offset_v
    );
    let _ = writeln!(
        s,
        "  full scale       = ±{fs:.6} V at the amplifier's output (V_REF / 2 / gain) = electronics.adc_full_scale_v: the designed loop gain"
    );
    let _ = writeln!(
        s,
        "  step             = {} units of the 16-bit sample = {:.4} mV at the amplifier's output = {:.4} µrad of pendulum angle",
        f.step(),
        step_v * 1e3,
        step_rad * 1e6
    );
    let _ = writeln!(
        s,
        "  mid-scale code   = {:.4} V at the pin for 0 V at the amplifier (front_end_offset_v; V_REF/2 = {:.4} V centres a unipolar converter)",
        b.front_end_offset_v,
        b.reference_v / 2.0
    );
    let _ = writeln!(
        s,
        "  torquer current  = {:.4} mA{}",
        instr.full_current_ma,
        if b.torquer_current_ma.is_some() {
            " (board.torquer_current_ma)"
        } else {
            " (nominal: SF / g × current scale factor)"
        }
    );
    s
}

/// The text of `firmware/src/constants.rs` for the loop of `ctx`: the tick, the loop's
/// configuration (the designed coefficients, a one-second gate) and the board's converter
/// (the design's signed 16-bit one for a file without `[board]`).
///
/// # Errors
/// The clock is not a whole number of hertz.
pub fn firmware_constants(ctx: &Ctx, checked: &LoopCheck) -> Result<String> {
    let instr = &ctx.instr;
    let clock = instr.clock_hz;
    if clock.fract() != 0.0 || !(1.0..=f64::from(u32::MAX)).contains(&clock) {
        bail!(
            "{}: electronics.clock_hz = {clock}: the firmware's tick timer needs a whole number of hertz",
            ctx.name
        );
    }
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let tick_hz = clock as u32;
    let c = checked.config;
    let m = checked.margins;
    let (adc, board) = match &instr.board {
        Some(b) => (b.adc, b.name.as_deref().unwrap_or("[board] without a name")),
        None => (
            AdcFormat::SIGNED_16,
            "none ([board] absent: the design's signed 16-bit converter)",
        ),
    };
    let coding = match adc.coding() {
        Coding::OffsetBinary => "OffsetBinary",
        Coding::TwosComplement => "TwosComplement",
    };
    let align = match adc.alignment() {
        Alignment::Left => "Left",
        Alignment::Right => "Right",
    };
    let file = ctx.name.replace('\\', "/");
    let u = underscore;
    Ok(format!(
        "//! The firmware's loop constants, generated by `cargo xtask constants` (`ptsa design\n\
         //! --firmware-constants`) from the instrument file\n\
         //! `{file}`: do not edit by hand.\n\
         //! CI fails when this file is not what the instrument file gives (a host test), and\n\
         //! `cargo xtask constants` writes it again.\n\
         //!\n\
         //! Board: {board}.\n\
         //! Loop (linear model): crossover {:.1} Hz, phase margin {:.1} deg, gain margin {:.1} dB;\n\
         //! limit cycle {:.1} Hz.\n\
         \n\
         use ptsa_core::adc::{{AdcFormat, Alignment, Coding}};\n\
         use ptsa_core::{{Coef, Config, Pole}};\n\
         \n\
         /// Tick (clock) frequency of the loop, Hz (`electronics.clock_hz`).\n\
         pub const TICK_HZ: u32 = {};\n\
         \n\
         /// The loop: the compensator designed for the instrument file and a one-second gate.\n\
         pub const CONFIG: Config = Config {{\n\
         \x20   ticks_per_cycle: {},\n\
         \x20   b0: Coef::from_bits({}),\n\
         \x20   b1: Coef::from_bits({}),\n\
         \x20   a1: Pole::from_bits({}),\n\
         \x20   ki: Coef::from_bits({}),\n\
         \x20   gate_ticks: {},\n\
         \x20   noise_shaping: {},\n\
         }};\n\
         \n\
         /// The converter whose data register the tick reads (`[board]` of the instrument file).\n\
         pub const ADC: AdcFormat = match AdcFormat::new({}, Coding::{coding}, Alignment::{align}) {{\n\
         \x20   Some(f) => f,\n\
         \x20   None => panic!(\"the converter has 1 to 16 bits\"),\n\
         }};\n",
        m.crossover_hz,
        m.phase_margin_deg,
        m.gain_margin_db,
        checked.limit_cycle_hz,
        u(i64::from(tick_hz)),
        c.ticks_per_cycle,
        u(i64::from(c.b0.to_bits())),
        u(i64::from(c.b1.to_bits())),
        u(i64::from(c.a1.to_bits())),
        u(i64::from(c.ki.to_bits())),
        u(i64::from(tick_hz)),
        c.noise_shaping,
        adc.bits(),
    ))
}
