//! Test image for QEMU (`netduinoplus2`): bit-exactness of one golden vector on the
//! emulated Cortex-M4.
//!
//! Semihosting command line: `golden <input> <output>`, paths relative to QEMU's working
//! directory. Streams `<input>` (a `tests/golden/*.in` file) in 1 KiB chunks through
//! [`ptsa_core::trace::GoldenRunner`], the same code the host test uses, and writes the
//! output text to `<output>` for the host to compare with the `.out` file. Same ptsa-core,
//! profile and `memory.x` as the production image. Exits QEMU with status 0, or 1 with a
//! message on standard error.
#![no_std]
#![no_main]
#![deny(unsafe_code)]

use cortex_m_rt::entry;
use ptsa_firmware::rt::exit;
use ptsa_firmware::testimage::{Failure, PATH, golden_pass, next_path};
use semihosting::eprintln;

// Reports on semihosting standard error; HardFault exits 70, a panic 101.
ptsa_firmware::image_runtime!(semihosting, "golden");

#[entry]
fn main() -> ! {
    match run() {
        Ok(()) => exit(0),
        Err(Failure) => exit(1),
    }
}

fn run() -> Result<(), Failure> {
    let Ok(args) = semihosting::experimental::env::args::<{ 2 * PATH }>() else {
        eprintln!("golden: cannot read the semihosting command line");
        return Err(Failure);
    };
    let mut it = (&args).into_iter();
    let _program = it.next();
    let input = next_path(&mut it, "input")?;
    let output = next_path(&mut it, "output")?;
    golden_pass(input.as_cstr(), output.as_cstr())
}
