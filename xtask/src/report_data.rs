//! `cargo xtask report-data`: write the report's tables again in the case-frame format
//! (`data/r890-table-6.*.case.csv`), a maintainer's task after the transcriptions or the
//! format change.

use crate::util::{self, Error};

/// `cargo xtask report-data --help`.
pub const USAGE: &str = "\
report-data
    Write data/r890-table-6.{1,2,3}.case.csv again from the report's transcriptions
    (data/r890-*.csv) with the release `ptsa` (its hidden `discover --convert-report-data
    data`). A host test fails when the checked-in files are not what this writes.";

/// `cargo xtask report-data`.
pub fn run(args: &[String]) -> Result<(), Error> {
    if let Some(a) = args.first() {
        return Err(Error::Usage(format!("unknown option `{a}`")));
    }
    let status = util::ptsa_release(&["discover", "--convert-report-data", "data"])
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("`ptsa discover --convert-report-data data` failed ({status})").into());
    }
    Ok(())
}
