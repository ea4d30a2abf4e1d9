//! The full hidden-effect campaign (filled in by the discovery work).

/// `cargo xtask hidden [--sets N]`.
pub fn run(_args: &[String]) -> Result<(), String> {
    Err("the hidden-effect campaign is not implemented yet".to_string())
}
