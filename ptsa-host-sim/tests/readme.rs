//! The README as a user meets it: every command of its `sh` blocks run as written, every
//! output it shows checked against what the command printed, its shipped example files
//! remade by the script that made them, and its length kept to a quick start's.
//!
//! The blocks run in `sh` from a fresh folder that holds `data` (a link to the repository's)
//! as the repository's root would, so `scratch/` and `report/` land in that folder. The
//! one stand-in: `cargo ptsa ARGS` runs this build's `ptsa` with ARGS, which is what the
//! workspace's alias (`.cargo/config.toml`) runs. `cargo xtask CMD` lines are checked to be
//! commands `cargo xtask ci` itself runs (this test is one of its steps), never skipped in
//! silence: any other `cargo xtask` line fails the test.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `cargo xtask` commands the README may show, each run by `cargo xtask ci` in full:
/// `ci` is that run; `firmware` (no options) is its firmware step (`firmware::ci` is
/// `firmware::run` without options, xtask/src/firmware.rs).
const RUN_BY_CI: [&str; 2] = ["ci", "firmware"];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).unwrap()
}

/// One fenced block: its info string (`sh`, `text`, ...), its first line number, its text.
struct Block {
    lang: String,
    line: usize,
    text: String,
}

fn blocks(page: &str, md: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<Block> = None;
    for (i, l) in md.lines().enumerate() {
        match (&mut open, l.strip_prefix("```")) {
            (None, Some(lang)) => {
                open = Some(Block {
                    lang: lang.trim().to_string(),
                    line: i + 1,
                    text: String::new(),
                });
            }
            (Some(_), Some("")) => out.push(open.take().unwrap()),
            (Some(b), _) => {
                b.text.push_str(l);
                b.text.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "{page}: a fenced block is not closed");
    out
}

/// `expected` (one line of a `text` block, `…` for what it leaves out) appears in `output`:
/// its pieces between the ellipses, in order, on one line.
fn shown_in(expected: &str, output: &str) -> bool {
    let pieces: Vec<&str> = expected
        .split('…')
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .collect();
    output.lines().any(|line| {
        let mut at = 0;
        pieces.iter().all(|p| match line[at..].find(p) {
            Some(k) => {
                at += k + p.len();
                true
            }
            None => false,
        })
    })
}

/// Runs one `sh` block in `dir`: the combined stdout and stderr; panics if it fails.
fn run_block(dir: &Path, block: &Block, xtask_log: &Path, page: &str) -> String {
    let script = format!(
        "set -e\n\
         cargo() {{\n\
           case \"$1\" in\n\
             ptsa) shift; \"$PTSA\" \"$@\" ;;\n\
             xtask) shift; echo \"$*\" >> \"$XTASK_LOG\" ;;\n\
             *) echo \"the page runs cargo $*: not a command this test knows\" >&2; return 2 ;;\n\
           esac\n\
         }}\n{}",
        block.text
    );
    let out = Command::new("sh")
        .arg("-c")
        .arg(&script)
        .current_dir(dir)
        .env("PTSA", env!("CARGO_BIN_EXE_ptsa"))
        .env("XTASK_LOG", xtask_log)
        .output()
        .expect("sh runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success(),
        "{page} line {}: the block failed ({}):\n{}\n{text}",
        block.line,
        out.status,
        block.text
    );
    text
}

/// Runs every `sh` block of `page` (a path from the repository's root) in a fresh folder
/// and checks each `text` block against the output of the block before it; the folder.
fn run_page(page: &str, min_blocks: usize) -> tempfile::TempDir {
    let md = std::fs::read_to_string(root().join(page)).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::os::unix::fs::symlink(root().join("data"), dir.join("data")).unwrap();
    let xtask_log = dir.join("xtask.log");
    let mut last_output: Option<(usize, String)> = None;
    let mut ran = 0;
    for b in blocks(page, &md) {
        match b.lang.as_str() {
            "sh" => {
                last_output = Some((b.line, run_block(dir, &b, &xtask_log, page)));
                ran += 1;
            }
            "text" => {
                let (at, output) = last_output
                    .as_ref()
                    .unwrap_or_else(|| panic!("{page} line {}: output before any command", b.line));
                for (k, l) in b.text.lines().enumerate() {
                    assert!(
                        l.trim().is_empty() || shown_in(l, output),
                        "{page} line {}: not in the output of the block at line {at}:\n{l}\n\
                         --- the output ---\n{output}",
                        b.line + 1 + k
                    );
                }
            }
            _ => {}
        }
    }
    assert!(ran >= min_blocks, "{page}: only {ran} sh blocks run");
    let xtask = std::fs::read_to_string(&xtask_log).unwrap_or_default();
    for cmd in xtask.lines() {
        assert!(
            RUN_BY_CI.contains(&cmd.trim()),
            "{page} shows `cargo xtask {cmd}`, which `cargo xtask ci` does not run: run it \
             here or leave it out"
        );
    }
    tmp
}

#[test]
fn every_sh_block_runs_as_written_and_prints_what_the_readme_shows() {
    let tmp = run_page("README.md", 6);
    let dir = tmp.path();
    assert!(dir.join("scratch/sn3/sn3.md").is_file());
    assert!(dir.join("scratch/allan.png").is_file());
    assert!(dir.join("report").is_dir(), "the main job wrote no report/");
}

/// The guides' pages: every `sh` block runs as written and prints what the page shows.
#[test]
fn every_guide_runs_as_written() {
    let mut pages = guides();
    pages.sort();
    assert!(pages.len() >= 3, "{pages:?}");
    for page in &pages {
        let tmp = run_page(page, 3);
        assert!(
            tmp.path().join("scratch").is_dir(),
            "{page} wrote nothing into scratch/"
        );
    }
}

/// `docs/guide/*.md`, as paths from the repository's root.
fn guides() -> Vec<String> {
    std::fs::read_dir(root().join("docs/guide"))
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            std::path::Path::new(&name)
                .extension()
                .is_some_and(|x| x == "md")
                .then(|| format!("docs/guide/{name}"))
        })
        .collect()
}

/// The prose outside code blocks and tables, one paragraph per item.
fn paragraphs(md: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut fenced = false;
    for l in md.lines() {
        if l.starts_with("```") {
            fenced = !fenced;
            out.push(String::new());
        } else if fenced || l.starts_with('#') || l.starts_with('|') || l.trim().is_empty() {
            out.push(String::new());
        } else {
            let p = out.last_mut().unwrap();
            p.push(' ');
            p.push_str(l.trim());
        }
    }
    out.retain(|p| !p.trim().is_empty());
    out
}

#[test]
fn the_readme_is_a_quick_start() {
    let md = readme();
    let words = md.split_whitespace().count();
    assert!(words <= 1500, "README.md has {words} words (at most 1500)");
    let first = md.lines().position(|l| l == "```sh").expect("a command") + 2;
    assert!(
        first <= 40,
        "the first command is on line {first} (at most 40)"
    );
    short_sentences("README.md", &md);
}

/// Every sentence of `md`'s prose has at most 40 words.
fn short_sentences(page: &str, md: &str) {
    for p in paragraphs(md) {
        for s in sentences(&p) {
            let n = s.split_whitespace().count();
            assert!(n <= 40, "{page}: a sentence of {n} words (at most 40):{s}");
        }
    }
}

/// `p` cut into sentences: each ends at '.', '?' or '!' followed by a space or the end; a
/// dot inside a name or a number (`sn3.json`, `0.2`) has no space after it.
fn sentences(p: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = 0;
    let mut chars = p.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        let end = chars.peek().is_none_or(|(_, n)| n.is_whitespace());
        if matches!(c, '.' | '?' | '!') && end {
            out.push(&p[start..i + c.len_utf8()]);
            start = i + c.len_utf8();
        }
    }
    if start < p.len() {
        out.push(&p[start..]);
    }
    out
}

#[test]
fn a_dot_inside_a_name_or_a_number_ends_no_sentence() {
    assert_eq!(
        sentences("Write sn3.json with 0.2 s. Then stop! Or not"),
        ["Write sn3.json with 0.2 s.", " Then stop!", " Or not"]
    );
}

/// The pages written by hand for users: the guides, the method pages, the reference pages
/// that are not generated (a generated one opens with `# Reference:`), the docs' index and
/// ARCHITECTURE.md. The figures' pages and the contributors' notes are not among them.
fn user_pages() -> Vec<String> {
    let mut pages = guides();
    for dir in ["docs/method", "docs/reference"] {
        for e in std::fs::read_dir(root().join(dir)).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            let page = format!("{dir}/{name}");
            let markdown = std::path::Path::new(&name)
                .extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("md"));
            if markdown
                && !std::fs::read_to_string(root().join(&page))
                    .unwrap()
                    .starts_with("# Reference:")
            {
                pages.push(page);
            }
        }
    }
    pages.extend(["docs/README.md", "ARCHITECTURE.md", "python/README.md"].map(String::from));
    pages
}

#[test]
fn the_user_pages_sentences_are_short() {
    let pages = user_pages();
    assert!(pages.len() >= 12, "{pages:?}");
    for page in pages {
        short_sentences(&page, &std::fs::read_to_string(root().join(&page)).unwrap());
    }
}

#[test]
fn the_shipped_plans_are_what_ptsa_plan_writes() {
    let tmp = tempfile::tempdir().unwrap();
    for (file, n) in [("tumble-plan.csv", "24"), ("check-plan.csv", "8")] {
        let o = common::ptsa_in(
            tmp.path(),
            &[
                "plan",
                "tumble",
                "--positions",
                n,
                "--count-columns",
                "--output",
                file,
            ],
        );
        assert!(o.status.success(), "{}", common::stderr(&o));
        let made = std::fs::read_to_string(tmp.path().join(file)).unwrap();
        let shipped = std::fs::read_to_string(root().join("data/examples").join(file)).unwrap();
        assert_eq!(
            made, shipped,
            "data/examples/{file} differs from `ptsa plan`'s"
        );
    }
}

#[test]
fn the_shipped_examples_are_what_the_script_makes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("examples");
    let run = Command::new("python3")
        .arg(root().join("scripts/examples.py"))
        .arg(&out)
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run python3 ({e}): install Python 3 (Debian: apt-get install python3)")
        });
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let mut made = 0;
    for e in std::fs::read_dir(&out).unwrap() {
        let name = e.unwrap().file_name();
        let fresh = std::fs::read(out.join(&name)).unwrap();
        let shipped = std::fs::read(root().join("data/examples").join(&name))
            .unwrap_or_else(|_| panic!("{name:?} is made but not shipped in data/examples/"));
        assert!(
            fresh == shipped,
            "data/examples/{name:?} differs from scripts/examples.py's"
        );
        made += 1;
    }
    assert_eq!(made, 4);
}

/// Every relative link of the user docs (README.md, ARCHITECTURE.md, data/README.md and
/// docs/, the notes and the generated reference included) names a file that exists.
#[test]
fn every_relative_link_in_the_docs_resolves() {
    fn markdown(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                markdown(&p, out);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let root = root();
    let mut files = vec![
        root.join("README.md"),
        root.join("ARCHITECTURE.md"),
        root.join("data/README.md"),
    ];
    markdown(&root.join("docs"), &mut files);
    let mut checked = 0;
    let mut broken = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (k, _) in text.match_indices("](") {
            let rest = &text[k + 2..];
            let Some(end) = rest.find(')') else { continue };
            let target = rest[..end].split('#').next().unwrap_or("");
            if target.is_empty() || target.contains("://") || target.contains(' ') {
                continue;
            }
            checked += 1;
            if !f.parent().unwrap().join(target).exists() {
                broken.push(format!("{}: {target}", f.display()));
            }
        }
    }
    assert!(
        broken.is_empty(),
        "links to nothing:\n{}",
        broken.join("\n")
    );
    assert!(checked > 30, "only {checked} links checked");
}
