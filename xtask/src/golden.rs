//! Golden vectors.

/// `cargo xtask golden [--overwrite]`.
pub fn run(_args: &[String]) -> Result<(), String> {
    Err("not yet".to_string())
}
