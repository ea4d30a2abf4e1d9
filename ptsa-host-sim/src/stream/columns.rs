//! A CSV of numeric columns read fast: the header found after `#` and blank lines, then
//! the named columns of every row parsed in parallel, in blocks of whole lines. Every
//! refusal names the file, the line and, for a cell, the column (1-based, in characters).
//! Used by `noise --readings` (`time_s`, `reading`) and by a raw stream (`time_s` and
//! three axes' readings).

use anyhow::{Result, bail};
use rayon::prelude::*;

/// The header row and the text after it.
pub struct Header<'a> {
    /// Its 1-based line.
    pub line: usize,
    /// Its cells, trimmed.
    pub cells: Vec<&'a str>,
    /// The text after the header.
    pub body: &'a str,
    /// The line `body` starts on.
    pub body_line: usize,
}

impl Header<'_> {
    /// The index of column `name`, if the header has it.
    #[must_use]
    pub fn find(&self, name: &str) -> Option<usize> {
        self.cells.iter().position(|c| *c == name)
    }

    /// The header as written (its cells joined by commas).
    #[must_use]
    pub fn text(&self) -> String {
        self.cells.join(",")
    }

    /// The line of the `k`-th data row (blank and `#` lines are not rows): the slow path,
    /// for a message.
    #[must_use]
    pub fn line_of(&self, k: usize) -> usize {
        let mut seen = 0;
        for (j, l) in self.body.lines().enumerate() {
            let t = l.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            if seen == k {
                return self.body_line + j;
            }
            seen += 1;
        }
        self.body_line
    }
}

/// The header of `text` (a byte-order mark, blank and `#` lines before it skipped).
///
/// # Errors
/// No line but comments: `expected` says what the header should be.
pub fn header<'a>(name: &str, text: &'a str, expected: &str) -> Result<Header<'a>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut rest = text;
    let mut line = 0;
    loop {
        line += 1;
        let (l, next) = rest.split_once('\n').unwrap_or((rest, ""));
        let t = l.trim();
        if t.is_empty() || t.starts_with('#') {
            if next.is_empty() {
                bail!("{name}: no header; expected a first line {expected}");
            }
            rest = next;
            continue;
        }
        return Ok(Header {
            line,
            cells: t.split(',').map(str::trim).collect(),
            body: next,
            body_line: line + 1,
        });
    }
}

/// The columns `at` (header indices) of every row of `h`'s body, in the order of `at`;
/// `what[i]` names column `at[i]` in the errors ("the `time_s`, s").
///
/// # Errors
/// A cell that is not a finite number (line and column); a row with fewer cells than the
/// last column wanted.
pub fn columns(name: &str, h: &Header<'_>, at: &[usize], what: &[&str]) -> Result<Vec<Vec<f64>>> {
    let blocks = blocks(h.body, 1 << 20);
    // Each block's first line number: the newlines before it.
    let mut starts = Vec::with_capacity(blocks.len());
    let mut line = h.body_line;
    for b in &blocks {
        starts.push(line);
        line += memchr::memchr_iter(b'\n', b.as_bytes()).count();
    }
    let parsed: Vec<Vec<Vec<f64>>> = blocks
        .par_iter()
        .zip(starts.par_iter())
        .map(|(b, &start)| parse_block(name, b, start, at, what))
        .collect::<Result<_>>()?;
    let n: usize = parsed.iter().map(|b| b[0].len()).sum();
    let mut out: Vec<Vec<f64>> = at.iter().map(|_| Vec::with_capacity(n)).collect();
    for b in parsed {
        for (o, c) in out.iter_mut().zip(b) {
            o.extend_from_slice(&c);
        }
    }
    Ok(out)
}

/// `text` cut into blocks of about `size` bytes, each ending at a line's end.
fn blocks(text: &str, size: usize) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        if rest.len() <= size {
            out.push(rest);
            break;
        }
        let cut =
            memchr::memchr(b'\n', &rest.as_bytes()[size..]).map_or(rest.len(), |k| size + k + 1);
        out.push(&rest[..cut]);
        rest = &rest[cut..];
    }
    out
}

/// A cell as a finite number: trimmed only when it needs it.
fn number(cell: &str) -> Option<f64> {
    let b = cell.as_bytes();
    let cell = if b.first().is_some_and(u8::is_ascii_whitespace)
        || b.last().is_some_and(u8::is_ascii_whitespace)
    {
        cell.trim()
    } else {
        cell
    };
    cell.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// The columns `at` of the rows of one block starting on line `start`.
fn parse_block(
    name: &str,
    block: &str,
    start: usize,
    at: &[usize],
    what: &[&str],
) -> Result<Vec<Vec<f64>>> {
    let want = at.iter().max().map_or(0, |m| m + 1);
    // The slot of each cell index, if it is wanted.
    let mut slot = vec![None; want];
    for (i, &c) in at.iter().enumerate() {
        slot[c] = Some(i);
    }
    let mut out: Vec<Vec<f64>> = at
        .iter()
        .map(|_| Vec::with_capacity(block.len() / (8 * at.len() + 8)))
        .collect();
    let bytes = block.as_bytes();
    let (mut pos, mut line) = (0, start);
    let mut row = vec![0.0; at.len()];
    while pos < bytes.len() {
        let end = memchr::memchr(b'\n', &bytes[pos..]).map_or(bytes.len(), |k| pos + k);
        let l = block[pos..end]
            .strip_suffix('\r')
            .unwrap_or(&block[pos..end]);
        pos = end + 1;
        let here = line;
        line += 1;
        let first = l.as_bytes().iter().position(|b| !b.is_ascii_whitespace());
        if first.is_none_or(|k| l.as_bytes()[k] == b'#') {
            continue;
        }
        let (mut j, mut from, mut got) = (0, 0, 0);
        loop {
            let to = memchr::memchr(b',', &l.as_bytes()[from..]).map_or(l.len(), |k| from + k);
            if let Some(i) = slot[j] {
                let cell = &l[from..to];
                let Some(v) = number(cell) else {
                    let col = l[..from].chars().count() + 1;
                    bail!(
                        "{name}:{here}:{col}: `{}` is not a finite number; expected {}",
                        cell.trim(),
                        what[i]
                    );
                };
                row[i] = v;
                got += 1;
            }
            j += 1;
            if to >= l.len() || j >= want {
                break;
            }
            from = to + 1;
        }
        if got < at.len() {
            bail!(
                "{name}:{here}: {j} cells; expected at least {want} (the header's {})",
                what.iter()
                    .map(|w| w.split(',').next().unwrap_or(w).trim_start_matches("the "))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        for (o, v) in out.iter_mut().zip(&row) {
            o.push(*v);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::fmt::Write as _;

    use super::*;

    #[test]
    fn columns_are_read_in_the_order_asked_across_blocks() {
        let mut text = String::from("\u{feff}# c\n\n a , t ,b\n");
        for k in 0..200_000 {
            let _ = writeln!(text, "{k},{},{}", k * 2, k % 3);
            if k == 7 {
                text.push_str("# a comment row\n");
            }
        }
        let h = header("f.csv", &text, "`t,a`").unwrap();
        assert_eq!((h.line, h.cells.clone()), (3, vec!["a", "t", "b"]));
        let c = columns("f.csv", &h, &[1, 0], &["the t", "the a"]).unwrap();
        assert_eq!(c[0].len(), 200_000);
        assert_eq!((c[0][199_999], c[1][199_999]), (399_998.0, 199_999.0));
        assert_eq!(h.line_of(8), 13);
        let bad = text.replacen("150000,300000", "150000,x", 1);
        let h = header("f.csv", &bad, "`t,a`").unwrap();
        let e = columns("f.csv", &h, &[1, 0], &["the t, s", "the a"])
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "f.csv:150005:8: `x` is not a finite number; expected the t, s"
        );
        let h = header("f.csv", "a,t,b\n1,2\n", "`t,a`").unwrap();
        let e = columns("f.csv", &h, &[2], &["the b"])
            .unwrap_err()
            .to_string();
        assert_eq!(e, "f.csv:2: 2 cells; expected at least 3 (the header's b)");
        let e = header("f.csv", "# only\n", "`t,a`")
            .err()
            .unwrap()
            .to_string();
        assert_eq!(e, "f.csv: no header; expected a first line `t,a`");
    }
}
