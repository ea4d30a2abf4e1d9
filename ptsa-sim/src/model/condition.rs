//! Test conditions in the instrument's case frame.
//!
//! A [`Condition`] is one row of the case-frame data format (`docs/reference/case-frame-format.md`): gravity,
//! constant rates, and sinusoidal linear and angular oscillations, all along or about the
//! case axes IA, PA, OA (right-handed). [`Condition::inputs_at`] evaluates what the
//! instrument feels at a time `t`. Gravity is given in g; its value in cm/s² is the
//! instrument file's `local_gravity_cm_s2`, passed in wherever inputs are evaluated (one
//! source).

use std::f64::consts::TAU;

/// Axis indices in every `[f64; 3]` of this module.
pub const IA: usize = 0;
/// Pendulous axis index.
pub const PA: usize = 1;
/// Output axis index.
pub const OA: usize = 2;

/// What a row's measurement is (case-frame column `kind`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RowKind {
    /// `difference` (the default): the mean indicated acceleration in the condition minus
    /// that in its reference condition (same gravity, rates `ref_w_*`, no oscillation).
    #[default]
    Difference,
    /// `absolute`: the mean indicated acceleration itself over the row's gate,
    /// `SF·(2P/T − 1)` with the instrument file's nominal SF (a tumble or centrifuge
    /// position), no reference subtracted.
    Absolute,
    /// `response`: a sinusoidal input along IA (`freq_hz`, `lin_ia_cm_s2`) and the
    /// output's component at that frequency: `measured_gain` (output amplitude over input
    /// amplitude) and `measured_phase_deg` (output phase minus input phase).
    Response,
}

impl RowKind {
    /// Its name in the case frame.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            RowKind::Difference => "difference",
            RowKind::Absolute => "absolute",
            RowKind::Response => "response",
        }
    }

    /// The kind named `s` in the case frame.
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "difference" => Some(RowKind::Difference),
            "absolute" => Some(RowKind::Absolute),
            "response" => Some(RowKind::Response),
            _ => None,
        }
    }
}

/// Which way the input along IA last moved before a row was read (case-frame column
/// `approach`): the lab's record of the direction of approach of a tumble position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Approach {
    /// `up` (or `+`): the input along IA rose to this reading (approached from below).
    Up,
    /// `down` (or `-`): the input along IA fell to this reading (approached from above).
    Down,
}

impl Approach {
    /// The spellings the case frame accepts, in order: `up`, `down`, `+`, `-`.
    pub const WORDS: &[&str] = &["up", "down", "+", "-"];

    /// Its name in the case frame (`up`, `down`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Approach::Up => "up",
            Approach::Down => "down",
        }
    }

    /// The approach written `s` in the case frame (`up` or `+`, `down` or `-`).
    #[must_use]
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "up" | "+" => Some(Approach::Up),
            "down" | "-" => Some(Approach::Down),
            _ => None,
        }
    }

    /// +1 for up, −1 for down.
    #[must_use]
    pub fn sign(self) -> f64 {
        match self {
            Approach::Up => 1.0,
            Approach::Down => -1.0,
        }
    }
}

/// What a row takes from the rows around it: the direction of approach of its input along
/// IA and its temperature from the file's reference temperature. Zero until
/// [`with_history`] sets it from the recorded `approach` and `temp_c` and the order of the
/// rows; a row built alone (a plan, the advice) keeps zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct History {
    /// The approach sign s ∈ {−1, 0, +1} of an absolute row (0 for a difference or
    /// response row: its reference run is read at the same position after the same
    /// approach, so a hysteresis cancels).
    pub approach_sign: f64,
    /// ΔT = `temp_c` − the reference temperature (the mean of the file's `temp_c`), °C;
    /// 0 without `temp_c`.
    pub delta_t_c: f64,
    /// The time since the instrument was switched on over the span of the run (both in
    /// `time_s`), or `None` when the rows do not all give `time_s`.
    pub t_on_span: Option<f64>,
    /// The time since the instrument was switched on, s (`None` as `t_on_span`).
    pub t_on_s: Option<f64>,
}

/// One test condition (one row of a case-frame file). Every oscillation runs at `freq_hz`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Condition {
    /// Free text.
    pub label: String,
    /// What `measured_cm_s2` is (case-frame column `kind`).
    pub kind: RowKind,
    /// The rows that share a reference run (case-frame column `block`; `None` = the one
    /// block of the file). A bias shift per block is a nuisance term of `ptsa discover`.
    pub block: Option<String>,
    /// When the row was measured, s (case-frame column `time_s`; `None` = row order). A
    /// linear drift in time is a nuisance term of `ptsa discover`.
    pub time_s: Option<f64>,
    /// Gravity's specific force along IA, PA, OA with the case at rest, in g (the instrument
    /// file's local gravity).
    pub g: [f64; 3],
    /// Constant angular rate of the case about IA, PA, OA, rad/s.
    pub w_rad_s: [f64; 3],
    /// Frequency of every oscillation, Hz (0 = none).
    pub freq_hz: f64,
    /// Linear vibration amplitude along IA, PA, OA, cm/s²: `amp·sin(2πft + phase)`.
    pub lin_cm_s2: [f64; 3],
    /// Phase of each linear vibration, degrees.
    pub lin_deg: [f64; 3],
    /// Angular oscillation amplitude about IA, PA, OA, mrad: angle `amp·sin(2πft + phase)`.
    pub ang_mrad: [f64; 3],
    /// Phase of each angular oscillation, degrees.
    pub ang_deg: [f64; 3],
    /// Constant rates of the reference condition (same gravity, no oscillation), rad/s.
    pub ref_w_rad_s: [f64; 3],
    /// Distance of the proof mass from the axis of the constant rates (a centrifuge arm), cm;
    /// see [`Condition::centripetal_cm_s2`] for where its acceleration points (0 = none).
    pub radius_cm: f64,
    /// Measured mean indicated acceleration minus the reference's, cm/s² (if measured).
    pub measured_cm_s2: Option<f64>,
    /// 1-sigma uncertainty of `measured_cm_s2`, cm/s² (if given).
    pub sigma_cm_s2: Option<f64>,
    /// A response row's measured gain, output amplitude over input amplitude.
    pub measured_gain: Option<f64>,
    /// A response row's measured phase, output minus input, degrees.
    pub measured_phase_deg: Option<f64>,
    /// 1-sigma uncertainty of `measured_gain`.
    pub sigma_gain: Option<f64>,
    /// 1-sigma uncertainty of `measured_phase_deg`, degrees.
    pub sigma_phase_deg: Option<f64>,
    /// The direction of approach the lab recorded (case-frame column `approach`; `None`:
    /// not recorded, then [`with_history`] derives it from the change of the input along
    /// IA since the previous row).
    pub approach: Option<Approach>,
    /// The instrument's temperature during the row, °C (case-frame column `temp_c`).
    pub temp_c: Option<f64>,
    /// 1-sigma error of the position's orientation, µrad, about each of the two axes across
    /// IA (how precisely the fixture sets the case; case-frame column `sigma_angle_urad`).
    /// It is noise, not physics: an absolute row's reading varies by it times the static
    /// specific force across IA ([`Condition::fixture_sigma_cm_s2`]).
    pub sigma_angle_urad: Option<f64>,
    /// When the instrument was last switched on before the row, s on the `time_s` clock
    /// (case-frame column `power_on_s`; `None`: an earlier row's, else the first row's
    /// time).
    pub power_on_s: Option<f64>,
    /// Pulses of positive torque counted over the row's gate (case-frame column `pulses`;
    /// an absolute row's measurement given as counts, with [`Condition::ticks`]: a whole
    /// number from 0 to `ticks`). [`crate::model::counts::with_counts`] turns them into
    /// `measured_cm_s2` with the instrument's nominal scale factor.
    pub pulses: Option<f64>,
    /// Clock ticks of the row's gate (case-frame column `ticks`; a whole number greater
    /// than 0).
    pub ticks: Option<f64>,
    /// The 1-sigma counting error of `measured_cm_s2` when it was converted from
    /// `pulses` and `ticks`, cm/s² (set by [`crate::model::counts::with_counts`]; not a
    /// case-frame column). Like the fixture's orientation error it is known noise of the
    /// row, added in quadrature to its stated or estimated sigma.
    pub counting_sigma_cm_s2: Option<f64>,
    /// What the row takes from the rows around it ([`with_history`]).
    pub history: History,
}

impl Condition {
    /// Whether the row holds a measurement (`measured_cm_s2` or counts, or a response's
    /// gain or phase).
    #[must_use]
    pub fn is_measured(&self) -> bool {
        match self.kind {
            RowKind::Response => self.measured_gain.is_some() || self.measured_phase_deg.is_some(),
            // Counts are a measurement before they are converted.
            _ => self.measured_cm_s2.is_some() || self.pulses.is_some(),
        }
    }
}

/// What the instrument feels at one instant, in case axes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CaseInputs {
    /// Specific force along IA, PA, OA (gravity + vibration), cm/s².
    pub a_cm_s2: [f64; 3],
    /// Angular rate about IA, PA, OA, rad/s.
    pub w_rad_s: [f64; 3],
    /// Angular acceleration about IA, PA, OA, rad/s².
    pub dw_rad_s2: [f64; 3],
    /// The approach sign of the row's input along IA, −1, 0 or +1 ([`History`]).
    pub approach: f64,
    /// The row's temperature from the reference temperature, °C ([`History`]).
    pub delta_t_c: f64,
    /// The time since power-on over the run's span ([`History`]; `None`: no `time_s`).
    pub t_on_span: Option<f64>,
}

impl Condition {
    /// Every input of the condition as bits: all its fields but the free text (label, block,
    /// time) and the measurement, which no run reads. Two conditions with the same bits are
    /// the same run (`-0.0` and `0.0` differ; a NaN never meets another). The destructuring
    /// names every field, so one added to [`Condition`] does not compile here until it is
    /// placed.
    #[must_use]
    pub fn input_bits(&self) -> Vec<u64> {
        let Condition {
            label: _,
            kind,
            block: _,
            time_s: _,
            g,
            w_rad_s,
            freq_hz,
            lin_cm_s2,
            lin_deg,
            ang_mrad,
            ang_deg,
            ref_w_rad_s,
            radius_cm,
            measured_cm_s2: _,
            sigma_cm_s2: _,
            measured_gain: _,
            measured_phase_deg: _,
            sigma_gain: _,
            sigma_phase_deg: _,
            // Recorded inputs enter through `history`, what the physics reads.
            approach: _,
            temp_c: _,
            power_on_s: _,
            sigma_angle_urad: _,
            pulses: _,
            ticks: _,
            counting_sigma_cm_s2: _,
            history,
        } = self;
        let mut k: Vec<u64> = Vec::with_capacity(32 + crate::model::effects::N_CANDIDATES);
        k.push(*kind as u64);
        for v in [
            g,
            w_rad_s,
            lin_cm_s2,
            lin_deg,
            ang_mrad,
            ang_deg,
            ref_w_rad_s,
        ] {
            k.extend(v.iter().map(|x| x.to_bits()));
        }
        k.push(freq_hz.to_bits());
        k.push(radius_cm.to_bits());
        k.push(history.approach_sign.to_bits());
        k.push(history.delta_t_c.to_bits());
        k.push(history.t_on_span.map_or(u64::MAX, f64::to_bits));
        k.push(history.t_on_s.map_or(u64::MAX, f64::to_bits));
        k
    }

    /// The reference condition: same gravity, rates `ref_w_rad_s`, no oscillation; read at
    /// the same position after the same approach and at the same temperature (its
    /// [`History`] is the row's).
    #[must_use]
    pub fn reference(&self) -> Condition {
        Condition {
            label: format!("{} (reference)", self.label),
            g: self.g,
            w_rad_s: self.ref_w_rad_s,
            ref_w_rad_s: self.ref_w_rad_s,
            radius_cm: self.radius_cm,
            approach: self.approach,
            temp_c: self.temp_c,
            power_on_s: self.power_on_s,
            history: self.history,
            ..Condition::default()
        }
    }

    /// The 1-sigma error of the row's reading that its orientation error
    /// (`sigma_angle_urad`) makes, cm/s²: a small rotation `δ` of the case changes the
    /// specific force along IA by `δ_PA·a_OA − δ_OA·a_PA`, so independent errors of σ about
    /// PA and OA give `σ·√(a_PA² + a_OA²)`, with `a` the static specific force (gravity and
    /// a centrifuge arm's). A difference row is read at one placement, condition against
    /// reference: the error of the gravity cancels and what is left is `σ` times the
    /// difference of the two specific forces across IA. A response row's gain and phase
    /// do not depend on it (0), nor does a row without the column.
    #[must_use]
    pub fn fixture_sigma_cm_s2(&self, g_cm_s2: f64) -> f64 {
        let Some(s_urad) = self.sigma_angle_urad else {
            return 0.0;
        };
        let across = |c: &Condition| {
            let a = c.prepare(g_cm_s2).mean_inputs().a_cm_s2;
            [a[1], a[2]]
        };
        let a = match self.kind {
            RowKind::Absolute => across(self),
            RowKind::Difference => {
                let (c, r) = (across(self), across(&self.reference()));
                [c[0] - r[0], c[1] - r[1]]
            }
            RowKind::Response => return 0.0,
        };
        s_urad * 1e-6 * a[0].hypot(a[1])
    }

    /// The specific force of a centrifuge arm, cm/s², in case axes: with the proof mass at
    /// `radius_cm` from the spin axis (the axis of the constant rates `w_rad_s`), the case
    /// feels `|w|²·radius` pointing **from the proof mass toward the spin axis**, and the
    /// instrument is taken to be mounted with its input axis pointing at the spin axis: the
    /// direction is the projection of +IA onto the plane perpendicular to `w`,
    /// `û = (IA − (IA·ŵ)ŵ)/|…|`. A positive radius thus reads as a positive input along IA
    /// (times the cosine of IA's tilt out of the turntable plane); a negative radius means
    /// IA points away from the axis. Tilting the rate vector within the IA–PA (or IA–OA)
    /// plane puts part of the acceleration along PA (or OA). Zero without a radius or a
    /// rate; `None` when IA lies along the spin axis, where the direction is undefined.
    #[must_use]
    pub fn centripetal_cm_s2(&self, w_rad_s: [f64; 3]) -> Option<[f64; 3]> {
        let w2 = w_rad_s.iter().map(|x| x * x).sum::<f64>();
        if self.radius_cm == 0.0 || w2 == 0.0 {
            return Some([0.0; 3]);
        }
        let w_ia = w_rad_s[0] / w2.sqrt();
        // IA − (IA·ŵ)ŵ, with IA = (1, 0, 0).
        let mut u = w_rad_s.map(|x| -w_ia * x / w2.sqrt());
        u[0] += 1.0;
        let nu = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        if nu < 1e-9 {
            return None;
        }
        Some(u.map(|x| w2 * self.radius_cm * x / nu))
    }

    /// Whether anything in the condition varies with time.
    #[must_use]
    pub fn is_static(&self) -> bool {
        self.freq_hz == 0.0
            || (self.lin_cm_s2.iter().all(|&x| x == 0.0) && self.ang_mrad.iter().all(|&x| x == 0.0))
    }

    /// Case-frame inputs at time `t` (s), with local gravity `g_cm_s2`.
    ///
    /// Angular oscillation about axis j is the small angle `φ_j(t) = amp_j·1e-3·sin(ωt + p_j)`;
    /// its rate `φ̇_j` adds to `w_rad_s[j]` and `φ̈_j` is the angular acceleration. Gravity,
    /// fixed in the laboratory, is seen from the oscillating case rotated by `−φ` to first
    /// order: `g_case = g − φ × g`. Constant rates are taken to turn the case about a
    /// gravity-fixed axis (a rate table), so they do not rotate gravity in the case frame.
    #[must_use]
    pub fn inputs_at(&self, t: f64, g_cm_s2: f64) -> CaseInputs {
        let p = self.prepare(g_cm_s2);
        let (s, c) = (p.omega * t).sin_cos();
        p.inputs(s, c)
    }

    /// The condition reduced to per-axis sine and cosine coefficients of the common phase
    /// `ωt`, so that [`Prepared::inputs`] needs no trigonometry (the simulator's hot path).
    /// `g_cm_s2` is the local gravity (the instrument file's).
    #[must_use]
    pub fn prepare(&self, g_cm_s2: f64) -> Prepared {
        let omega = TAU * self.freq_hz;
        let mut p = Prepared {
            omega,
            g: self.g.map(|x| x * g_cm_s2),
            centripetal: self.centripetal_cm_s2(self.w_rad_s).unwrap_or([0.0; 3]),
            w0: self.w_rad_s,
            approach: self.history.approach_sign,
            delta_t_c: self.history.delta_t_c,
            t_on_span: self.history.t_on_span,
            ..Prepared::default()
        };
        if self.freq_hz != 0.0 {
            for j in 0..3 {
                if self.lin_cm_s2[j] != 0.0 {
                    let (sp, cp) = self.lin_deg[j].to_radians().sin_cos();
                    p.lin_s[j] = self.lin_cm_s2[j] * cp;
                    p.lin_c[j] = self.lin_cm_s2[j] * sp;
                }
                if self.ang_mrad[j] != 0.0 {
                    let amp = self.ang_mrad[j] * 1e-3;
                    let (sp, cp) = self.ang_deg[j].to_radians().sin_cos();
                    p.phi_s[j] = amp * cp;
                    p.phi_c[j] = amp * sp;
                }
            }
        }
        p
    }
}

/// A [`Condition`] prepared for fast evaluation: every oscillation written as
/// `x_s·sin(ωt) + x_c·cos(ωt)` (`sin(ωt + p) = sin ωt·cos p + cos ωt·sin p`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Prepared {
    /// Angular frequency of every oscillation, rad/s.
    pub omega: f64,
    /// Gravity's specific force along IA, PA, OA, cm/s².
    pub g: [f64; 3],
    /// A centrifuge arm's specific force along IA, PA, OA, cm/s².
    pub centripetal: [f64; 3],
    /// Constant rates, rad/s.
    pub w0: [f64; 3],
    /// Linear vibration, sine coefficient, cm/s².
    pub lin_s: [f64; 3],
    /// Linear vibration, cosine coefficient, cm/s².
    pub lin_c: [f64; 3],
    /// Angular oscillation, sine coefficient, rad.
    pub phi_s: [f64; 3],
    /// Angular oscillation, cosine coefficient, rad.
    pub phi_c: [f64; 3],
    /// The approach sign ([`History::approach_sign`]).
    pub approach: f64,
    /// The temperature from the reference, °C ([`History::delta_t_c`]).
    pub delta_t_c: f64,
    /// The time since power-on over the run's span ([`History::t_on_span`]).
    pub t_on_span: Option<f64>,
}

impl Prepared {
    /// Every field's bits, for grouping conditions that feel the same inputs (the batch
    /// engine computes such lanes' inputs once). The destructuring names every field, so a
    /// field added to the struct does not compile here until it is part of the key (a key
    /// that listed the fields by hand once left out `centripetal`: two centrifuge arms came
    /// back with one's value).
    #[must_use]
    pub fn key_bits(&self) -> Vec<u64> {
        let Prepared {
            omega,
            g,
            centripetal,
            w0,
            lin_s,
            lin_c,
            phi_s,
            phi_c,
            approach,
            delta_t_c,
            t_on_span,
        } = self;
        [omega, approach, delta_t_c]
            .into_iter()
            .chain(g)
            .chain(centripetal)
            .chain(w0)
            .chain(lin_s)
            .chain(lin_c)
            .chain(phi_s)
            .chain(phi_c)
            .map(|x| x.to_bits())
            .chain(std::iter::once(t_on_span.map_or(u64::MAX, f64::to_bits)))
            .collect()
    }

    /// Case-frame inputs given `s = sin(ωt)`, `c = cos(ωt)` (same model as
    /// [`Condition::inputs_at`]).
    #[inline]
    #[must_use]
    pub fn inputs(&self, s: f64, c: f64) -> CaseInputs {
        let w = self.omega;
        let mut a = self.g;
        let mut phi = [0.0; 3];
        let mut rate = self.w0;
        let mut dw = [0.0; 3];
        for j in 0..3 {
            a[j] += self.lin_s[j] * s + self.lin_c[j] * c;
            phi[j] = self.phi_s[j] * s + self.phi_c[j] * c;
            rate[j] += w * (self.phi_s[j] * c - self.phi_c[j] * s);
            dw[j] = -w * w * phi[j];
        }
        let phi_x_g = cross(phi, self.g);
        for j in 0..3 {
            a[j] -= phi_x_g[j];
            a[j] += self.centripetal[j];
        }
        CaseInputs {
            a_cm_s2: a,
            w_rad_s: rate,
            dw_rad_s2: dw,
            approach: self.approach,
            delta_t_c: self.delta_t_c,
            t_on_span: self.t_on_span,
        }
    }

    /// The time-invariant part: gravity and the constant rates.
    #[must_use]
    pub fn mean_inputs(&self) -> CaseInputs {
        CaseInputs {
            a_cm_s2: [0, 1, 2].map(|j| self.g[j] + self.centripetal[j]),
            w_rad_s: self.w0,
            dw_rad_s2: [0.0; 3],
            approach: self.approach,
            delta_t_c: self.delta_t_c,
            t_on_span: self.t_on_span,
        }
    }

    /// Whether anything varies with time.
    #[must_use]
    pub fn is_dynamic(&self) -> bool {
        self.omega != 0.0
            && (self
                .lin_s
                .iter()
                .chain(&self.lin_c)
                .chain(&self.phi_s)
                .chain(&self.phi_c))
            .any(|&x| x != 0.0)
    }
}

/// A change of the mean input along IA smaller than this fraction of local gravity is no
/// change (0° and 360° of a tumble differ by rounding).
pub const APPROACH_RESOLUTION: f64 = 1e-9;

/// The rows' indices in the order they were measured: by `time_s` when every row gives it
/// (ties in file order), else the file's order.
#[must_use]
pub fn measurement_order(rows: &[Condition]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    if rows.iter().all(|r| r.time_s.is_some()) {
        order.sort_by(|&a, &b| {
            rows[a]
                .time_s
                .unwrap_or_default()
                .total_cmp(&rows[b].time_s.unwrap_or_default())
        });
    }
    order
}

/// The span of a run the time since power-on is measured against
/// ([`History::t_on_span`]), s: the last row's `time_s` less the earliest power-on time
/// (the earliest `power_on_s`, or the first row's time when earlier); `None` unless every
/// row gives `time_s` and the span is positive.
#[must_use]
pub fn warm_up_span_s(rows: &[Condition]) -> Option<f64> {
    let times: Vec<f64> = rows.iter().map(|r| r.time_s).collect::<Option<_>>()?;
    let first = times.iter().copied().fold(f64::INFINITY, f64::min);
    let last = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let start = rows
        .iter()
        .filter_map(|r| r.power_on_s)
        .fold(first, f64::min);
    Some(last - start).filter(|&s| s > 0.0)
}

/// `rows` with their [`History`] set: what each row takes from the rows around it.
///
/// * **Approach sign** of an absolute row: the recorded `approach` (+1 up, −1 down) when
///   given; otherwise the sign of the change of the mean input along IA (gravity and a
///   centrifuge arm's push, `Prepared::mean_inputs`) since the previous row of the file in
///   time order (`time_s` when every row gives it, ties in file order; else file order),
///   whatever that row's kind; 0 for the first row and for a change below
///   [`APPROACH_RESOLUTION`]·g. Difference and response rows get 0.
/// * **ΔT** = `temp_c` − the mean `temp_c` of the rows that give one; 0 for a row without.
/// * **Time since power-on** over the span of the run, when every row gives `time_s`: the
///   row's time less its power-on time (its `power_on_s`, else the latest one given on an
///   earlier row in time order, else the first row's time), over the last row's time less
///   the earliest power-on time; `None` without `time_s` on every row or with a span of 0.
#[must_use]
pub fn with_history(rows: &[Condition], g_cm_s2: f64) -> Vec<Condition> {
    let mut out = rows.to_vec();
    let temps: Vec<f64> = rows.iter().filter_map(|r| r.temp_c).collect();
    #[allow(clippy::cast_precision_loss)]
    let t_ref = if temps.is_empty() {
        0.0
    } else {
        temps.iter().sum::<f64>() / temps.len() as f64
    };
    let order = measurement_order(rows);
    let tol = APPROACH_RESOLUTION * g_cm_s2.abs();
    let timed = !rows.is_empty() && rows.iter().all(|r| r.time_s.is_some());
    let times: Vec<f64> = rows.iter().map(|r| r.time_s.unwrap_or(0.0)).collect();
    let first = times.iter().copied().fold(f64::INFINITY, f64::min);
    let span = warm_up_span_s(rows).unwrap_or(0.0);
    let mut power_on = first;
    let mut prev: Option<f64> = None;
    for i in order {
        let r = &rows[i];
        let a = r.prepare(g_cm_s2).mean_inputs().a_cm_s2[IA];
        let derived = match prev {
            Some(p) if a - p > tol => 1.0,
            Some(p) if p - a > tol => -1.0,
            _ => 0.0,
        };
        prev = Some(a);
        let approach_sign = match r.kind {
            RowKind::Absolute => r.approach.map_or(derived, Approach::sign),
            RowKind::Difference | RowKind::Response => 0.0,
        };
        if let Some(p) = r.power_on_s {
            power_on = p;
        }
        out[i].history = History {
            approach_sign,
            delta_t_c: r.temp_c.map_or(0.0, |t| t - t_ref),
            t_on_span: (timed && span > 0.0).then(|| (times[i] - power_on) / span),
            t_on_s: (timed && span > 0.0).then(|| times[i] - power_on),
        };
    }
    out
}

/// Cross product.
#[must_use]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_centrifuge_arm_pushes_along_the_projection_of_ia() {
        let g = 980.4;
        // Spin about OA (IA and PA in the turntable plane), 100 cm arm: |w|²R along IA.
        let mut c = Condition {
            g: [0.0, 0.0, 1.0],
            w_rad_s: [0.0, 0.0, 3.0],
            radius_cm: 100.0,
            ..Condition::default()
        };
        let i = c.inputs_at(0.0, g);
        assert!((i.a_cm_s2[IA] - 900.0).abs() < 1e-9 && i.a_cm_s2[PA].abs() < 1e-12);
        assert!((i.a_cm_s2[OA] - g).abs() < 1e-9);
        // The rate vector tilted by β in the IA–PA plane: the push along cos β IA + sin β PA.
        let b = 30f64.to_radians();
        c.w_rad_s = [-3.0 * b.sin(), 3.0 * b.cos(), 0.0];
        c.g = [-b.sin(), b.cos(), 0.0];
        let i = c.inputs_at(0.0, g);
        assert!((i.a_cm_s2[IA] - (900.0 * b.cos() - g * b.sin())).abs() < 1e-9);
        assert!((i.a_cm_s2[PA] - (900.0 * b.sin() + g * b.cos())).abs() < 1e-9);
        // IA along the spin axis: undefined.
        c.w_rad_s = [2.0, 0.0, 0.0];
        assert!(c.centripetal_cm_s2(c.w_rad_s).is_none());
    }

    /// The orientation error of a row, by hand: 1000 µrad at `g = (0.6, 0.8, 0)` is
    /// 1e-3 · 0.8 g across IA, and at `g = (0, 0, 1)` 1e-3 · g; a difference row on a rate
    /// table about OA leaves nothing (gravity cancels), nor does an arm there (its push is
    /// along IA, none of it across); a response row or a row without the column: 0.
    #[test]
    fn a_fixture_error_is_the_angle_times_the_specific_force_across_ia() {
        let g = 980.0;
        let mut c = Condition {
            kind: RowKind::Absolute,
            g: [0.6, 0.8, 0.0],
            sigma_angle_urad: Some(1000.0),
            ..Condition::default()
        };
        assert!((c.fixture_sigma_cm_s2(g) - 1e-3 * 0.8 * g).abs() < 1e-12);
        c.g = [0.0, 0.0, 1.0];
        assert!((c.fixture_sigma_cm_s2(g) - 1e-3 * g).abs() < 1e-12);
        c.kind = RowKind::Difference;
        c.w_rad_s = [0.0, 0.0, 2.0];
        assert!(c.fixture_sigma_cm_s2(g) == 0.0);
        c.radius_cm = 10.0;
        assert!(c.fixture_sigma_cm_s2(g) < 1e-12);
        c.kind = RowKind::Response;
        assert!(c.fixture_sigma_cm_s2(g) == 0.0);
        c.kind = RowKind::Absolute;
        c.sigma_angle_urad = None;
        assert!(c.fixture_sigma_cm_s2(g) == 0.0);
    }

    /// A tumble's rows without `approach`: +1 where `g_ia` rose since the previous row,
    /// −1 where it fell, 0 at the first row and where it did not change; `time_s` reorders;
    /// a recorded approach wins; a difference row gets 0; ΔT from the mean `temp_c`; the
    /// reference run keeps the row's history.
    #[test]
    fn history_is_the_sign_of_the_last_change_and_the_temperature_from_the_mean() {
        let g = 980.4;
        let row = |g_ia: f64| Condition {
            kind: RowKind::Absolute,
            g: [g_ia, (1.0 - g_ia * g_ia).sqrt(), 0.0],
            ..Condition::default()
        };
        let rows = vec![row(0.0), row(0.5), row(0.5), row(-0.2), row(1.0)];
        let signs = |rows: &[Condition]| -> Vec<f64> {
            with_history(rows, g)
                .iter()
                .map(|r| r.history.approach_sign)
                .collect()
        };
        assert_eq!(signs(&rows), [0.0, 1.0, 0.0, -1.0, 1.0]);
        // Measured in another order (time_s): the previous row in time.
        let mut timed = rows.clone();
        for (r, t) in timed.iter_mut().zip([40.0, 10.0, 30.0, 20.0, 0.0]) {
            r.time_s = Some(t);
        }
        // Time order: rows 4 (1.0), 1 (0.5), 3 (−0.2), 2 (0.5), 0 (0.0).
        assert_eq!(signs(&timed), [-1.0, -1.0, 1.0, -1.0, 0.0]);
        // The lab's record wins; a difference row has none.
        let mut recorded = rows.clone();
        recorded[1].approach = Some(Approach::Down);
        recorded[2].approach = Some(Approach::Up);
        recorded[3].kind = RowKind::Difference;
        assert_eq!(signs(&recorded), [0.0, -1.0, 1.0, 0.0, 1.0]);
        // ΔT from the mean of the rows that give one; the reference keeps the history.
        let mut warm = rows;
        for (r, t) in warm.iter_mut().zip([20.0, 21.0, 22.0, 23.0]) {
            r.temp_c = Some(t);
        }
        let h = with_history(&warm, g);
        let dt: Vec<f64> = h.iter().map(|r| r.history.delta_t_c).collect();
        assert_eq!(dt, [-1.5, -0.5, 0.5, 1.5, 0.0]);
        assert_eq!(h[3].reference().history, h[3].history);
        let i = h[3].inputs_at(0.0, g);
        assert_eq!((i.approach, i.delta_t_c), (-1.0, 1.5));
        // 0° and 360° of a tumble differ by rounding only: no change.
        let turn = |deg: f64| {
            let (s, c) = f64::to_radians(deg).sin_cos();
            Condition {
                kind: RowKind::Absolute,
                g: [c, s, 0.0],
                ..Condition::default()
            }
        };
        assert_eq!(signs(&[turn(0.0), turn(360.0)]), [0.0, 0.0]);
    }

    /// The time since power-on over the run's span: from the first row's time, or from
    /// the latest `power_on_s` given on a row at or before it in time order; none without
    /// `time_s` on every row.
    #[test]
    fn time_since_power_on_is_over_the_span_of_the_run() {
        let row = |t: Option<f64>, on: Option<f64>| Condition {
            kind: RowKind::Absolute,
            time_s: t,
            power_on_s: on,
            ..Condition::default()
        };
        let t_on = |rows: &[Condition]| -> Vec<Option<f64>> {
            with_history(rows, 980.4)
                .iter()
                .map(|r| r.history.t_on_span)
                .collect()
        };
        let rows = [
            row(Some(100.0), None),
            row(Some(150.0), None),
            row(Some(200.0), None),
        ];
        assert_eq!(t_on(&rows), [Some(0.0), Some(0.5), Some(1.0)]);
        // Switched on at 0 s, and again at 160 s (the third row's record).
        let rows = [
            row(Some(100.0), Some(0.0)),
            row(Some(150.0), None),
            row(Some(200.0), Some(160.0)),
        ];
        assert_eq!(t_on(&rows), [Some(0.5), Some(0.75), Some(0.2)]);
        assert_eq!(t_on(&[row(Some(1.0), None), row(None, None)]), [None, None]);
        assert_eq!(t_on(&[row(Some(5.0), None)]), [None]);
    }

    #[test]
    fn oscillation_about_oa_tilts_gravity_into_ia() {
        // IA horizontal, PA up (g_pa = 1): a rotation φ about OA moves gravity into IA.
        let c = Condition {
            g: [0.0, 1.0, 0.0],
            freq_hz: 1.0,
            ang_mrad: [0.0, 0.0, 2.0],
            ..Condition::default()
        };
        let g = 980.4;
        let i = c.inputs_at(0.25, g); // sin = 1: φ_OA = 2 mrad
        // −(φ × g)_IA = −(φ_PA g_OA − φ_OA g_PA) = φ_OA g_PA
        assert!((i.a_cm_s2[IA] - 2e-3 * g).abs() < 1e-9);
        assert!((i.dw_rad_s2[OA] + 2e-3 * TAU * TAU).abs() < 1e-9);
    }
}
