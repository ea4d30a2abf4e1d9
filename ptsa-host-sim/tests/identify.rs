//! The loop's own parameters identified through the closed loop from a frequency-response
//! table made with a perturbed instrument file the analysis never sees.

use ptsa_host_sim::condition::{IA, RowKind};
use ptsa_host_sim::discovery::sim::{ClosedLoopSimulator, response_of};
use ptsa_host_sim::discovery::{Options, discover, show};
use ptsa_host_sim::{CandidateId, Condition, Effects, Instrument, SimOptions};

fn table(instr: &Instrument, sigma_gain: f64, sigma_phase: f64) -> Vec<Condition> {
    let opts = SimOptions {
        seed: 99,
        ..SimOptions::default()
    };
    let freqs = [
        2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 120.0, 150.0,
        180.0, 220.0, 260.0, 300.0, 400.0,
    ];
    freqs
        .iter()
        .map(|&f| {
            let mut c = Condition {
                label: format!("{f} Hz"),
                kind: RowKind::Response,
                freq_hz: f,
                ..Condition::default()
            };
            c.lin_cm_s2[IA] = 2000.0;
            let [g, p] = response_of(instr, &c, &Effects::NONE, &opts);
            c.measured_gain = Some(g);
            c.measured_phase_deg = Some(p);
            c.sigma_gain = Some(sigma_gain);
            c.sigma_phase_deg = Some(sigma_phase);
            c
        })
        .collect()
}

#[test]
fn damping_off_by_two_tolerances_is_named() {
    let nominal = Instrument::kearfott_2401();
    let mut truth = nominal.clone();
    let c = nominal.get("pendulum.damping_dyn_cm_s").unwrap();
    truth.set("pendulum.damping_dyn_cm_s", c * 1.5).unwrap();
    let rows = table(&truth, 0.01, 0.5);
    let sim = ClosedLoopSimulator {
        instrument: nominal.clone(),
        options: SimOptions::default(),
    };
    let t0 = std::time::Instant::now();
    let d = discover(&rows, &sim, &Options::for_instrument(&nominal)).unwrap();
    eprintln!(
        "{}\n{:.2} s",
        show::text_report("response", &d),
        t0.elapsed().as_secs_f64()
    );
    let named: Vec<CandidateId> = d.selected.iter().map(|s| s.id).collect();
    assert_eq!(named.first(), Some(&CandidateId::ParamDamping), "{named:?}");
}
