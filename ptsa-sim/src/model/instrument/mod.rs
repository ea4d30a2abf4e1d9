//! The instrument file (`data/kearfott-2401.toml`): Table 2.1 of R-890 with tolerances, and
//! the PTSA electronics, validated on load; or, for an accelerometer without a PTSA loop
//! (`data/navigation.toml`, `data/mems.toml`), only what a calibration needs: its name and
//! class, its reading's unit and nominal scale, its nominal bias, local gravity, the nominal
//! terms of its IEEE 1293 model equation (`[model_equation]`, which a file with a loop may
//! give too) and the plausibility bounds.

mod board;
mod read;
mod rewrite;
mod schema;
mod units;

pub use board::Board;
pub use read::InstrumentError;
pub use schema::{
    ADC_FULL_SCALE, ADC_OFFSET, AMPLIFIER_GAIN, ANISOINERTIA, BIAS, CLOCK, DAMPING,
    DEMODULATOR_BANDWIDTH, FREEDOM, Form, INERTIA, LOCAL_GRAVITY, LOOP_SECTIONS, MODEL_EQUATION,
    ModelEquationKey, NOISE, PARAMETERS, PENDULOSITY, PHASE, PICKOFF_SF, Parameter, Plausibility,
    QUADRATURE, SCALE_FACTOR, SPRING, STOP_DAMPING, STOP_STIFFNESS, TORQUER_SF, TORQUER_TAU,
    Tolerance, toleranceable,
};
pub use units::{ReadingScale, ReadingUnit};

use crate::model::effects::{CandidateId, Effects};

/// The shipped instrument file, compiled in.
pub const KEARFOTT_2401_TOML: &str = include_str!("../../../../data/kearfott-2401.toml");
/// The shipped file of a navigation-grade servo (force-rebalance) accelerometer: no PTSA
/// loop, the bounds of that class.
pub const NAVIGATION_TOML: &str = include_str!("../../../../data/navigation.toml");
/// The shipped file of one axis of a consumer MEMS accelerometer: no PTSA loop, the bounds
/// of that class.
pub const MEMS_TOML: &str = include_str!("../../../../data/mems.toml");

/// The shipped instrument files, by the name `--instrument` and `ptsa instrument new
/// --class` take: `(name, path in the repository, text)`. The first is the default.
pub const SHIPPED: &[(&str, &str, &str)] = &[
    (
        "kearfott-2401",
        "data/kearfott-2401.toml",
        KEARFOTT_2401_TOML,
    ),
    ("navigation", "data/navigation.toml", NAVIGATION_TOML),
    ("mems", "data/mems.toml", MEMS_TOML),
];

/// The shipped instrument file named `name` ([`SHIPPED`]): its path in the repository and
/// its text.
#[must_use]
pub fn shipped(name: &str) -> Option<(&'static str, &'static str)> {
    SHIPPED
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, path, text)| (path, text))
}

/// The instrument and its electronics, in the simulator's units (cgs, rad, s, V).
#[derive(Debug, Clone, PartialEq)]
pub struct Instrument {
    /// Pendulosity, dyn·cm per g of input (Table 2.1: 1100).
    pub pendulosity_dyn_cm_per_g: f64,
    /// Mechanical freedom (stop position), rad.
    pub freedom_rad: f64,
    /// Output-axis inertia `I_OA`, g·cm² (dyn·cm·s²).
    pub inertia_dyn_cm_s2: f64,
    /// Flexure spring, dyn·cm/rad.
    pub spring_dyn_cm_rad: f64,
    /// Damping `C_OA`, dyn·cm·s.
    pub damping_dyn_cm_s: f64,
    /// Anisoinertia `I_PA − I_IA`, g·cm².
    pub anisoinertia_g_cm2: f64,
    /// Pickoff scale factor, V/rad.
    pub pickoff_v_per_rad: f64,
    /// Quadrature null, V (at the pickoff).
    pub quadrature_v: f64,
    /// Demodulator phase error, rad.
    pub phase_error_rad: f64,
    /// Pickoff-referred noise, V rms per sample.
    pub noise_v_rms: f64,
    /// Torquer current scale factor, mA per g.
    pub current_sf_ma_per_g: f64,
    /// Torquer current rise time constant, s.
    pub torquer_tau_s: f64,
    /// Regulated torquer current, mA: set at load time from the nominal values so that the
    /// full scale equals `sf_cm_s2` (`I = SF/g · current_sf`). Monte Carlo keeps it fixed.
    pub full_current_ma: f64,
    /// Target full scale of the loop (the measured SF), cm/s².
    pub sf_cm_s2: f64,
    /// Bias `A_b` as a torque `P·A_b` on the pendulum, cm/s².
    pub bias_cm_s2: f64,
    /// Amplifier gain, V/V.
    pub amp_gain: f64,
    /// Offset at the ADC's input, V (after the amplifier): a constant code offset, as the
    /// quadrature the pickoff phase leaks.
    pub adc_offset_v: f64,
    /// Demodulator low-pass corner, Hz.
    pub demod_bandwidth_hz: f64,
    /// ADC full scale, ±V.
    pub adc_full_scale_v: f64,
    /// Clock, Hz.
    pub clock_hz: f64,
    /// Local gravity, cm/s².
    pub g_cm_s2: f64,
    /// Whether the command line set the local gravity (`--local-gravity`), not the file.
    pub gravity_from_command_line: bool,
    /// Stop contact stiffness, dyn·cm/rad.
    pub stop_stiffness_dyn_cm_rad: f64,
    /// Stop contact damping, dyn·cm·s.
    pub stop_damping_dyn_cm_s: f64,
    /// Tolerance box of every toleranced parameter.
    pub tolerances: Vec<Tolerance>,
    /// Plausibility bounds of the discovery candidates.
    pub plausibility: Plausibility,
    /// The board's front end (`[board]`), if the file describes one: the host loop then
    /// quantizes the pickoff as that converter does.
    pub board: Option<Board>,
    /// Whether the file describes a PTSA loop (Table 2.1's sections): without one, every
    /// loop field above is 0, nothing can run the closed loop, and no loop parameter is a
    /// discovery candidate.
    pub has_loop: bool,
    /// `instrument.name`, if the file gives one.
    pub name: Option<String>,
    /// `instrument.class`, if the file gives one.
    pub class: Option<String>,
    /// The nominal scale of the raw reading (`instrument.reading_unit`,
    /// `instrument.scale_factor_per_g`), if the file gives one.
    pub reading_scale: Option<ReadingScale>,
    /// The nominal model-equation terms of `[model_equation]` as candidate coefficients
    /// (0 for every other candidate): the baseline model includes them
    /// ([`Instrument::with_nominal_terms`]).
    pub nominal: Effects,
}

impl Instrument {
    /// The shipped Kearfott 2401 file (compiled in).
    ///
    /// # Panics
    /// Never for the shipped file (a unit test parses it).
    #[must_use]
    pub fn kearfott_2401() -> Self {
        Self::parse(KEARFOTT_2401_TOML, "data/kearfott-2401.toml")
            .expect("the shipped instrument file is valid")
    }

    /// Pendulosity `m·l`, g·cm: torque per unit specific force, dyn·cm per cm/s².
    #[must_use]
    pub fn pendulosity_g_cm(&self) -> f64 {
        self.pendulosity_dyn_cm_per_g / self.g_cm_s2
    }

    /// Torquer torque constant, dyn·cm per mA: `pendulosity / current scale factor`.
    #[must_use]
    pub fn torquer_dyn_cm_per_ma(&self) -> f64 {
        self.pendulosity_dyn_cm_per_g / self.current_sf_ma_per_g
    }

    /// Torque at full current, dyn·cm (`= P·SF` for the nominal instrument).
    #[must_use]
    pub fn full_torque_dyn_cm(&self) -> f64 {
        self.torquer_dyn_cm_per_ma() * self.full_current_ma
    }

    /// The loop's actual full scale, cm/s²: full torque over pendulosity (`= g·I/current_sf`).
    #[must_use]
    pub fn actual_sf_cm_s2(&self) -> f64 {
        self.full_torque_dyn_cm() / self.pendulosity_g_cm()
    }

    /// ADC codes per radian of pendulum angle: `pickoff · gain / (FS / 2^15)`.
    #[must_use]
    pub fn lsb_per_rad(&self) -> f64 {
        self.pickoff_v_per_rad * self.amp_gain / (self.adc_full_scale_v / 32768.0)
    }

    /// Pendulum angle per ADC LSB, rad (76.294 nrad nominal).
    #[must_use]
    pub fn theta_lsb_rad(&self) -> f64 {
        1.0 / self.lsb_per_rad()
    }

    /// Set one parameter that can carry a tolerance ([`toleranceable`]) by its file key, in
    /// the file's unit. The regulated current is not re-derived (the PTSA keeps its
    /// setting).
    ///
    /// # Errors
    /// Unknown key.
    pub fn set(&mut self, key: &str, v: f64) -> Result<(), String> {
        let p = toleranceable(key).ok_or_else(|| format!("unknown parameter {key}"))?;
        p.set(self, v);
        Ok(())
    }

    /// One toleranced parameter by its file key, in the file's unit (the inverse of
    /// [`Instrument::set`]); `None` for an unknown key.
    #[must_use]
    pub fn get(&self, key: &str) -> Option<f64> {
        toleranceable(key).map(|p| p.get(self))
    }

    /// The tolerance band of a parameter by its file key, `(lo, nominal, hi)` in the file's
    /// unit.
    #[must_use]
    pub fn tolerance(&self, key: &str) -> Option<(f64, f64, f64)> {
        self.tolerances
            .iter()
            .find(|t| t.key == key)
            .map(|t| (t.lo, t.nominal, t.hi))
    }

    /// The loop's own bias, cm/s²: the quadrature leak through a demodulator phase error
    /// puts the null at `θ0 = −V_q·tan(φ)/S`, where the spring and the `−P·a_PA·θ` term
    /// (with `a_pa_cm_s2` along PA) push `−(K + P·a_PA)·θ0/P` into the indicated output. It is
    /// zero for the nominal file (phase error 0).
    #[must_use]
    pub fn loop_bias_cm_s2(&self, a_pa_cm_s2: f64) -> f64 {
        if !self.has_loop {
            return 0.0;
        }
        let theta0 = -self.quadrature_v * self.phase_error_rad.tan() / self.pickoff_v_per_rad;
        let p = self.pendulosity_g_cm();
        -(self.spring_dyn_cm_rad + p * a_pa_cm_s2) * theta0 / p
    }

    /// The nominal value of candidate `id`'s term in this instrument's model equation, in
    /// the candidate's unit and sign (so that the instrument's own coefficient is this
    /// nominal value plus the change `ptsa discover` reports):
    ///
    /// * `bias`: the file's bias `A_b` (`electronics.bias_cm_s2`, or `instrument.bias_cm_s2`
    ///   without a loop), cm/s²;
    /// * `scale_factor`: `model_equation.k1_ppm`, ppm from the nominal scale factor (0 when
    ///   absent; the nominal scale factor itself is `electronics.scale_factor_cm_s2` for the
    ///   loop's pulses, [`Instrument::reading_scale`] for a raw reading);
    /// * `misalignment.delta_p_rad` (the coefficient of `a_PA`): `model_equation.delta_o_rad`;
    ///   `misalignment.delta_o_rad` (the coefficient of `a_OA`): minus
    ///   `model_equation.delta_p_rad` (the IEEE equation's `− δ_p·a_o`), rad;
    /// * `nonlinearity`, `cubic`, `vibropendulosity`, `anisoelasticity`, `cross_axis_*`:
    ///   `k2_s2_cm`, `k3_s4_cm2`, `k_ip_s2_cm`, `k_io_s2_cm`, `k_pp_s2_cm`, `k_oo_s2_cm`,
    ///   `k_po_s2_cm`;
    /// * every other candidate (dynamic terms, loop parameters): 0 (a loop parameter's
    ///   nominal is its file value, [`Instrument::get`]).
    #[must_use]
    pub fn nominal_model_term(&self, id: CandidateId) -> f64 {
        if id == CandidateId::Bias {
            self.bias_cm_s2
        } else {
            self.nominal.get(id)
        }
    }

    /// `effects` plus the nominal model-equation terms of `[model_equation]`: what the
    /// simulators put into a run (the baseline, `Effects::NONE`, becomes the nominal
    /// terms).
    #[must_use]
    pub fn with_nominal_terms(&self, effects: &Effects) -> Effects {
        let mut e = *effects;
        for (id, c) in self.nominal.nonzero() {
            e.add(id, c);
        }
        e
    }

    /// The file's name for the instrument: `instrument.name`, or for a file with a loop
    /// and no name, the PTSA loop's.
    #[must_use]
    pub fn display_name(&self) -> &str {
        self.name
            .as_deref()
            .unwrap_or(if self.has_loop { "PTSA loop" } else { "" })
    }
}

impl Instrument {
    /// The shipped instrument file named `name` ([`SHIPPED`]), parsed.
    ///
    /// # Errors
    /// An unknown name (the message lists the shipped ones).
    ///
    /// # Panics
    /// Never for a shipped file (a unit test parses each).
    pub fn shipped(name: &str) -> Result<Self, String> {
        let (path, text) = shipped(name).ok_or_else(|| {
            let names: Vec<&str> = SHIPPED.iter().map(|s| s.0).collect();
            format!(
                "`{name}` is not a shipped instrument; expected one of {}",
                names.join(", ")
            )
        })?;
        Ok(Self::parse(text, path).expect("a shipped instrument file is valid"))
    }
}

#[cfg(test)]
mod tests {
    use super::read::{line_col, user_message};
    use super::schema::{FileT, Raw};
    use super::*;
    use std::path::Path;

    /// The value of `key` (`section.name`) as written in `src`: a bare number or a table's
    /// `value`; `None` when the file leaves it out.
    fn written(src: &str, key: &str) -> Option<f64> {
        let t: toml::Table = toml::from_str(src).unwrap();
        let (section, name) = key.split_once('.').unwrap();
        let v = t.get(section)?.get(name)?;
        let v = v.get("value").unwrap_or(v);
        v.as_float()
    }

    /// The shipped file with the amplifier gain and the ADC offset given tolerances, so that
    /// every entry that can carry one does.
    fn every_entry_toleranced() -> String {
        KEARFOTT_2401_TOML.replace(
            "amplifier_gain = 100.0",
            "amplifier_gain = { value = 100.0, tol_pct = 5.0 }\nadc_offset_mv = { value = 0.5, tol_abs = 2.0 }",
        )
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
    }

    /// The table is the file: every numeric entry of the shipped file's tables (but
    /// `[plausibility]`) is in [`PARAMETERS`] once, and every entry of the table is in the
    /// file (or may be left out), read in the type its form says.
    #[test]
    fn every_entry_of_the_file_is_in_the_parameter_table_once() {
        let keys: Vec<&str> = PARAMETERS.iter().map(|p| p.key).collect();
        for (k, key) in keys.iter().enumerate() {
            assert!(!keys[..k].contains(key), "{key} is in PARAMETERS twice");
        }
        let t: toml::Table = toml::from_str(KEARFOTT_2401_TOML).unwrap();
        for (section, entries) in &t {
            if section == "plausibility" {
                continue;
            }
            for name in entries.as_table().unwrap().keys() {
                let key = format!("{section}.{name}");
                assert!(keys.contains(&key.as_str()), "{key} is not in PARAMETERS");
            }
        }
        let src = every_entry_toleranced();
        let f: FileT = toml::from_str(&src).unwrap();
        for p in PARAMETERS {
            let form = match (p.raw)(&f) {
                Raw::Param(_) => Form::Toleranced,
                Raw::Optional(_) => Form::OptionalToleranced,
                Raw::NumOrParam(_) => Form::NumberOrToleranced,
                Raw::Num(_) => Form::Number,
            };
            assert_eq!(form, p.form, "{}", p.key);
            assert!(
                written(KEARFOTT_2401_TOML, p.key).is_some() || p.form == Form::OptionalToleranced,
                "{} is not in the shipped file",
                p.key
            );
        }
    }

    /// Every parameter of the table round-trips: parse reads the file's value into the
    /// field `get` reads back, `set` then `get` gives a new value back, and for an entry
    /// that can carry a tolerance, `rewrite` writes it to the file and parse reads it back.
    /// An entry that cannot is not settable, and a changed value in the file is read.
    #[test]
    fn every_parameter_round_trips_parse_set_get_write() {
        let src = every_entry_toleranced();
        let shipped = Instrument::parse(&src, "t.toml").unwrap();
        for p in PARAMETERS {
            let v0 = written(&src, p.key).unwrap();
            assert!(close(p.get(&shipped), v0), "{}: parse", p.key);
            // A new value inside every range (away from 0 and from the nominal).
            let v = if v0 == 0.0 { 0.25 } else { v0 * 1.01 };
            let mut i = shipped.clone();
            p.set(&mut i, v);
            assert!(close(p.get(&i), v), "{}: set, get", p.key);
            if p.form.can_be_toleranced() {
                let mut j = shipped.clone();
                j.set(p.key, v).unwrap();
                assert_eq!(j, i, "{}", p.key);
                assert!(close(j.get(p.key).unwrap(), v), "{}", p.key);
                let (lo, nom, hi) = shipped.tolerance(p.key).unwrap();
                assert!(lo <= nom && nom <= hi && close(nom, v0), "{}", p.key);
                let out = Instrument::rewrite(&src, "t.toml", &[(p.key, v, "new".into())]).unwrap();
                let back = Instrument::parse(&out, "t.toml").unwrap();
                assert!(close(p.get(&back), v), "{}: rewrite", p.key);
                assert_eq!(written(&out, p.key), Some(v), "{}", p.key);
                for q in PARAMETERS.iter().filter(|q| q.key != p.key) {
                    let (a, b) = (q.get(&back), q.get(&shipped));
                    assert_eq!(a.to_bits(), b.to_bits(), "{} moved {}", p.key, q.key);
                }
            } else {
                assert!(shipped.clone().set(p.key, v).is_err(), "{}", p.key);
                assert_eq!(shipped.get(p.key), None, "{}", p.key);
                assert_eq!(shipped.tolerance(p.key), None, "{}", p.key);
                let (section, name) = p.key.split_once('.').unwrap();
                let mut t: toml::Table = toml::from_str(&src).unwrap();
                t[section][name] = toml::Value::Float(v);
                let back = Instrument::parse(&toml::to_string(&t).unwrap(), "t.toml").unwrap();
                assert!(
                    close(p.get(&back), v),
                    "{}: parse of a changed value",
                    p.key
                );
            }
        }
        // The tolerance box holds exactly the toleranced entries, in the table's order.
        let tol: Vec<&str> = shipped.tolerances.iter().map(|t| t.key).collect();
        let table: Vec<&str> = PARAMETERS
            .iter()
            .filter(|p| p.form.can_be_toleranced())
            .map(|p| p.key)
            .collect();
        assert_eq!(tol, table);
    }

    /// Each entry's range is checked under its own key, with its own expectation.
    #[test]
    fn every_parameter_is_refused_out_of_range_under_its_key() {
        let src = every_entry_toleranced();
        for p in PARAMETERS {
            let (section, name) = p.key.split_once('.').unwrap();
            let mut t: toml::Table = toml::from_str(&src).unwrap();
            let bad = toml::Value::Float(-1e9);
            match t[section][name].as_table_mut() {
                Some(table) => {
                    table.insert("value".into(), bad);
                }
                None => t[section][name] = bad,
            }
            let e = Instrument::parse(&toml::to_string(&t).unwrap(), "t.toml").unwrap_err();
            assert_eq!(
                e.message,
                format!("{} = -1000000000: expected {}", p.key, p.expected),
                "{e}"
            );
        }
    }

    #[test]
    fn rewrite_changes_only_the_named_entries() {
        let src = KEARFOTT_2401_TOML;
        let out = Instrument::rewrite(
            src,
            "k.toml",
            &[
                ("pendulum.damping_dyn_cm_s", 114_361.25, "fitted".into()),
                ("torquer.time_constant_us", 38.5, "lag fitted".into()),
            ],
        )
        .unwrap();
        let i = Instrument::parse(&out, "k.toml").unwrap();
        assert_eq!(i.get("pendulum.damping_dyn_cm_s"), Some(114_361.25));
        assert!((i.get("torquer.time_constant_us").unwrap() - 38.5).abs() < 1e-12);
        // tol_pct keeps its percentage around the new value; min/max widens to hold it.
        let (lo, _, hi) = i.tolerance("pendulum.damping_dyn_cm_s").unwrap();
        assert!((lo - 0.6 * 114_361.25).abs() < 1e-6 && (hi - 1.4 * 114_361.25).abs() < 1e-6);
        assert_eq!(
            i.tolerance("torquer.time_constant_us"),
            Some((0.2, 38.5, 38.5))
        );
        // Everything else is the same text, line for line, plus the two notes.
        let removed: Vec<&str> = src
            .lines()
            .filter(|l| !out.lines().any(|o| o == *l))
            .collect();
        assert_eq!(removed.len(), 2, "{removed:?}");
        assert!(out.contains("# fitted\ndamping_dyn_cm_s = { value = 114361.25, tol_pct = 40.0 }"));
        assert_eq!(out.lines().count(), src.lines().count() + 2);
        // No change, no difference; a refused value is an error, not a bad file.
        assert_eq!(Instrument::rewrite(src, "k.toml", &[]).unwrap(), src);
        let e = Instrument::rewrite(
            src,
            "k.toml",
            &[("pendulum.inertia_oa_g_cm2", -1.0, String::new())],
        )
        .unwrap_err();
        assert!(e.message.contains("inertia"), "{e}");
        assert!(Instrument::rewrite(src, "k.toml", &[("no.such", 1.0, String::new())]).is_err());
    }

    /// The amplifier gain is a bare number (exact, not identified) or a toleranced table;
    /// the ADC offset is optional (0 without a tolerance) or a toleranced table; both are
    /// set, read and rewritten like the other parameters.
    #[test]
    fn amplifier_gain_and_adc_offset_take_a_tolerance_when_the_file_gives_one() {
        let shipped = Instrument::kearfott_2401();
        assert_eq!(shipped.tolerance("electronics.amplifier_gain"), None);
        assert_eq!(shipped.tolerance("electronics.adc_offset_mv"), None);
        assert_eq!(shipped.get("electronics.adc_offset_mv"), Some(0.0));
        let src = KEARFOTT_2401_TOML
            .replace(
                "amplifier_gain = 100.0",
                "amplifier_gain = { value = 100.0, tol_pct = 5.0 }\nadc_offset_mv = { value = 0.5, tol_abs = 2.0 }",
            );
        let mut i = Instrument::parse(&src, "t.toml").unwrap();
        let (lo, nom, hi) = i.tolerance("electronics.amplifier_gain").unwrap();
        assert!(
            (lo - 95.0).abs() < 1e-9 && (nom - 100.0).abs() < 1e-12 && (hi - 105.0).abs() < 1e-9
        );
        assert_eq!(
            i.tolerance("electronics.adc_offset_mv"),
            Some((-1.5, 0.5, 2.5))
        );
        assert!((i.adc_offset_v - 0.5e-3).abs() < 1e-15);
        i.set("electronics.amplifier_gain", 90.0).unwrap();
        assert!((i.lsb_per_rad() / shipped.lsb_per_rad() - 0.9).abs() < 1e-12);
        let out = Instrument::rewrite(
            &src,
            "t.toml",
            &[("electronics.amplifier_gain", 97.5, "fitted".into())],
        )
        .unwrap();
        let r = Instrument::parse(&out, "t.toml").unwrap();
        assert_eq!(r.get("electronics.amplifier_gain"), Some(97.5));
        // Errors name the line and what was expected.
        let e = Instrument::parse(
            &KEARFOTT_2401_TOML.replace("amplifier_gain = 100.0", "amplifier_gain = \"high\""),
            "m.toml",
        )
        .unwrap_err();
        assert_eq!(e.line, line_of("amplifier_gain"), "{e}");
        assert!(e.message.contains("expected a number"), "{e}");
        let e = Instrument::parse(
            &KEARFOTT_2401_TOML.replace(
                "amplifier_gain = 100.0",
                "amplifier_gain = 100.0\nadc_offset_mv = { value = 4000.0, tol_abs = 1.0 }",
            ),
            "m.toml",
        )
        .unwrap_err();
        assert!(
            e.message.contains("electronics.adc_offset_mv = 4000"),
            "{e}"
        );
        assert!(e.message.contains("within the ADC's full scale"), "{e}");
    }

    #[test]
    fn shipped_file_parses_with_the_table_values() {
        let i = Instrument::kearfott_2401();
        assert!((i.pendulosity_g_cm() - 1.122).abs() < 1e-3);
        assert!((i.actual_sf_cm_s2() - 21121.1).abs() < 1e-9);
        assert!((i.theta_lsb_rad() - 76.294e-9).abs() < 1e-12);
        assert!((i.full_current_ma - 21.328).abs() < 1e-3);
        assert_eq!(i.tolerances.len(), 12);
    }

    #[test]
    fn errors_name_line_column_and_expectation() {
        let bad = KEARFOTT_2401_TOML.replace(
            "inertia_oa_g_cm2 = { value = 14.0,",
            "inertia_oa_g_cm2 = { value = -14.0,",
        );
        let e = Instrument::parse(&bad, "x.toml").unwrap_err();
        assert_eq!(e.file, "x.toml");
        let line = KEARFOTT_2401_TOML
            .lines()
            .position(|l| l.starts_with("inertia_oa_g_cm2"))
            .unwrap()
            + 1;
        assert_eq!(e.line, line, "{e}");
        assert!(e.column > 20, "{e}");
        assert!(e.message.contains("expected an inertia > 0"), "{e}");

        let typo = KEARFOTT_2401_TOML.replace("bias_cm_s2 =", "bias_cm_s =");
        let e = Instrument::parse(&typo, "y.toml").unwrap_err();
        assert!(e.message.contains("bias_cm_s"), "{e}");
        assert!(e.line > 1, "{e}");

        let syntax = KEARFOTT_2401_TOML.replace("clock_hz = 64000.0", "clock_hz = 64000.0.0");
        assert!(Instrument::parse(&syntax, "z.toml").is_err());
    }

    /// The error for the shipped file with `from` replaced by `to` (exactly once).
    fn mutated(from: &str, to: &str) -> InstrumentError {
        assert_eq!(KEARFOTT_2401_TOML.matches(from).count(), 1, "{from}");
        Instrument::parse(&KEARFOTT_2401_TOML.replace(from, to), "m.toml").unwrap_err()
    }

    /// The 1-based line of the shipped file that starts with `key`.
    fn line_of(key: &str) -> usize {
        KEARFOTT_2401_TOML
            .lines()
            .position(|l| l.starts_with(key))
            .unwrap()
            + 1
    }

    /// No Rust or serde vocabulary in a user message.
    fn assert_user_terms(e: &InstrumentError) {
        for word in [
            "f64",
            "i64",
            "i128",
            "struct",
            "Param",
            "PendulumT",
            "map",
            "sequence",
            "invalid type",
        ] {
            assert!(!e.message.contains(word), "`{word}` in: {e}");
        }
    }

    #[test]
    fn a_missing_file_is_reported_without_a_position() {
        let e = Instrument::load(Path::new("nonexist.toml")).unwrap_err();
        assert_eq!(e.position(), None);
        assert_eq!(e.file, "nonexist.toml");
        let m = e.to_string();
        assert!(m.starts_with("nonexist.toml: cannot read: "), "{m}");
        assert!(!m.contains("os error") && !m.contains(":0"), "{m}");
        #[cfg(unix)]
        assert_eq!(m, "nonexist.toml: cannot read: No such file or directory");
    }

    #[test]
    fn a_number_of_the_wrong_type_is_named_in_toml_terms() {
        let line = line_of("clock_hz");
        for (value, found) in [
            ("\"fast\"", "the string \"fast\""),
            ("true", "`true`"),
            ("[64000]", "an array"),
            ("{ value = 64000 }", "a table"),
            ("1979-05-27", "the date/time 1979-05-27"),
        ] {
            let e = mutated("clock_hz = 64000.0", &format!("clock_hz = {value}"));
            assert_eq!(
                e.message,
                format!("expected a number, found {found}"),
                "{e}"
            );
            assert_eq!(e.position(), Some((line, 12)), "{e}");
            assert_user_terms(&e);
        }
        let e = mutated(
            "time_constant_us = { value = 2.0,",
            "time_constant_us = { value = \"fast\",",
        );
        assert_eq!(
            e.to_string(),
            format!(
                "m.toml:{}:30: expected a number, found the string \"fast\"",
                line_of("time_constant_us")
            )
        );
        let e = mutated("tol_abs = 10.0", "tol_abs = \"10 %\"");
        assert_eq!(e.message, "expected a number, found the string \"10 %\"");
        // An integer is a number.
        let i = Instrument::parse(
            &KEARFOTT_2401_TOML.replace("clock_hz = 64000.0", "clock_hz = 64000"),
            "m.toml",
        )
        .unwrap();
        assert_eq!(i.clock_hz.to_bits(), 64000.0_f64.to_bits());
    }

    #[test]
    fn a_toleranced_entry_of_the_wrong_type_names_the_table_forms() {
        let e = mutated(
            "inertia_oa_g_cm2 = { value = 14.0, tol_pct = 20.0 }",
            "inertia_oa_g_cm2 = 14.0",
        );
        assert_eq!(
            e.to_string(),
            format!(
                "m.toml:{}:20: expected a table {{ value = ..., tol_pct = ... }}, \
                 {{ value = ..., tol_abs = ... }} or {{ value = ..., min = ..., max = ... }}, \
                 found the number 14.0",
                line_of("inertia_oa_g_cm2")
            )
        );
        assert_user_terms(&e);
        // A section of the wrong type.
        for (line, message) in [
            ("stops = 3", "expected a [stops] table, found the number 3"),
            (
                "pickoff = \"x\"",
                "expected a [pickoff] table, found the string \"x\"",
            ),
            (
                "pendulum = []",
                "expected a [pendulum] table, found an array of 0 values",
            ),
            (
                "electronics = [1.0]",
                "expected an [electronics] table, found an array of 1 value",
            ),
        ] {
            let e = Instrument::parse(&format!("# c\n{line}\n"), "s.toml").unwrap_err();
            assert_eq!((e.message.as_str(), e.line), (message, 2), "{e}");
            assert_user_terms(&e);
        }
    }

    #[test]
    fn serde_messages_are_reworded_in_the_file_terms() {
        assert_eq!(
            user_message("invalid type: sequence, expected a [stops] table"),
            "expected a [stops] table, found an array"
        );
        assert_eq!(
            user_message("invalid type: map, expected x, y"),
            "expected x, y, found a table"
        );
        assert_eq!(
            user_message("invalid type: integer `99` as i128, expected a number"),
            "expected a number, found the number 99"
        );
        assert_eq!(
            user_message("invalid type: boolean `false`, expected a table"),
            "expected a table, found `false`"
        );
        assert_eq!(
            user_message(" missing field `value`\n"),
            "missing field `value`"
        );
    }

    #[test]
    fn byte_order_mark_and_non_utf8_text() {
        let with_bom = format!("\u{feff}{KEARFOTT_2401_TOML}");
        assert_eq!(
            Instrument::parse(&with_bom, "b.toml").unwrap(),
            Instrument::kearfott_2401()
        );
        // Columns on the first line do not count the byte-order mark.
        let e = Instrument::parse(&format!("\u{feff}x = 1\n{KEARFOTT_2401_TOML}"), "b.toml")
            .unwrap_err();
        assert_eq!(e.position(), Some((1, 1)), "{e}");
        let mut bytes = KEARFOTT_2401_TOML.as_bytes().to_vec();
        let at = KEARFOTT_2401_TOML.find("ml = 1.12").unwrap();
        bytes[at] = 0xB5;
        let e = Instrument::parse_bytes(&bytes, "l.toml").unwrap_err();
        let (line, column) = line_col(KEARFOTT_2401_TOML, at);
        assert_eq!(
            e.to_string(),
            format!(
                "l.toml:{line}:{column}: the file is not UTF-8 text: byte 0xB5 at byte offset \
                 {at} is not valid UTF-8; expected UTF-8 text"
            )
        );
    }

    #[test]
    fn an_infinite_tolerance_band_is_refused() {
        let e = mutated("max = 20.0 }", "max = inf }");
        assert_eq!(
            e.message,
            "torquer.time_constant_us: tolerance band [0.2, inf] leaves the valid range: \
             expected a time constant > 0 µs"
        );
    }

    #[test]
    fn positions_are_found_inside_multi_byte_characters() {
        assert_eq!(line_col("aµb\nc", 2), (1, 2));
        assert_eq!(line_col("aµb\nc", 5), (2, 1));
        assert_eq!(line_col("aµb", 99), (1, 4));
    }

    /// Each shipped file parses, under its name; the two classes without a loop have no
    /// loop field, no tolerance, their reading scale and their own bounds; an unknown name
    /// is refused listing the shipped ones.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn the_shipped_instruments_parse_by_name() {
        let k = Instrument::shipped("kearfott-2401").unwrap();
        assert_eq!(k, Instrument::kearfott_2401());
        assert!(k.has_loop && k.reading_scale.is_none() && k.nominal.is_zero());
        for (name, unit, per_g, sf_ppm) in [
            ("navigation", ReadingUnit::MilliAmp, 1.33, 1e5),
            ("mems", ReadingUnit::Lsb, 16384.0, 5e4),
        ] {
            let i = Instrument::shipped(name).unwrap();
            assert!(!i.has_loop, "{name}");
            assert!(i.tolerances.is_empty(), "{name}");
            assert_eq!(i.class.as_deref(), Some(name));
            assert_eq!(i.reading_scale, Some(ReadingScale { unit, per_g }));
            assert_eq!(i.plausibility.scale_factor_ppm, sf_ppm, "{name}");
            assert_eq!(i.pendulosity_dyn_cm_per_g, 0.0);
            assert_eq!(i.loop_bias_cm_s2(500.0), 0.0);
            assert!((i.g_cm_s2 - 980.665).abs() < 1e-12);
        }
        let e = Instrument::shipped("adxl").unwrap_err();
        assert_eq!(
            e,
            "`adxl` is not a shipped instrument; expected one of kearfott-2401, navigation, mems"
        );
    }

    /// The text of the shipped MEMS file with `from` replaced by `to` (exactly once).
    fn mems_with(from: &str, to: &str) -> String {
        assert_eq!(MEMS_TOML.matches(from).count(), 1, "{from}");
        MEMS_TOML.replace(from, to)
    }

    /// The line (1-based) of `text` that starts with `key`.
    fn line_in(text: &str, key: &str) -> usize {
        text.lines().position(|l| l.starts_with(key)).unwrap() + 1
    }

    /// A file without a loop is validated like one with: every refusal names the key, the
    /// line and what was expected.
    #[test]
    fn a_file_without_a_loop_is_refused_with_its_position() {
        let cases: &[(&str, &str, &str, &str)] = &[
            (
                "reading_unit = \"LSB\"",
                "reading_unit = \"g\"",
                "reading_unit",
                "instrument.reading_unit = \"g\": a reading in g is converted by its definition; expected the unit of a scale factor: V, mA or LSB",
            ),
            (
                "reading_unit = \"LSB\"",
                "reading_unit = \"counts\"",
                "reading_unit",
                "instrument.reading_unit = \"counts\": expected one of V, mA, LSB",
            ),
            (
                "reading_unit = \"LSB\"\n",
                "",
                "scale_factor_per_g",
                "instrument.scale_factor_per_g without instrument.reading_unit: expected both",
            ),
            (
                "scale_factor_per_g = 16384.0",
                "scale_factor_per_g = -16384.0",
                "scale_factor_per_g",
                "instrument.scale_factor_per_g = -16384: expected a nominal scale factor > 0 LSB per g",
            ),
            (
                "local_gravity_cm_s2 = 980.665",
                "local_gravity_cm_s2 = 0.0",
                "local_gravity_cm_s2",
                "instrument.local_gravity_cm_s2 = 0: expected gravity > 0 cm/s²",
            ),
            (
                "k2_s2_cm = 0.0",
                "k2_s2 = 0.0",
                "k2_s2",
                "model_equation.k2_s2: not a term of the model equation; expected one of k1_ppm, delta_o_rad,",
            ),
            (
                "k2_s2_cm = 0.0",
                "delta_p_rad = 2.0",
                "delta_p_rad",
                "model_equation.delta_p_rad = 2: expected |misalignment| < 1 rad",
            ),
            (
                "k2_s2_cm = 0.0",
                "k2_s2_cm = \"small\"",
                "k2_s2_cm",
                "expected a number, found the string \"small\"",
            ),
        ];
        for (from, to, key, message) in cases {
            let text = mems_with(from, to);
            let e = Instrument::parse(&text, "m.toml").unwrap_err();
            assert!(e.message.contains(message), "{to}: {e}");
            assert_eq!(e.line, line_in(&text, key), "{to}: {e}");
            assert!(e.column >= 1, "{e}");
        }
        // Without its name or its bias: the table's first key's line.
        let e = Instrument::parse(&mems_with("bias_cm_s2 = 0.0\n", ""), "m.toml").unwrap_err();
        assert!(
            e.message
                .starts_with("instrument.bias_cm_s2: missing; a file without a PTSA loop"),
            "{e}"
        );
        assert_eq!(e.line, line_in(MEMS_TOML, "name ="), "{e}");
        // A loop's section in it: then every loop section is required.
        let e = Instrument::parse(&format!("{MEMS_TOML}\n[stops]\n"), "m.toml").unwrap_err();
        assert_eq!(
            e.message,
            "a file with a PTSA loop has [pendulum], [pickoff], [torquer], [electronics] and [stops]; [pendulum], [pickoff], [torquer], [electronics] missing (a file without a loop has none of them)"
        );
        // No [instrument] and no loop.
        let e = Instrument::parse("[plausibility]\nbias_cm_s2 = 1.0\n", "p.toml").unwrap_err();
        assert!(
            e.message
                .contains("or, for an accelerometer without one, an [instrument] table"),
            "{e}"
        );
        // A file with a loop keeps its bias and gravity in [electronics].
        let e = Instrument::parse(
            &format!("{KEARFOTT_2401_TOML}\n[instrument]\nname = \"k\"\nbias_cm_s2 = 1.0\n"),
            "k.toml",
        )
        .unwrap_err();
        assert!(
            e.message.starts_with(
                "instrument.bias_cm_s2: a file with a PTSA loop gives it as electronics.bias_cm_s2"
            ),
            "{e}"
        );
    }

    /// `[model_equation]`'s keys are the nominal values of their candidates, `δ_p` under the
    /// IEEE sign (the candidate of `a_OA` is `−δ_p`); the bias is the file's `A_b`.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn model_equation_keys_are_the_nominal_terms() {
        let mut text = format!("{KEARFOTT_2401_TOML}\n[model_equation]\n");
        for (k, m) in MODEL_EQUATION.iter().enumerate() {
            let _ =
                std::fmt::Write::write_fmt(&mut text, format_args!("{} = {}e-7\n", m.key, k + 1));
        }
        let i = Instrument::parse(&text, "k.toml").unwrap();
        for (k, m) in MODEL_EQUATION.iter().enumerate() {
            let x: f64 = format!("{}e-7", k + 1).parse().unwrap();
            assert_eq!(i.nominal_model_term(m.id), m.sign * x, "{}", m.key);
        }
        assert_eq!(
            i.nominal_model_term(CandidateId::MisalignmentO),
            -3e-7,
            "delta_p_rad"
        );
        assert_eq!(i.nominal_model_term(CandidateId::Bias), 18.7);
        assert_eq!(i.nominal_model_term(CandidateId::Anisoinertia), 0.0);
        let e = i.with_nominal_terms(&Effects::only(CandidateId::Nonlinearity, 1.0));
        assert_eq!(e.get(CandidateId::Nonlinearity), 1.0 + 4e-7);
        assert_eq!(e.get(CandidateId::Cubic), 5e-7);
    }

    /// Raw readings: units of acceleration by their definition (g with the file's local
    /// gravity), V, mA or LSB only through the file's scale in that unit.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn readings_are_converted_through_the_nominal_scale() {
        let m = Instrument::shipped("mems").unwrap();
        let g = 980.665;
        assert_eq!(m.reading_to_cm_s2(16384.0, ReadingUnit::Lsb), Ok(g));
        assert_eq!(m.reading_to_cm_s2(-0.5, ReadingUnit::G), Ok(-0.5 * g));
        assert_eq!(m.reading_to_cm_s2(9.5, ReadingUnit::MPerS2), Ok(950.0));
        assert_eq!(m.reading_to_cm_s2(3.0, ReadingUnit::CmPerS2), Ok(3.0));
        let e = m.reading_to_cm_s2(1.0, ReadingUnit::Volt).unwrap_err();
        assert!(
            e.contains("a reading in V needs a nominal scale factor in V per g"),
            "{e}"
        );
        let k = Instrument::kearfott_2401();
        let e = k.reading_to_cm_s2(1.0, ReadingUnit::MilliAmp).unwrap_err();
        assert!(
            e.contains(
                "expected instrument.reading_unit = \"mA\" and instrument.scale_factor_per_g"
            ),
            "{e}"
        );
        for u in ReadingUnit::ALL {
            assert_eq!(ReadingUnit::parse(u.name()), Some(*u));
        }
        assert_eq!(ReadingUnit::parse("m/s2"), Some(ReadingUnit::MPerS2));
        assert_eq!(ReadingUnit::parse("cm/s^2"), Some(ReadingUnit::CmPerS2));
        assert_eq!(ReadingUnit::parse("counts"), None);
    }

    /// `rewrite_model_equation` sets each term (the bias in its key; the others in
    /// `[model_equation]`, added when absent), keeps every line it does not set, and the
    /// result reads back with the new values.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values read as written, and sums exact in binary"
    )]
    fn rewrite_model_equation_sets_the_terms_and_keeps_the_rest() {
        let changes = vec![
            (CandidateId::Bias, 20.5, "fitted bias".to_string()),
            (CandidateId::ScaleFactor, 400.0, "fitted K1".to_string()),
            (CandidateId::MisalignmentO, -2.5e-4, "fitted".to_string()),
            (CandidateId::Nonlinearity, 3e-8, "fitted K2".to_string()),
        ];
        for (src, bias_key) in [
            (KEARFOTT_2401_TOML, "bias_cm_s2 = 20.5"),
            (MEMS_TOML, "bias_cm_s2 = 20.5"),
        ] {
            let out = Instrument::rewrite_model_equation(src, "f.toml", &changes).unwrap();
            let back = Instrument::parse(&out, "f.toml").unwrap();
            for (id, v, _) in &changes {
                assert_eq!(back.nominal_model_term(*id), *v, "{id}");
            }
            // δ_p is written under its own sign: the candidate's −2.5e-4 is δ_p = 2.5e-4.
            assert!(out.contains("\ndelta_p_rad = 0.00025\n"), "{out}");
            assert!(
                out.contains(&format!("# fitted bias\n{bias_key}\n")),
                "{out}"
            );
            // Every line of the source is still there, but the values set.
            let kept: Vec<&str> = out.lines().collect();
            for l in src.lines() {
                let set = l.starts_with("bias_cm_s2 = 0.0")
                    || l.starts_with("bias_cm_s2 = 18.7")
                    || l.starts_with("k2_s2_cm");
                assert!(set || kept.contains(&l), "lost: {l}");
            }
            let before = Instrument::parse(src, "f.toml").unwrap();
            assert_eq!(back.plausibility, before.plausibility);
            assert_eq!(back.tolerances, before.tolerances);
        }
        // Not a term of the model equation.
        let e = Instrument::rewrite_model_equation(
            MEMS_TOML,
            "f.toml",
            &[(CandidateId::Anisoinertia, 1.0, String::new())],
        )
        .unwrap_err();
        assert!(
            e.message.contains("not a term of the model equation"),
            "{e}"
        );
    }
}
