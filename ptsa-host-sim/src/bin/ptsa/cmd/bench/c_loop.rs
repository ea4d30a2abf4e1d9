//! The plain C loop of `ptsa bench --compare-c` (`benches/c_static/static_loop.c`): written
//! to a temporary folder, built with the system C compiler, fed the Rust loop's constants
//! and state ([`ClosedLoop::c_static_params`]), checked once against the Rust loop bit for
//! bit (pulses and plant state), then timed.

use std::path::PathBuf;

use anyhow::{Context, Result};
use ptsa_host_sim::lab::fixtures;
use ptsa_host_sim::model::effects::Effects;
use ptsa_host_sim::model::instrument::Instrument;
use ptsa_host_sim::simulation::sim::{ClosedLoop, SimOptions};

/// The C source, compiled into the binary.
const C_STATIC_LOOP: &str = include_str!("../../../../../benches/c_static/static_loop.c");

/// The plain C loop, compiled into a temporary folder, with its parameters.
pub(super) struct CStaticLoop {
    /// The folder of the source and the executable, removed when the loop is dropped.
    _dir: tempfile::TempDir,
    exe: PathBuf,
    params: String,
    settle: u64,
    ticks: u64,
}

impl CStaticLoop {
    /// Compile the C loop and check it once against the Rust loop (pulses and plant state).
    pub(super) fn build(
        instr: &Instrument,
        opts: &SimOptions,
        accel: f64,
        ticks: u64,
    ) -> Result<Self> {
        let dir = tempfile::Builder::new()
            .prefix("ptsa-c-static-")
            .tempdir()
            .context("creating a temporary folder for the C loop")?;
        let src = dir.path().join("static_loop.c");
        let exe = dir.path().join("static_loop");
        std::fs::write(&src, C_STATIC_LOOP)
            .with_context(|| format!("writing {}", src.display()))?;
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
        let out = std::process::Command::new(&cc)
            .args(["-std=c11", "-O2", "-o"])
            .arg(&exe)
            .arg(&src)
            .output()
            .with_context(|| format!("running the C compiler `{cc}`"))?;
        anyhow::ensure!(
            out.status.success(),
            "`{cc} -std=c11 -O2` failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let cond = fixtures::along_ia(accel, instr.g_cm_s2);
        let mut l = ClosedLoop::new(instr, &cond, &Effects::NONE, opts);
        let params = l
            .c_static_params()
            .context("no C parameters for this loop")?;
        let settle = opts.warmup_ticks(instr.clock_hz);
        let c = Self {
            _dir: dir,
            exe,
            params,
            settle,
            ticks,
        };
        // The check: the same pulses over the gate and the same final plant state.
        let (_, pulses, x) = c.run_once()?;
        l.run_fast(settle);
        let p0 = l.core().total_pulses();
        l.run_fast(ticks);
        let want_pulses = u64::from((l.core().total_pulses() - p0).0);
        let want_x: Vec<String> = l
            .state()
            .iter()
            .map(|v| format!("{:016x}", v.to_bits()))
            .collect();
        anyhow::ensure!(
            pulses == want_pulses && x == want_x.join(","),
            "the C loop disagrees with the Rust loop: pulses {pulses} vs {want_pulses}, state {x} vs {}",
            want_x.join(",")
        );
        Ok(c)
    }

    /// One timed run of the C loop: ticks/s.
    pub(super) fn run(&self) -> Result<f64> {
        Ok(self.run_once()?.0)
    }

    /// One run: ticks/s, pulses over the gate, the final plant state's bits.
    fn run_once(&self) -> Result<(f64, u64, String)> {
        use std::io::Write as _;
        let mut child = std::process::Command::new(&self.exe)
            .args([self.settle.to_string(), self.ticks.to_string(), "1".into()])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .spawn()
            .context("running the C loop")?;
        child
            .stdin
            .take()
            .context("C loop stdin")?
            .write_all(self.params.as_bytes())?;
        let out = child.wait_with_output()?;
        anyhow::ensure!(out.status.success(), "the C loop failed");
        let text = String::from_utf8_lossy(&out.stdout);
        let field = |name: &str| {
            text.split_whitespace()
                .find_map(|w| w.strip_prefix(name))
                .map(str::to_owned)
                .with_context(|| format!("C loop output without {name}: {text}"))
        };
        let rate: f64 = field("rate=")?.parse()?;
        let pulses: u64 = field("pulses=")?.parse()?;
        Ok((rate, pulses, field("x=")?))
    }
}
