//! Placeholder (criterion benchmark follows).
fn main() {}
