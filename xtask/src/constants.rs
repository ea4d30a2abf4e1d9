//! `cargo xtask constants`: write the firmware's generated constants
//! (`firmware/src/constants.rs`) from an instrument file, or check that they are fresh.

use std::process::Stdio;

use crate::util::{self, Error};

/// `cargo xtask constants --help`.
pub const USAGE: &str = "\
constants [--instrument FILE] [--check]
    Write firmware/src/constants.rs (the firmware's tick, loop configuration and
    converter) from the instrument file (default data/kearfott-2401-discovery.toml, the
    Kearfott 2401 on the STM32F407 Discovery): the text `ptsa design --firmware-constants
    --instrument FILE` prints (it builds and runs the release `ptsa`). The file appears
    whole (written beside, then renamed).
    --instrument FILE  the instrument file, relative to the repository root or absolute
    --check            write nothing; fail (exit 1) naming the first differing line when
                       the checked-in file is not what the instrument file gives (CI runs
                       the same comparison as a host test)";

/// The instrument file the firmware's constants are made from by default.
pub const DEFAULT_INSTRUMENT: &str = "data/kearfott-2401-discovery.toml";
/// The generated file, relative to the repository root.
pub const CONSTANTS_RS: &str = "firmware/src/constants.rs";

/// `cargo xtask constants [--instrument FILE] [--check]`.
pub fn run(args: &[String]) -> Result<(), Error> {
    let mut instrument = DEFAULT_INSTRUMENT.to_string();
    let mut check = false;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--instrument" => {
                instrument.clone_from(
                    it.next()
                        .ok_or_else(|| Error::Usage("--instrument needs a file".into()))?,
                );
            }
            "--check" => check = true,
            other => return Err(Error::Usage(format!("unknown option `{other}`"))),
        }
    }
    let root = util::root();
    let generated = generate(&instrument)?;
    let path = root.join(CONSTANTS_RS);
    if check {
        let on_disk = std::fs::read_to_string(&path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        compare(&on_disk, &generated, &instrument)?;
        eprintln!("{CONSTANTS_RS} is what {instrument} gives");
        return Ok(());
    }
    let tmp = path.with_extension("rs.tmp");
    std::fs::write(&tmp, &generated).map_err(|e| format!("cannot write {}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("cannot replace {}: {e}", path.display())
    })?;
    eprintln!("wrote {CONSTANTS_RS} from {instrument}");
    Ok(())
}

/// What `ptsa design --firmware-constants --instrument FILE` prints, run in the repository
/// root (so that a relative `FILE` is named as given in the file's header).
fn generate(instrument: &str) -> Result<String, String> {
    let out = util::ptsa_release(&["--instrument", instrument, "design", "--firmware-constants"])
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`ptsa design --firmware-constants --instrument {instrument}` failed ({})",
            out.status
        ));
    }
    String::from_utf8(out.stdout).map_err(|_| "ptsa printed something that is not UTF-8".into())
}

/// `Ok` when the checked-in text is the generated one; else the first differing line and
/// the command that writes the file again.
pub fn compare(on_disk: &str, generated: &str, instrument: &str) -> Result<(), String> {
    if on_disk == generated {
        return Ok(());
    }
    let line = on_disk
        .lines()
        .zip(generated.lines())
        .position(|(a, b)| a != b)
        .map_or_else(
            || on_disk.lines().count().min(generated.lines().count()) + 1,
            |i| i + 1,
        );
    let show = |t: &str| {
        t.lines()
            .nth(line - 1)
            .map_or("<end of file>".to_string(), |l| format!("`{}`", l.trim()))
    };
    Err(format!(
        "{CONSTANTS_RS} is stale: line {line} is {}, {instrument} gives {}; run `cargo xtask \
         constants{}` and commit the file",
        show(on_disk),
        show(generated),
        if instrument == DEFAULT_INSTRUMENT {
            String::new()
        } else {
            format!(" --instrument {instrument}")
        }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stale_constants_file_is_refused_with_the_command_that_regenerates_it() {
        let fresh = "//! x\npub const TICK_HZ: u32 = 64_000;\npub const B0: i32 = 1;\n";
        assert!(compare(fresh, fresh, DEFAULT_INSTRUMENT).is_ok());
        let stale = fresh.replace("B0: i32 = 1", "B0: i32 = 2");
        let e = compare(&stale, fresh, DEFAULT_INSTRUMENT).unwrap_err();
        assert!(e.contains("line 3 is `pub const B0: i32 = 2;`"), "{e}");
        assert!(e.contains("gives `pub const B0: i32 = 1;`"), "{e}");
        assert!(e.contains("run `cargo xtask constants` and commit"), "{e}");
        let e = compare(&stale, fresh, "my.toml").unwrap_err();
        assert!(
            e.contains("`cargo xtask constants --instrument my.toml`"),
            "{e}"
        );
        // A file cut short.
        let e = compare("//! x\n", fresh, DEFAULT_INSTRUMENT).unwrap_err();
        assert!(e.contains("line 2 is <end of file>"), "{e}");
    }

    #[test]
    fn the_checked_in_file_is_what_the_compiled_constants_hold() {
        // The file xtask compiles (`firmware::constants`) is the checked-in one: its loop is
        // one ptsa-core accepts and its tick divides the board's and QEMU's timer clocks.
        let c = crate::firmware::constants::CONFIG;
        assert!(c.build().is_ok());
        assert_eq!(80_000_000 % crate::firmware::constants::TICK_HZ, 0);
        assert_eq!(1_000_000_000 % crate::firmware::constants::TICK_HZ, 0);
    }
}
