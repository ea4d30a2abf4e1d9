//! The shapes the residuals are searched against when no candidate explains them, and the
//! terms a user writes with `--term`: both are made of the same **variables** (the case
//! inputs a row feels, and what a row takes from the row measured before it), with units
//! derived from the inputs' own (cm/s², rad/s, rad/s²).
//!
//! * **Variables** ([`VARS`]): the nine case inputs `a_IA … dw_OA` (their time average over
//!   the row's motion, condition minus reference for a difference row); for an absolute
//!   row also the previous row's mean inputs `prev_a_IA …`, their change since it
//!   `delta_a_IA …`, and the sign of the last move of the input along IA
//!   `sign_delta_a_IA` (the previous row in time order: `time_s` when every row gives it,
//!   else the file's order; the first row's previous row is itself). A difference or a
//!   response row's history variables are 0: its reference is read after the same
//!   approach.
//! * **The library** ([`shapes`]): four families, each tested with its own Bonferroni
//!   control and its own share of the level (`Family::weight`): the generic basis (every
//!   input and every product of two, as before), the history (each history variable
//!   alone), time shapes beyond the linear drift (`t^2`, `t^3` and saturating exponentials
//!   `exp(-t/τ)`, τ = 1/16, 1/8, 1/4 and 1/2 of the run's span, t from the first row, in
//!   `time_s` or rows), the products of three of the row's own inputs, and the products
//!   of two or three variables with a history variable among them.
//! * **The grammar** ([`parse_term`]) of `--term`: sums and differences of products of
//!   variables, integer powers (`^1` to `^6`), numbers and parentheses, variable names in
//!   any case (`a_pa^3`, `a_pa*w_oa`, `(a_ia - a_pa)^2`); a sum's terms must share a unit.

use crate::model::condition::{CaseInputs, Condition, IA, OA, PA, RowKind};

/// Samples per oscillation period for the time averages (exact for products of three
/// sinusoids of the row's frequency: harmonics up to the third).
pub const SAMPLES: u32 = 8;

/// A physical dimension as exponents of cm, s, rad and rows (row order standing for
/// time).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Dim {
    /// Exponent of cm.
    pub cm: i32,
    /// Exponent of s.
    pub s: i32,
    /// Exponent of rad.
    pub rad: i32,
    /// Exponent of a row (time in row order).
    pub row: i32,
}

/// cm/s²: a specific force, and what every term adds to a reading.
pub const ACCEL: Dim = Dim {
    cm: 1,
    s: -2,
    rad: 0,
    row: 0,
};
const RATE: Dim = Dim {
    cm: 0,
    s: -1,
    rad: 1,
    row: 0,
};
const ANG_ACC: Dim = Dim {
    cm: 0,
    s: -2,
    rad: 1,
    row: 0,
};
const ONE: Dim = Dim {
    cm: 0,
    s: 0,
    rad: 0,
    row: 0,
};

impl Dim {
    /// The product of two dimensions.
    #[must_use]
    pub fn times(self, o: Dim) -> Dim {
        Dim {
            cm: self.cm + o.cm,
            s: self.s + o.s,
            rad: self.rad + o.rad,
            row: self.row + o.row,
        }
    }

    /// The dimension to the power `k`.
    #[must_use]
    pub fn pow(self, k: i32) -> Dim {
        Dim {
            cm: self.cm * k,
            s: self.s * k,
            rad: self.rad * k,
            row: self.row * k,
        }
    }

    /// The unit of a coefficient that multiplies a term of this dimension into cm/s².
    #[must_use]
    pub fn coefficient(self) -> Dim {
        ACCEL.times(self.pow(-1))
    }

    /// The unit written out: `s⁴/cm²`, `cm/rad²`, `s/rad`, `cm/s²`, `1`.
    #[must_use]
    pub fn render(self) -> String {
        let parts = [
            ("cm", self.cm),
            ("rad", self.rad),
            ("s", self.s),
            ("row", self.row),
        ];
        let side = |positive: bool| -> Vec<String> {
            parts
                .iter()
                .filter(|(_, e)| if positive { *e > 0 } else { *e < 0 })
                .map(|&(u, e)| format!("{u}{}", superscript(e.abs())))
                .collect()
        };
        let (num, den) = (side(true), side(false));
        let num = if num.is_empty() {
            "1".to_string()
        } else {
            num.join("·")
        };
        match den.len() {
            0 => num,
            1 => format!("{num}/{}", den[0]),
            _ => format!("{num}/({})", den.join("·")),
        }
    }
}

/// `e` as superscript digits (none for 1).
fn superscript(e: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    if e == 1 {
        return String::new();
    }
    e.to_string()
        .chars()
        .map(|c| c.to_digit(10).map_or(c, |d| DIGITS[d as usize]))
        .collect()
}

/// What a variable is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// One of the nine case inputs, by index (a, w, dw along IA, PA, OA), averaged over
    /// the row's motion.
    Now(usize),
    /// The previous row's mean of that input (absolute rows).
    Prev(usize),
    /// The change of that mean since the previous row (absolute rows).
    Delta(usize),
    /// The sign of the last move of the input along IA, −1, 0 or +1 (absolute rows).
    SignDeltaIa,
}

impl Source {
    /// A history variable (0 on a difference or response row).
    #[must_use]
    pub fn history(self) -> bool {
        !matches!(self, Source::Now(_))
    }
}

/// One variable of the library and of the `--term` grammar.
#[derive(Clone, Copy, Debug)]
pub struct Var {
    /// Its name (the grammar takes it in any case).
    pub name: &'static str,
    /// Its unit.
    pub dim: Dim,
    /// What it is.
    pub source: Source,
}

macro_rules! vars {
    ($($now:literal, $prev:literal, $delta:literal, $dim:expr;)*) => {
        /// Every variable: the nine inputs, their previous values, their changes, the sign
        /// of the last move along IA.
        pub const VARS: &[Var] = &{
            const NOW: &[(&str, Dim)] = &[$(($now, $dim),)*];
            const PREV: &[&str] = &[$($prev,)*];
            const DELTA: &[&str] = &[$($delta,)*];
            let mut out = [Var { name: "", dim: ONE, source: Source::SignDeltaIa }; 28];
            let mut k = 0;
            while k < 9 {
                out[k] = Var { name: NOW[k].0, dim: NOW[k].1, source: Source::Now(k) };
                out[9 + k] = Var { name: PREV[k], dim: NOW[k].1, source: Source::Prev(k) };
                out[18 + k] = Var { name: DELTA[k], dim: NOW[k].1, source: Source::Delta(k) };
                k += 1;
            }
            out[27] = Var { name: "sign_delta_a_IA", dim: ONE, source: Source::SignDeltaIa };
            out
        };
    };
}

vars! {
    "a_IA", "prev_a_IA", "delta_a_IA", ACCEL;
    "a_PA", "prev_a_PA", "delta_a_PA", ACCEL;
    "a_OA", "prev_a_OA", "delta_a_OA", ACCEL;
    "w_IA", "prev_w_IA", "delta_w_IA", RATE;
    "w_PA", "prev_w_PA", "delta_w_PA", RATE;
    "w_OA", "prev_w_OA", "delta_w_OA", RATE;
    "dw_IA", "prev_dw_IA", "delta_dw_IA", ANG_ACC;
    "dw_PA", "prev_dw_PA", "delta_dw_PA", ANG_ACC;
    "dw_OA", "prev_dw_OA", "delta_dw_OA", ANG_ACC;
}

/// The index in [`VARS`] of the variable named `name` (any case).
#[must_use]
pub fn var_index(name: &str) -> Option<usize> {
    VARS.iter().position(|v| v.name.eq_ignore_ascii_case(name))
}

/// The nine case inputs at an instant.
fn signals(i: &CaseInputs) -> [f64; 9] {
    let [a0, a1, a2] = i.a_cm_s2;
    let [w0, w1, w2] = i.w_rad_s;
    let [d0, d1, d2] = i.dw_rad_s2;
    [a0, a1, a2, w0, w1, w2, d0, d1, d2]
}

/// The nine inputs of `c` at [`SAMPLES`] equally spaced instants of its period (one if
/// static).
#[must_use]
pub fn samples(c: &Condition, g_cm_s2: f64) -> Vec<[f64; 9]> {
    let p = c.prepare(g_cm_s2);
    let n = if c.is_static() { 1 } else { SAMPLES };
    (0..n)
        .map(|k| {
            let ph = std::f64::consts::TAU * f64::from(k) / f64::from(n);
            let (s, co) = ph.sin_cos();
            signals(&p.inputs(s, co))
        })
        .collect()
}

/// Each row's history variables ([`Source::Prev`], [`Source::Delta`], then
/// [`Source::SignDeltaIa`]; 19 values), `None` for a difference or response row. The
/// previous row is the previous one in time order (`time_s` when every row gives it, else
/// the rows' order); the first row's is itself.
#[must_use]
pub fn histories(rows: &[Condition], g_cm_s2: f64) -> Vec<Option<[f64; 19]>> {
    let means: Vec<[f64; 9]> = rows
        .iter()
        .map(|r| {
            let s = samples(r, g_cm_s2);
            #[allow(clippy::cast_precision_loss)]
            let n = s.len() as f64;
            let mut m = [0.0; 9];
            for x in &s {
                for j in 0..9 {
                    m[j] += x[j] / n;
                }
            }
            m
        })
        .collect();
    let order = crate::model::condition::measurement_order(rows);
    let tol = crate::model::condition::APPROACH_RESOLUTION * g_cm_s2.abs();
    let mut out = vec![None; rows.len()];
    let mut prev: Option<usize> = None;
    for i in order {
        let p = means[prev.unwrap_or(i)];
        prev = Some(i);
        if rows[i].kind != RowKind::Absolute {
            continue;
        }
        let mut h = [0.0; 19];
        for j in 0..9 {
            h[j] = p[j];
            h[9 + j] = means[i][j] - p[j];
        }
        let d = h[9 + IA];
        h[18] = if d > tol {
            1.0
        } else if d < -tol {
            -1.0
        } else {
            0.0
        };
        out[i] = Some(h);
    }
    out
}

/// The value of variable `v` at an instant with inputs `now` on a row with history `hist`.
fn var_value(v: usize, now: &[f64; 9], hist: Option<&[f64; 19]>) -> f64 {
    match VARS[v].source {
        Source::Now(j) => now[j],
        Source::Prev(j) => hist.map_or(0.0, |h| h[j]),
        Source::Delta(j) => hist.map_or(0.0, |h| h[9 + j]),
        Source::SignDeltaIa => hist.map_or(0.0, |h| h[18]),
    }
}

/// The families of the library, each tested with its own Bonferroni control.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Each input and each product of two (condition minus reference).
    Basis,
    /// Each history variable alone.
    History,
    /// Time shapes beyond the linear drift.
    Time,
    /// Products of three of the row's own inputs.
    Products,
    /// Products of two or three variables with a history variable among them.
    HistoryProducts,
    /// Harmonics of a tumble's angle beyond the third (IEEE Std 1293's Fourier analysis of
    /// a multipoint tumble): `sin kφ`, `cos kφ` of the angle in each plane the rows turn
    /// in, for k = 4 up to what the plane's distinct angles resolve.
    Harmonics,
}

impl Family {
    /// Every family, in test order.
    pub const ALL: [Family; 6] = [
        Family::Basis,
        Family::History,
        Family::Time,
        Family::Products,
        Family::HistoryProducts,
        Family::Harmonics,
    ];

    /// The test's name in the JSON (`generic_basis` keeps its earlier meaning).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Family::Basis => "generic_basis",
            Family::History => "history",
            Family::Time => "time_shapes",
            Family::Products => "products",
            Family::HistoryProducts => "history_products",
            Family::Harmonics => "tumble_harmonics",
        }
    }

    /// Its share of the level, relative to the lack of fit's 1 (weighted Bonferroni over
    /// the tests run: a test of weight w among tests of total weight W is held at
    /// `α·w/W`): the generic basis 1, the history, time shapes, third-order products and a
    /// tumble's harmonics ½, the products with the row before (a large family of
    /// speculative forms) ¼.
    #[must_use]
    pub fn weight(self) -> f64 {
        match self {
            Family::Basis => 1.0,
            Family::History | Family::Time | Family::Products | Family::Harmonics => 0.5,
            Family::HistoryProducts => 0.25,
        }
    }
}

/// One element of the library: a column over the observations and what it is.
#[derive(Clone, Debug)]
pub struct Shape {
    /// Its family.
    pub family: Family,
    /// In the hint (`mean(a_IA·w_PA)` for the basis, as before; the form otherwise).
    pub name: String,
    /// The form, in the `--term` grammar where it is a product (`a_PA^3`,
    /// `delta_a_IA*a_PA`), else `t^2`, `exp(-t/90 s)`.
    pub form: String,
    /// The unit of its coefficient (cm/s² over the form's).
    pub unit: String,
    /// Simplicity: history variables, distinct variables, then order (the simpler of two
    /// shapes the data cannot tell apart is proposed: the inputs of the row itself before
    /// the row before).
    pub complexity: (usize, usize, u32),
    /// The column (cm/s² per unit coefficient), 0 where it does not apply.
    pub col: Vec<f64>,
}

/// A product of variables: `(index in VARS, power)`, in index order.
pub type Monomial = Vec<(usize, u32)>;

/// The form of a monomial in the grammar (`a_PA^3`, `a_IA*w_PA`).
#[must_use]
pub fn monomial_form(m: &Monomial) -> String {
    m.iter()
        .map(|&(v, k)| {
            if k == 1 {
                VARS[v].name.to_string()
            } else {
                format!("{}^{k}", VARS[v].name)
            }
        })
        .collect::<Vec<_>>()
        .join("*")
}

/// The dimension of a monomial.
fn monomial_dim(m: &Monomial) -> Dim {
    m.iter().fold(ONE, |d, &(v, k)| {
        #[allow(clippy::cast_possible_wrap)]
        d.times(VARS[v].dim.pow(k as i32))
    })
}

/// Every monomial of order 1 to 3 over the variables `active`, in order.
fn monomials(active: &[usize]) -> Vec<Monomial> {
    let mut out: Vec<Monomial> = Vec::new();
    let n = active.len();
    let push = |out: &mut Vec<Monomial>, idx: &[usize]| {
        let mut m: Monomial = Vec::new();
        for &i in idx {
            let v = active[i];
            if let Some(last) = m.last_mut().filter(|(u, _)| *u == v) {
                last.1 += 1;
            } else {
                m.push((v, 1));
            }
        }
        out.push(m);
    };
    for i in 0..n {
        push(&mut out, &[i]);
        for j in i..n {
            push(&mut out, &[i, j]);
            for k in j..n {
                push(&mut out, &[i, j, k]);
            }
        }
    }
    out
}

/// The family of a monomial of the library (`None`: left out — a sign to a power above 1,
/// which is the sign's magnitude, or a history variable's power).
fn family_of(m: &Monomial) -> Option<Family> {
    let order: u32 = m.iter().map(|&(_, k)| k).sum();
    let hist = m.iter().filter(|&&(v, _)| VARS[v].source.history()).count();
    if m.iter()
        .any(|&(v, k)| VARS[v].source == Source::SignDeltaIa && k > 1)
    {
        return None;
    }
    match (hist, order) {
        (0, 1 | 2) => Some(Family::Basis),
        (1, 1) => Some(Family::History),
        (0, _) => Some(Family::Products),
        _ => Some(Family::HistoryProducts),
    }
}

/// A function of the inputs at an instant and a row's history variables.
pub type RowFn<'a> = dyn Fn(&[f64; 9], Option<&[f64; 19]>) -> f64 + 'a;

/// The average of `f(sample)` over a row's samples.
fn average(samples: &[[f64; 9]], f: impl Fn(&[f64; 9]) -> f64) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let n = samples.len() as f64;
    samples.iter().map(f).sum::<f64>() / n
}

/// One row's value of `f` (a function of the inputs at an instant and the history), for a
/// unit coefficient: its time average, condition minus reference for a difference row
/// (differences that cancel to rounding are 0), as the reading sees it.
fn row_value(
    now: &[[f64; 9]],
    reference: Option<&[[f64; 9]]>,
    hist: Option<&[f64; 19]>,
    f: &RowFn<'_>,
) -> f64 {
    let c = average(now, |x| f(x, hist));
    match reference {
        None => c,
        Some(r) => {
            let rv = average(r, |x| f(x, None));
            let scale = c.abs().max(rv.abs());
            if (c - rv).abs() <= 1e-9 * scale {
                0.0
            } else {
                c - rv
            }
        }
    }
}

/// The rows' inputs as the library reads them: per row its samples, its reference's (a
/// difference row) and its history.
pub struct RowInputs {
    now: Vec<Vec<[f64; 9]>>,
    reference: Vec<Option<Vec<[f64; 9]>>>,
    hist: Vec<Option<[f64; 19]>>,
}

impl RowInputs {
    /// The inputs of `rows` (all of a file's rows, for the history).
    #[must_use]
    pub fn of(rows: &[Condition], g_cm_s2: f64) -> Self {
        RowInputs {
            now: rows.iter().map(|r| samples(r, g_cm_s2)).collect(),
            reference: rows
                .iter()
                .map(|r| (r.kind == RowKind::Difference).then(|| samples(&r.reference(), g_cm_s2)))
                .collect(),
            hist: histories(rows, g_cm_s2),
        }
    }

    /// The column of `f` over the rows `which` (indices into the rows given to [`of`]).
    ///
    /// [`of`]: RowInputs::of
    #[must_use]
    pub fn column(&self, which: &[usize], f: &RowFn<'_>) -> Vec<f64> {
        which
            .iter()
            .map(|&i| {
                row_value(
                    &self.now[i],
                    self.reference[i].as_deref(),
                    self.hist[i].as_ref(),
                    f,
                )
            })
            .collect()
    }
}

/// Whether variable `v` is not identically 0 over the rows `which` (beyond rounding: 1e-9
/// of g for an acceleration).
fn active(inputs: &RowInputs, which: &[usize], v: usize, g_cm_s2: f64) -> bool {
    let floor = match VARS[v].dim {
        d if d == ACCEL => 1e-9 * g_cm_s2.abs(),
        _ => 1e-12,
    };
    which.iter().any(|&i| {
        inputs.now[i]
            .iter()
            .chain(inputs.reference[i].iter().flatten())
            .any(|x| var_value(v, x, inputs.hist[i].as_ref()).abs() > floor)
    })
}

/// The library over the observations of rows `which` (indices into `rows`, one per
/// observation; `value[k]`: observation k is a value in cm/s², else its columns are 0)
/// with times `time` (`time_s`, or rows when `seconds` is false; the time shapes only for
/// the observations that `drifts`). Elements that vanish here, or repeat an earlier one
/// (|cos| > 0.9999), are left out. The basis family is in the order of the earlier
/// generic basis, with its names.
#[must_use]
pub fn shapes(
    rows: &[Condition],
    g_cm_s2: f64,
    which: &[usize],
    value: &[bool],
    time: &[f64],
    drifts: &[bool],
    seconds: bool,
) -> Vec<Shape> {
    let mut out: Vec<Shape> = Vec::new();
    // The basis first (in the earlier basis's order), then the history, then the rest, the
    // time shapes and the harmonics: an element repeating an earlier one is left out.
    for s in monomial_shapes(rows, g_cm_s2, which, value)
        .into_iter()
        .chain(time_shapes(which, time, drifts, seconds))
        .chain(harmonics(rows, which, value))
    {
        push_new(&mut out, s);
    }
    // Families in test order, each keeping its own order.
    out.sort_by_key(|s| Family::ALL.iter().position(|f| *f == s.family));
    out
}

/// `s` added to `out` unless it vanishes or repeats an element already there
/// (|cos| > 0.9999).
fn push_new(out: &mut Vec<Shape>, s: Shape) {
    let n = norm(&s.col);
    if n == 0.0 {
        return;
    }
    let repeats = out.iter().any(|o| {
        let dot: f64 = o.col.iter().zip(&s.col).map(|(a, b)| a * b).sum();
        (dot / (norm(&o.col) * n)).abs() > 0.9999
    });
    if !repeats {
        out.push(s);
    }
}

/// The products of the inputs active in these rows, family by family in test order (the
/// basis in the earlier basis's order, with its names), each a column over the
/// observations (0 where an observation is not a value).
fn monomial_shapes(
    rows: &[Condition],
    g_cm_s2: f64,
    which: &[usize],
    value: &[bool],
) -> Vec<Shape> {
    let inputs = RowInputs::of(rows, g_cm_s2);
    let act: Vec<usize> = (0..VARS.len())
        .filter(|&v| active(&inputs, which, v, g_cm_s2))
        .collect();
    let mut library: Vec<(Family, Monomial)> = monomials(&act)
        .into_iter()
        .filter_map(|m| Some((family_of(&m)?, m)))
        .collect();
    library.sort_by_key(|(f, _)| Family::ALL.iter().position(|x| x == f));
    library
        .into_iter()
        .map(|(family, m)| {
            let f = |x: &[f64; 9], h: Option<&[f64; 19]>| {
                m.iter().fold(1.0, |acc, &(v, k)| {
                    #[allow(clippy::cast_possible_wrap)]
                    let p = var_value(v, x, h).powi(k as i32);
                    acc * p
                })
            };
            let mut col = inputs.column(which, &f);
            for (x, &v) in col.iter_mut().zip(value) {
                if !v {
                    *x = 0.0;
                }
            }
            let form = monomial_form(&m);
            let name = if family == Family::Basis {
                basis_name(&m)
            } else {
                form.clone()
            };
            Shape {
                family,
                name,
                unit: monomial_dim(&m).coefficient().render(),
                complexity: (
                    m.iter().filter(|&&(v, _)| VARS[v].source.history()).count(),
                    m.len(),
                    m.iter().map(|&(_, k)| k).sum(),
                ),
                form,
                col,
            }
        })
        .collect()
}

/// The shapes in time beyond the linear drift over the observations that `drifts` (t², t³
/// and exponentials of a sixteenth to half the span), `time` in s when `seconds`, else in
/// rows; none when the times do not span.
fn time_shapes(which: &[usize], time: &[f64], drifts: &[bool], seconds: bool) -> Vec<Shape> {
    let ts: Vec<f64> = (0..which.len())
        .filter(|&k| drifts[k])
        .map(|k| time[k])
        .collect();
    let t0 = ts.iter().copied().fold(f64::INFINITY, f64::min);
    let span = ts.iter().copied().fold(f64::NEG_INFINITY, f64::max) - t0;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let tdim = if seconds {
        Dim { s: 1, ..ONE }
    } else {
        Dim { row: 1, ..ONE }
    };
    let unit = if seconds { "s" } else { "rows" };
    let time_shape = |form: String, k: u32, f: &dyn Fn(f64) -> f64, dim: Dim| {
        let col: Vec<f64> = (0..which.len())
            .map(|j| if drifts[j] { f(time[j] - t0) } else { 0.0 })
            .collect();
        Shape {
            family: Family::Time,
            name: form.clone(),
            form,
            unit: dim.coefficient().render(),
            complexity: (0, 1, k),
            col,
        }
    };
    let mut out = Vec::new();
    #[allow(clippy::cast_possible_wrap)]
    for k in [2u32, 3] {
        out.push(time_shape(
            format!("t^{k}"),
            k,
            &|t| t.powi(k as i32),
            tdim.pow(k as i32),
        ));
    }
    for per in [16.0, 8.0, 4.0, 2.0] {
        let tau = span / per;
        out.push(time_shape(
            format!("exp(-t/{} {unit})", short(tau)),
            1,
            &|t| (-t / tau).exp(),
            ONE,
        ));
    }
    out
}

/// The lowest harmonic of a tumble's angle `harmonics` gives: the third and below are the
/// model equation's (`K_0`, `K_1`, the misalignments, the second-order terms) and the
/// third-order products'.
pub const FIRST_HARMONIC: usize = 4;

/// The planes of the case a tumble turns gravity in: the two axes (the angle φ from the
/// first toward the second) and the axis of the turn, with its name.
const PLANES: [(usize, usize, usize, &str); 3] = [
    (IA, PA, OA, "IA-PA"),
    (IA, OA, PA, "IA-OA"),
    (PA, OA, IA, "PA-OA"),
];

/// A row's angle in the plane `(a, b, about)`, rad in [0, 2π): an absolute row at rest whose
/// gravity lies in the plane (1 g in it, none along `about`).
fn plane_angle(r: &Condition, (a, b, about): (usize, usize, usize)) -> Option<f64> {
    let at_rest = r.kind == RowKind::Absolute
        && r.is_static()
        && r.w_rad_s.iter().all(|&w| w == 0.0)
        && r.radius_cm == 0.0;
    let in_plane = r.g[about].abs() < 1e-3 && (r.g[a].hypot(r.g[b]) - 1.0).abs() < 1e-2;
    (at_rest && in_plane).then(|| r.g[b].atan2(r.g[a]).rem_euclid(std::f64::consts::TAU))
}

/// The number of distinct angles among `phis` (to a microradian, 0 and 2π the same).
fn distinct_angles(phis: &[f64]) -> usize {
    let mut v = phis.to_vec();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|x, y| (*x - *y).abs() < 1e-6);
    if v.len() > 1 && v[0] + std::f64::consts::TAU - v[v.len() - 1] < 1e-6 {
        v.pop();
    }
    v.len()
}

/// The tumble-harmonic shapes over the observations of rows `which` (`value[k]`: a value
/// in cm/s²): for each plane with rows in it, `sin kφ` and `cos kφ` on those rows (0
/// elsewhere), k from [`FIRST_HARMONIC`] to `⌊(n − 1)/2⌋` for its n distinct angles (what
/// n positions resolve without aliasing).
fn harmonics(rows: &[Condition], which: &[usize], value: &[bool]) -> Vec<Shape> {
    let mut out = Vec::new();
    for (a, b, about, plane) in PLANES {
        let phis: Vec<Option<f64>> = which
            .iter()
            .zip(value)
            .map(|(&i, &v)| {
                if v {
                    plane_angle(&rows[i], (a, b, about))
                } else {
                    None
                }
            })
            .collect();
        let present: Vec<f64> = phis.iter().flatten().copied().collect();
        let kmax = distinct_angles(&present).saturating_sub(1) / 2;
        for k in FIRST_HARMONIC..=kmax {
            #[allow(clippy::cast_precision_loss)]
            let kf = k as f64;
            for (name, f) in [("sin", f64::sin as fn(f64) -> f64), ("cos", f64::cos)] {
                let form = format!("{name}({k}φ) in the {plane} plane");
                out.push(Shape {
                    family: Family::Harmonics,
                    name: form.clone(),
                    form,
                    unit: "cm/s²".to_string(),
                    #[allow(clippy::cast_possible_truncation)]
                    complexity: (0, 1, k as u32),
                    col: phis.iter().map(|p| p.map_or(0.0, |p| f(kf * p))).collect(),
                });
            }
        }
    }
    out
}

/// A time constant in about three significant digits, trailing zeros dropped.
fn short(x: f64) -> String {
    let p = if x.abs() >= 100.0 {
        0
    } else if x.abs() >= 10.0 {
        1
    } else {
        2
    };
    let t = format!("{x:.p$}");
    if t.contains('.') {
        t.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        t
    }
}

/// The earlier generic basis's name of an order-1 or -2 monomial of the inputs.
fn basis_name(m: &Monomial) -> String {
    match m.as_slice() {
        [(v, 1)] => format!("mean({})", VARS[*v].name),
        [(v, 2)] => format!("mean({}²)", VARS[*v].name),
        [(a, _), (b, _)] => format!("mean({}·{})", VARS[*a].name, VARS[*b].name),
        _ => monomial_form(m),
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// A user's term (`--term`), parsed: its text, its canonical form and unit.
#[derive(Clone, Debug)]
pub struct Term {
    /// As typed.
    pub text: String,
    /// The expression.
    expr: Expr,
    /// The unit of the term itself.
    pub dim: Dim,
}

#[derive(Clone, Debug)]
enum Expr {
    Num(f64),
    Var(usize),
    Neg(Box<Expr>),
    Add(Box<Expr>, Box<Expr>),
    Sub(Box<Expr>, Box<Expr>),
    Mul(Box<Expr>, Box<Expr>),
    Pow(Box<Expr>, i32),
}

impl Expr {
    fn eval(&self, now: &[f64; 9], hist: Option<&[f64; 19]>) -> f64 {
        match self {
            Expr::Num(x) => *x,
            Expr::Var(v) => var_value(*v, now, hist),
            Expr::Neg(a) => -a.eval(now, hist),
            Expr::Add(a, b) => a.eval(now, hist) + b.eval(now, hist),
            Expr::Sub(a, b) => a.eval(now, hist) - b.eval(now, hist),
            Expr::Mul(a, b) => a.eval(now, hist) * b.eval(now, hist),
            Expr::Pow(a, k) => a.eval(now, hist).powi(*k),
        }
    }

    fn vars(&self, out: &mut Vec<usize>) {
        match self {
            Expr::Num(_) => {}
            Expr::Var(v) => out.push(*v),
            Expr::Neg(a) | Expr::Pow(a, _) => a.vars(out),
            Expr::Add(a, b) | Expr::Sub(a, b) | Expr::Mul(a, b) => {
                a.vars(out);
                b.vars(out);
            }
        }
    }
}

impl Term {
    /// The unit of its coefficient.
    #[must_use]
    pub fn unit(&self) -> String {
        self.dim.coefficient().render()
    }

    /// Whether it reads a history variable (absolute rows only).
    #[must_use]
    pub fn uses_history(&self) -> bool {
        let mut v = Vec::new();
        self.expr.vars(&mut v);
        v.iter().any(|&i| VARS[i].source.history())
    }

    /// Its column over the rows `which` of `inputs`: the term's time average (condition
    /// minus reference for a difference row) per unit coefficient, cm/s² per unit.
    #[must_use]
    pub fn column(&self, inputs: &RowInputs, which: &[usize]) -> Vec<f64> {
        inputs.column(which, &|x, h| self.expr.eval(x, h))
    }
}

/// Parse `text` as a `--term` expression.
///
/// # Errors
/// One line naming the column (1-based, in characters) of the first bad token and what
/// was expected there; a sum of terms of different units; a term without a variable.
pub fn parse_term(text: &str) -> Result<Term, String> {
    let chars: Vec<char> = text.chars().collect();
    let mut p = Parser { s: &chars, i: 0 };
    let (expr, dim) = p.sum()?;
    p.skip_ws();
    if p.i < chars.len() {
        return Err(p.error("`+`, `-`, `*`, `^` or the end of the term"));
    }
    let mut v = Vec::new();
    expr.vars(&mut v);
    if v.is_empty() {
        return Err(
            "no variable: expected a product of case inputs such as `a_pa^3` or `a_pa*w_oa`"
                .to_string(),
        );
    }
    Ok(Term {
        text: text.trim().to_string(),
        expr,
        dim,
    })
}

struct Parser<'a> {
    s: &'a [char],
    i: usize,
}

/// The highest power the grammar takes.
pub const MAX_POWER: i32 = 6;

impl Parser<'_> {
    fn skip_ws(&mut self) {
        while self.s.get(self.i).is_some_and(|c| c.is_whitespace()) {
            self.i += 1;
        }
    }

    fn found(&self) -> String {
        if self.i >= self.s.len() {
            return "the end of the term".to_string();
        }
        let rest: String = self.s[self.i..]
            .iter()
            .take_while(|c| !c.is_whitespace())
            .take(12)
            .collect();
        format!("`{rest}`")
    }

    fn error(&self, expected: &str) -> String {
        format!(
            "column {}: expected {expected}, found {}",
            self.i + 1,
            self.found()
        )
    }

    fn sum(&mut self) -> Result<(Expr, Dim), String> {
        let (mut e, dim) = self.product()?;
        loop {
            self.skip_ws();
            let op = match self.s.get(self.i) {
                Some('+') => '+',
                Some('-') => '-',
                _ => return Ok((e, dim)),
            };
            let at = self.i;
            self.i += 1;
            let (r, d) = self.product()?;
            if d != dim && !is_zero_num(&r) {
                return Err(format!(
                    "column {}: the terms of a sum must share a unit; expected a term in {} like the one before, found one in {}",
                    at + 1,
                    render_term_unit(dim),
                    render_term_unit(d)
                ));
            }
            e = if op == '+' {
                Expr::Add(Box::new(e), Box::new(r))
            } else {
                Expr::Sub(Box::new(e), Box::new(r))
            };
        }
    }

    fn product(&mut self) -> Result<(Expr, Dim), String> {
        let (mut e, mut dim) = self.power()?;
        loop {
            self.skip_ws();
            if self.s.get(self.i) != Some(&'*') {
                return Ok((e, dim));
            }
            self.i += 1;
            let (r, d) = self.power()?;
            dim = dim.times(d);
            e = Expr::Mul(Box::new(e), Box::new(r));
        }
    }

    fn power(&mut self) -> Result<(Expr, Dim), String> {
        let (e, dim) = self.atom()?;
        self.skip_ws();
        if self.s.get(self.i) != Some(&'^') {
            return Ok((e, dim));
        }
        self.i += 1;
        self.skip_ws();
        let start = self.i;
        while self.s.get(self.i).is_some_and(char::is_ascii_digit) {
            self.i += 1;
        }
        let digits: String = self.s[start..self.i].iter().collect();
        match digits.parse::<i32>() {
            Ok(k) if (1..=MAX_POWER).contains(&k) => Ok((Expr::Pow(Box::new(e), k), dim.pow(k))),
            _ => {
                self.i = start;
                Err(self.error(&format!("a whole power from 1 to {MAX_POWER} after `^`")))
            }
        }
    }

    fn atom(&mut self) -> Result<(Expr, Dim), String> {
        self.skip_ws();
        let start = self.i;
        match self.s.get(self.i) {
            Some('(') => {
                self.i += 1;
                let inner = self.sum()?;
                self.skip_ws();
                if self.s.get(self.i) != Some(&')') {
                    return Err(self.error("`)`"));
                }
                self.i += 1;
                Ok(inner)
            }
            Some('-') => {
                self.i += 1;
                let (e, d) = self.power()?;
                Ok((Expr::Neg(Box::new(e)), d))
            }
            Some(c) if c.is_ascii_digit() || *c == '.' => {
                while self.s.get(self.i).is_some_and(|c| {
                    c.is_ascii_digit()
                        || matches!(c, '.' | 'e' | 'E')
                        || (matches!(c, '+' | '-')
                            && matches!(self.s.get(self.i.wrapping_sub(1)), Some('e' | 'E')))
                }) {
                    self.i += 1;
                }
                let t: String = self.s[start..self.i].iter().collect();
                match t.parse::<f64>() {
                    Ok(x) if x.is_finite() => Ok((Expr::Num(x), ONE)),
                    _ => {
                        self.i = start;
                        Err(self.error("a number"))
                    }
                }
            }
            Some(c) if c.is_ascii_alphabetic() || *c == '_' => {
                while self
                    .s
                    .get(self.i)
                    .is_some_and(|c| c.is_ascii_alphanumeric() || *c == '_')
                {
                    self.i += 1;
                }
                let name: String = self.s[start..self.i].iter().collect();
                if let Some(v) = var_index(&name) {
                    Ok((Expr::Var(v), VARS[v].dim))
                } else {
                    self.i = start;
                    Err(self.error(
                        "a case input (a_ia, a_pa, a_oa, w_ia … w_oa, dw_ia … dw_oa; prev_X, delta_X, sign_delta_a_ia)",
                    ))
                }
            }
            _ => Err(self.error("a case input, a number or `(`")),
        }
    }
}

fn is_zero_num(e: &Expr) -> bool {
    matches!(e, Expr::Num(x) if *x == 0.0)
}

/// The unit of a term (not its coefficient's), for messages.
fn render_term_unit(d: Dim) -> String {
    if d == ONE {
        "no unit".to_string()
    } else {
        d.render()
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // exact small sums of exact numbers
mod tests {
    // The module by its path, not `super::*`: the layering test reads `super::` as `mod`.
    use crate::discovery::library::*;

    #[test]
    fn units_are_derived_from_the_inputs() {
        let u = |t: &str| parse_term(t).unwrap().unit();
        assert_eq!(u("a_pa^3"), "s⁴/cm²");
        assert_eq!(u("a_PA*w_OA"), "s/rad");
        assert_eq!(u("w_ia*w_pa"), "cm/rad²");
        assert_eq!(u("a_ia*a_pa"), "s²/cm");
        assert_eq!(u("dw_oa*a_pa"), "s²/rad");
        assert_eq!(u("sign_delta_a_ia"), "cm/s²");
        assert_eq!(u("2*a_ia"), "1");
        assert_eq!(u("w_oa"), "cm/(rad·s)");
        assert_eq!(u("(a_ia - a_pa)^2 + a_ia*a_oa"), "s²/cm");
        assert_eq!(u("prev_a_ia*delta_a_pa"), "s²/cm");
    }

    #[test]
    fn the_grammar_evaluates_what_it_reads() {
        let t = parse_term(" 0.5*(a_ia - a_pa)^2 - -a_pa*a_ia ").unwrap();
        let now = [3.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(t.expr.eval(&now, None), 0.5 * 4.0 + 3.0);
        let h = parse_term("prev_a_ia*sign_delta_a_ia").unwrap();
        let mut hist = [0.0; 19];
        hist[0] = 7.0;
        hist[18] = -1.0;
        assert_eq!(h.expr.eval(&now, Some(&hist)), -7.0);
        assert_eq!(h.expr.eval(&now, None), 0.0);
        assert!(h.uses_history() && !t.uses_history());
        assert_eq!(parse_term("A_PA^3").unwrap().dim, ACCEL.pow(3));
    }

    #[test]
    fn a_bad_token_is_named_by_its_column() {
        let e = |t: &str| parse_term(t).unwrap_err();
        assert_eq!(
            e("a_pa^x"),
            "column 6: expected a whole power from 1 to 6 after `^`, found `x`"
        );
        assert!(
            e("a_pa*b_xx").starts_with("column 6: expected a case input"),
            "{}",
            e("a_pa*b_xx")
        );
        assert_eq!(
            e("a_pa a_ia"),
            "column 6: expected `+`, `-`, `*`, `^` or the end of the term, found `a_ia`"
        );
        assert_eq!(
            e("(a_pa"),
            "column 6: expected `)`, found the end of the term"
        );
        assert_eq!(
            e("a_pa*"),
            "column 6: expected a case input, a number or `(`, found the end of the term"
        );
        assert_eq!(
            e("a_pa^7"),
            "column 6: expected a whole power from 1 to 6 after `^`, found `7`"
        );
        assert_eq!(
            e("a_pa + w_oa"),
            "column 6: the terms of a sum must share a unit; expected a term in cm/s² like the one before, found one in rad/s"
        );
        assert!(e("2*3").starts_with("no variable"));
    }

    #[test]
    fn monomials_are_formed_and_classed() {
        let m = monomials(&[0, 1]);
        let forms: Vec<String> = m.iter().map(monomial_form).collect();
        assert_eq!(
            forms,
            [
                "a_IA",
                "a_IA^2",
                "a_IA^3",
                "a_IA^2*a_PA",
                "a_IA*a_PA",
                "a_IA*a_PA^2",
                "a_PA",
                "a_PA^2",
                "a_PA^3"
            ]
        );
        assert_eq!(family_of(&vec![(1, 3)]), Some(Family::Products));
        assert_eq!(family_of(&vec![(0, 1), (1, 1)]), Some(Family::Basis));
        assert_eq!(family_of(&vec![(9, 1)]), Some(Family::History));
        assert_eq!(family_of(&vec![(27, 2)]), None);
        assert_eq!(
            family_of(&vec![(1, 1), (27, 1)]),
            Some(Family::HistoryProducts)
        );
        // Every form of the library parses back to its own unit.
        for mono in monomials(&[0, 1, 5, 18, 27]) {
            let f = monomial_form(&mono);
            assert_eq!(parse_term(&f).unwrap().dim, monomial_dim(&mono), "{f}");
        }
    }
}
