//! Rewriting an instrument file: new values for some entries, everything else kept. The file
//! is edited as a TOML document (`toml_edit`), which keeps comments, order, spacing and the
//! other entries by construction; each value set gets `# note` on the line above it. The
//! result is read again and must give each value back.

use toml_edit::{DocumentMut, Item, Key, Table, Value};

use super::read::{Ctx, user_message};
use super::schema::{FileT, MODEL_EQUATION, Num, NumOrParam, Param, Raw, toleranceable};
use super::{Instrument, InstrumentError};
use crate::model::effects::CandidateId;

/// The comment that opens a `[model_equation]` section the rewriting adds.
const MODEL_EQUATION_HEADER: &str = "# The instrument's nominal IEEE 1293 model-equation terms (cgs units, IEEE signs;\n# 0 when absent): the baseline model includes them.\n";

/// `src` as an editable document.
fn document(cx: &Ctx<'_>) -> Result<DocumentMut, InstrumentError> {
    cx.src
        .parse::<DocumentMut>()
        .map_err(|e| cx.err(e.span().map_or(0, |s| s.start), user_message(e.message())))
}

/// The value written as `text` (a float as `{:?}` writes it, or an inline table).
fn value(text: &str) -> Value {
    text.parse()
        .unwrap_or_else(|e| unreachable!("`{text}` is a TOML value ({e})"))
}

/// Sets `table`'s entry `name` to `new`, keeping the spacing around the old value and its
/// trailing comment, and puts `# note` on a line of its own above the entry: indented as the
/// entry when `indented`, at the line's start otherwise. `None` when `table` has no such
/// entry with a value.
fn set_entry(table: &mut Table, name: &str, new: Value, note: &str, indented: bool) -> Option<()> {
    let (mut key, item) = table.get_key_value_mut(name)?;
    let old = item.as_value_mut()?;
    let mut new = new;
    *new.decor_mut() = old.decor().clone();
    *old = new;
    let prefix = key
        .leaf_decor()
        .prefix()
        .and_then(|p| p.as_str())
        .unwrap_or("")
        .to_string();
    let cut = prefix.rfind('\n').map_or(0, |i| i + 1);
    let indent = &prefix[cut..];
    let note_indent = if indented { indent } else { "" };
    key.leaf_decor_mut().set_prefix(format!(
        "{}{note_indent}{}{indent}",
        &prefix[..cut],
        note_line(note)
    ));
    Some(())
}

/// `# note` as a line of its own.
fn note_line(note: &str) -> String {
    format!("# {}\n", note.replace('\n', " "))
}

/// A new entry `name = text` at the end of `table`, with the comment lines `above` (each
/// ending in a newline) above it.
fn add_entry(table: &mut Table, name: &str, text: &str, above: String) {
    let mut key = Key::new(name);
    key.leaf_decor_mut().set_prefix(above);
    let mut v = value(text);
    v.decor_mut().set_prefix(" ");
    v.decor_mut().set_suffix("");
    table.insert_formatted(&key, Item::Value(v));
}

/// The toleranced entry `key` as the file writes it: its table, or `None` when the file
/// gives it as a bare number or not at all.
fn toleranced<'a>(f: &'a FileT, key: &str) -> Option<&'a Param> {
    match (toleranceable(key)?.raw)(f) {
        Raw::Param(p) => Some(p.get_ref()),
        Raw::Optional(p) => p.map(toml::Spanned::get_ref),
        Raw::NumOrParam(g) => match g.get_ref() {
            NumOrParam::Param(q) => Some(q),
            NumOrParam::Num(_) => None,
        },
        Raw::Num(_) => None,
    }
}

/// The inline table of a toleranced entry with the new value `v`, in the tolerance form
/// `q` had: `tol_pct` and `tol_abs` keep their figure; a `min`/`max` band widens to hold `v`.
fn tolerance_table(q: &Param, v: f64) -> String {
    if let Some(Num(t)) = q.tol_pct {
        format!("{{ value = {v:?}, tol_pct = {t:?} }}")
    } else if let Some(Num(t)) = q.tol_abs {
        format!("{{ value = {v:?}, tol_abs = {t:?} }}")
    } else {
        let (lo, hi) = (q.min.map_or(v, |n| n.0), q.max.map_or(v, |n| n.0));
        format!(
            "{{ value = {v:?}, min = {:?}, max = {:?} }}",
            lo.min(v),
            hi.max(v)
        )
    }
}

/// An error of the rewriting itself (no position in the file).
fn fail(file: &str, message: String) -> InstrumentError {
    InstrumentError {
        file: file.to_string(),
        line: 0,
        column: 0,
        message,
    }
}

/// The section of `doc` named `name`, as a table.
fn section<'a>(doc: &'a mut DocumentMut, name: &str) -> Option<&'a mut Table> {
    doc.get_mut(name).and_then(Item::as_table_mut)
}

impl Instrument {
    /// The section that holds the bias and the local gravity: `[electronics]` with a loop,
    /// `[instrument]` without.
    fn values_section(&self) -> &'static str {
        if self.has_loop {
            "electronics"
        } else {
            "instrument"
        }
    }

    /// The text of instrument file `src` with new values for toleranced parameters,
    /// everything else (comments, order, other entries) kept: each `(key, value, note)`
    /// rewrites that entry's inline table with the new `value` in the same tolerance form
    /// (`tol_pct` and `tol_abs` keep their figure, so a percentage band now centres on the
    /// new value; a `min`/`max` band is widened to hold it) and puts `# note` on the line
    /// above. The result is parsed again and must give each value back exactly.
    ///
    /// # Errors
    /// `src` is not a valid instrument file, a key is not a toleranced parameter, or the
    /// new text does not give the values back (a value the file refuses, e.g. a negative
    /// inertia).
    pub fn rewrite(
        src: &str,
        file: &str,
        changes: &[(&str, f64, String)],
    ) -> Result<String, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        Self::parse(src, file)?;
        let cx = Ctx { file, src };
        let f: FileT = toml::from_str(src).map_err(|e| cx.err(0, user_message(e.message())))?;
        let mut doc = document(&cx)?;
        for (key, v, note) in changes {
            let not_toleranced = || {
                fail(
                    file,
                    format!("{key}: not a toleranced parameter of the file"),
                )
            };
            let q = toleranced(&f, key).ok_or_else(not_toleranced)?;
            let (name, entry) = key.split_once('.').ok_or_else(not_toleranced)?;
            section(&mut doc, name)
                .and_then(|t| set_entry(t, entry, value(&tolerance_table(q, *v)), note, true))
                .ok_or_else(not_toleranced)?;
        }
        let out = doc.to_string();
        let back = Self::parse(&out, file)?;
        for (key, v, _) in changes {
            if back
                .get(key)
                .is_none_or(|b| (b - v).abs() > 1e-12 * v.abs().max(1e-300))
            {
                return Err(fail(
                    file,
                    format!("{key}: the rewritten file does not give {v} back"),
                ));
            }
        }
        Ok(out)
    }

    /// The text of an instrument file with its local gravity (`electronics.` or
    /// `instrument.local_gravity_cm_s2`) set to `g_cm_s2`, a comment `note` above it; the
    /// rest of the text as it was. Every value of the file that is per g is then per g of
    /// this gravity, as if the file had said it.
    ///
    /// # Errors
    /// The file is not a valid instrument file, `g_cm_s2` is not a gravity it accepts, or
    /// it has no local gravity to set (a loop-less file that gives none).
    pub fn rewrite_gravity(
        src: &str,
        file: &str,
        g_cm_s2: f64,
        note: &str,
    ) -> Result<String, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        let name = Self::parse(src, file)?.values_section();
        let cx = Ctx { file, src };
        let mut doc = document(&cx)?;
        section(&mut doc, name)
            .and_then(|t| {
                let g = value(&format!("{g_cm_s2:?}"));
                set_entry(t, "local_gravity_cm_s2", g, note, false)
            })
            .ok_or_else(|| {
                cx.err(
                    0,
                    format!(
                        "{name}.local_gravity_cm_s2: missing; expected the local gravity to replace"
                    ),
                )
            })?;
        let out = doc.to_string();
        let back = Self::parse(&out, file)?;
        if (back.g_cm_s2 - g_cm_s2).abs() > 1e-12 * g_cm_s2.abs() {
            return Err(cx.err(
                0,
                format!("local_gravity_cm_s2: the rewritten file does not give {g_cm_s2} back"),
            ));
        }
        Ok(out)
    }

    /// The text of instrument file `src` with new nominal model-equation terms, everything
    /// else kept: each `(id, value, note)` sets candidate `id`'s nominal
    /// ([`Instrument::nominal_model_term`], in the candidate's unit and sign) to `value`:
    /// the bias into its key (`electronics.bias_cm_s2`, or `instrument.bias_cm_s2` without
    /// a loop), the others into `[model_equation]` under the file's key and IEEE sign
    /// (the section is added at the end of the file when absent, a key at the end of the
    /// section when absent), with `# note` on the line above. The result is parsed again
    /// and must give each value back.
    ///
    /// # Errors
    /// `src` is not a valid instrument file, `id` is not a term of the model equation, or
    /// the new text does not give the values back.
    pub fn rewrite_model_equation(
        src: &str,
        file: &str,
        changes: &[(CandidateId, f64, String)],
    ) -> Result<String, InstrumentError> {
        let src = src.strip_prefix('\u{feff}').unwrap_or(src);
        let bias_section = Self::parse(src, file)?.values_section();
        let cx = Ctx { file, src };
        let mut doc = document(&cx)?;
        for (id, v, note) in changes {
            if *id == CandidateId::Bias {
                section(&mut doc, bias_section)
                    .and_then(|t| set_entry(t, "bias_cm_s2", value(&format!("{v:?}")), note, false))
                    .ok_or_else(|| fail(file, format!("{bias_section}.bias_cm_s2: missing")))?;
                continue;
            }
            let m = MODEL_EQUATION
                .iter()
                .find(|m| m.id == *id)
                .ok_or_else(|| fail(file, format!("{id}: not a term of the model equation")))?;
            let x = format!("{:?}", m.sign * v + 0.0);
            if let Some(t) = section(&mut doc, "model_equation") {
                if set_entry(t, m.key, value(&x), note, false).is_none() {
                    add_entry(t, m.key, &x, note_line(note));
                }
            } else {
                let mut t = Table::new();
                t.decor_mut().set_prefix("\n");
                let above = format!("{MODEL_EQUATION_HEADER}{}", note_line(note));
                add_entry(&mut t, m.key, &x, above);
                doc.insert("model_equation", Item::Table(t));
            }
        }
        let out = doc.to_string();
        let back = Self::parse(&out, file)?;
        for (id, v, _) in changes {
            let b = back.nominal_model_term(*id);
            if (b - v).abs() > 1e-12 * v.abs().max(1e-300) {
                return Err(fail(
                    file,
                    format!("{id}: the rewritten file does not give {v} back"),
                ));
            }
        }
        Ok(out)
    }
}
