//! Faults, panics and exit of the three images, written once.
//!
//! As in knurling's app-template, there is one `HardFault` handler, one panic path and one
//! [`exit`]. What differs between the images is only where they report to, so each image
//! picks its reporting with one line, [`image_runtime!`](crate::image_runtime):
//!
//! * `image_runtime!(defmt)`, the production image `ptsa`: defmt over RTT (`defmt-rtt`).
//!   A panic goes through `panic-probe`, which logs the message with defmt and executes
//!   `udf`, i.e. ends in the same `HardFault` handler; that one logs the PC and LR with
//!   defmt, then halts on a breakpoint for the debugger on the board, or exits QEMU with
//!   status 70 when built with the `qemu` feature.
//! * `image_runtime!(semihosting, "<name>")`, the QEMU test images `golden` and `budget`:
//!   text on semihosting standard error, prefixed with the image's name. `HardFault`
//!   prints the PC and exits QEMU with status 70; a panic prints its message and exits with
//!   101.
//!
//! The selection is a macro rather than a cargo feature because the three images are one
//! package built in one `cargo build`: features would apply to all of them. The handlers
//! are items of the image that expands the macro, so an image links only its own
//! reporting (the test images link no defmt logger, the production image no panic
//! message formatting of its own).

pub use cortex_m_rt::{ExceptionFrame, exception};

/// Exit status of an image stopped by a `HardFault` (`EX_SOFTWARE` of sysexits.h).
pub const HARD_FAULT_STATUS: i32 = 70;
/// Exit status of a test image after a panic (as Rust's own).
pub const PANIC_STATUS: i32 = 101;

/// Leave the image: exit QEMU with `status` through semihosting.
///
/// Only for images run under QEMU (the test images, and the production image with the
/// `qemu` feature): on a board without a debugger attached a semihosting call itself
/// faults, so the board image never exits (its faults halt on a breakpoint instead).
pub fn exit(status: i32) -> ! {
    semihosting::process::exit(status)
}

/// `HardFault` of an image that reports over defmt (`image_runtime!(defmt)`).
pub fn defmt_hard_fault(ef: &ExceptionFrame) -> ! {
    defmt::error!("HardFault: pc={=u32:#x} lr={=u32:#x}", ef.pc(), ef.lr());
    #[cfg(feature = "qemu")]
    exit(HARD_FAULT_STATUS);
    #[cfg(not(feature = "qemu"))]
    loop {
        // Halt for the debugger (probe-rs reports the breakpoint and the log above).
        cortex_m::asm::bkpt();
    }
}

/// `HardFault` of a test image (`image_runtime!(semihosting, image)`).
pub fn semihosting_hard_fault(image: &str, ef: &ExceptionFrame) -> ! {
    semihosting::eprintln!("{}: HardFault at pc={:#010x}", image, ef.pc());
    exit(HARD_FAULT_STATUS)
}

/// Panic of a test image (`image_runtime!(semihosting, image)`).
pub fn semihosting_panic(image: &str, info: &core::panic::PanicInfo<'_>) -> ! {
    semihosting::eprintln!("{}: panic: {}", image, info);
    exit(PANIC_STATUS)
}

/// Define an image's `HardFault` handler and panic path, reporting over defmt (the
/// production image) or semihosting (the QEMU test images); see [`rt`](crate::rt).
///
/// ```ignore
/// ptsa_firmware::image_runtime!(defmt); // production image: defmt-rtt, panic-probe
/// ptsa_firmware::image_runtime!(semihosting, "golden"); // test image named `golden`
/// ```
#[macro_export]
macro_rules! image_runtime {
    (defmt) => {
        use defmt_rtt as _;
        // Logs the panic message with defmt, then `udf`: the HardFault below.
        use panic_probe as _;
        $crate::image_runtime!(@hard_fault |ef| $crate::rt::defmt_hard_fault(ef));
    };
    (semihosting, $image:literal) => {
        $crate::image_runtime!(@hard_fault |ef| $crate::rt::semihosting_hard_fault($image, ef));
        #[panic_handler]
        fn panic(info: &::core::panic::PanicInfo<'_>) -> ! {
            $crate::rt::semihosting_panic($image, info)
        }
    };
    (@hard_fault |$ef:ident| $report:expr) => {
        // cortex-m-rt requires the HardFault handler to be an `unsafe fn`; its body is a call
        // of a safe function.
        #[allow(unsafe_code)]
        #[$crate::rt::exception]
        unsafe fn HardFault($ef: &$crate::rt::ExceptionFrame) -> ! {
            $report
        }
    };
}
