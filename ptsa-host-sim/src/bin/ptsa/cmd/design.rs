//! `ptsa design`: the compensator designed for the instrument file, the loop's margins and
//! the ptsa-core constants, with the loop check's verdict. It runs for a loop the simulator
//! refuses too (printing the design, then the refusal).

use std::io::Write;

use anyhow::{Result, bail};
use clap::Args;
use ptsa_host_sim::model::design::Design;
use ptsa_host_sim::report::experiments::design;

use super::Ctx;

/// Arguments of `ptsa design`.
#[derive(Args, Debug, Clone)]
pub struct DesignArgs {
    /// Print only the four DEFAULT_*_BITS constants of ptsa-core/src/config.rs.
    #[arg(long)]
    pub print_core_constants: bool,
}

/// What to print.
pub enum Request {
    /// The design's text, the core constants and the verdict.
    All,
    /// Only the core constants.
    CoreConstants,
}

impl DesignArgs {
    /// The request (nothing to check).
    pub fn request(&self) -> Request {
        if self.print_core_constants {
            Request::CoreConstants
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
        Request::All => {
            write!(out, "{}", design::text(&ctx.instr))?;
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
