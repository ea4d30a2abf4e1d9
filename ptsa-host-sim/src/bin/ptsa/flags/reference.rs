//! `docs/reference/options.md`, written from the command line's own definition (clap's
//! `Cli::command()`): every subcommand, every option with its value, default and help. The
//! test fails when the checked-in page is not what this writes; `PTSA_WRITE_REFERENCE=1`
//! rewrites it instead.

use std::fmt::Write as _;

use clap::CommandFactory as _;

use super::Cli;

/// One line of help text: clap's long help with its line breaks and `|` made table-safe.
fn cell(text: &str) -> String {
    text.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
}

/// An option as it is typed: `-o, --output FILE`.
fn spelling(a: &clap::Arg) -> String {
    let mut s = String::new();
    if let Some(c) = a.get_short() {
        let _ = write!(s, "-{c}, ");
    }
    if let Some(l) = a.get_long() {
        let _ = write!(s, "--{l}");
    }
    if a.get_action().takes_values()
        && let Some(v) = a.get_value_names().and_then(|v| v.first())
    {
        let _ = write!(s, " {v}");
    }
    s
}

/// The section of one command and, after it, each of its subcommands'.
fn section(out: &mut String, cmd: &clap::Command, path: &str) {
    let _ = writeln!(out, "## `{path}`\n");
    if let Some(about) = cmd.get_about() {
        let _ = writeln!(out, "{}\n", cell(&about.to_string()));
    }
    let args: Vec<&clap::Arg> = cmd
        .get_arguments()
        .filter(|a| !a.is_hide_set() && a.get_long().is_some() && a.get_id() != "help")
        .collect();
    if !args.is_empty() {
        out.push_str("| option | default | meaning |\n|---|---|---|\n");
        for a in args {
            let default: Vec<String> = a
                .get_default_values()
                .iter()
                .map(|v| v.to_string_lossy().into_owned())
                .collect();
            let help = a
                .get_long_help()
                .or_else(|| a.get_help())
                .map(ToString::to_string);
            let _ = writeln!(
                out,
                "| `{}` | {} | {} |",
                spelling(a),
                if default.is_empty() {
                    String::new()
                } else {
                    format!("`{}`", default.join(","))
                },
                cell(&help.unwrap_or_default())
            );
        }
        out.push('\n');
    }
    for sub in cmd
        .get_subcommands()
        .filter(|s| !s.is_hide_set() && s.get_name() != "help")
    {
        section(out, sub, &format!("{path} {}", sub.get_name()));
    }
}

/// The page.
pub fn page() -> String {
    let mut out = String::from(
        "# Reference: every option\n\n\
         Generated from the command line's definition by the test \
         `flags::reference::tests::the_options_page_is_current` (`PTSA_WRITE_REFERENCE=1 cargo \
         test -p ptsa-host-sim --bin ptsa reference` writes it again). `ptsa SUBCOMMAND --help` \
         prints the same text. Old spellings kept for one release are not listed \
         ([conventions.md](conventions.md)).\n\n",
    );
    let cmd = Cli::command();
    section(&mut out, &cmd, "ptsa");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_options_page_is_current() {
        assert!(
            ptsa_host_sim::output::reference_page_is_current("options.md", &page()),
            "docs/reference/options.md is not what the command line defines: \
             PTSA_WRITE_REFERENCE=1 cargo test -p ptsa-host-sim --bin ptsa reference"
        );
    }
}
